#!/usr/bin/env bash
# ctest format_check: `./loom.sh format --check` fails on a file that does not follow .clang-format, names it,
# and passes on one that does. The files are written to a temporary folder beside a copy of .clang-format.
set -u
root="$1"
tmp="$(mktemp -d)"
trap 'rm -rf "$tmp"' EXIT
cp "$root/.clang-format" "$tmp/"
printf 'int  main( ){return 0;}\n' > "$tmp/misformatted.cpp"
printf 'int main() { return 0; }\n' > "$tmp/formatted.cpp"
if out="$(bash "$root/loom.sh" format --check "$tmp/misformatted.cpp" 2>&1)"; then
  echo "FAIL: the format check accepted a misformatted file"
  exit 1
fi
if ! grep -q misformatted.cpp <<<"$out"; then
  echo "FAIL: the format check did not name the misformatted file: $out"
  exit 1
fi
if ! bash "$root/loom.sh" format --check "$tmp/formatted.cpp"; then
  echo "FAIL: the format check rejected a formatted file"
  exit 1
fi
echo "format check: rejects and names misformatted.cpp, accepts formatted.cpp"
