#!/usr/bin/env bash
# ctest doc_links: every relative link in README.md and docs/*.md resolves. A link [text](path) must name an
# existing file or folder (relative to the document); a link with #anchor must name a heading of its target
# (GitHub's anchors: lower case, punctuation dropped, spaces to hyphens). Links to http(s) and mailto are
# not checked. With --self-test it also proves it fails on a broken file link and on a broken anchor.
set -u
root="$1"

# anchors FILE: the GitHub anchor of every heading in FILE, one per line (fenced code blocks skipped).
anchors() {
  awk '/^```/ { fence = !fence; next } !fence && /^#+ / { sub(/^#+ +/, ""); print }' "$1" |
    tr '[:upper:]' '[:lower:]' | sed -e 's/[^a-z0-9 _-]//g' -e 's/ /-/g'
}

# check DOC...: prints one line per broken link, returns 1 if there is one.
check() {
  local bad=0 doc link path anchor dir target
  for doc in "$@"; do
    dir="$(dirname "$doc")"
    while IFS= read -r link; do
      case "$link" in http://* | https://* | mailto:*) continue ;; esac
      path="${link%%#*}"
      anchor=""
      [[ "$link" == *"#"* ]] && anchor="${link#*#}"
      if [ -z "$path" ]; then target="$doc"; else target="$dir/$path"; fi
      if [ ! -e "$target" ]; then
        echo "$doc: broken link ($path does not exist): $link"
        bad=1
      elif [ -n "$anchor" ] && [ -f "$target" ] && ! anchors "$target" | grep -qxF "$anchor"; then
        echo "$doc: broken anchor (no heading #$anchor in $target): $link"
        bad=1
      fi
    done < <(awk '/^```/ { fence = !fence; next } !fence' "$doc" | grep -oE '\]\([^)[:space:]]+\)' |
      sed -e 's/^](//' -e 's/)$//')
  done
  return "$bad"
}

if [ "${2:-}" = --self-test ]; then
  tmp="$(mktemp -d)"
  trap 'rm -rf "$tmp"' EXIT
  printf '# A Heading, with Punctuation\n[ok](#a-heading-with-punctuation) [gone](missing.md)\n' > "$tmp/a.md"
  printf '[anchor](a.md#no-such-heading)\n' > "$tmp/b.md"
  out="$(check "$tmp/a.md" "$tmp/b.md")" && { echo "FAIL: broken links passed"; exit 1; }
  grep -q 'missing.md does not exist' <<<"$out" || { echo "FAIL: missed the broken file link: $out"; exit 1; }
  grep -q 'no heading #no-such-heading' <<<"$out" || { echo "FAIL: missed the broken anchor: $out"; exit 1; }
  [ "$(wc -l <<<"$out")" -eq 2 ] || { echo "FAIL: a good link was reported: $out"; exit 1; }
  echo "self-test: a broken file link and a broken anchor are reported, good links are not"
fi

cd "$root" || exit 1
docs=(README.md docs/*.md)
if check "${docs[@]}"; then
  echo "doc links: every relative link in ${#docs[@]} documents resolves"
else
  exit 1
fi
