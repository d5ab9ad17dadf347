#!/usr/bin/env bash
# bench/fresh_demo.sh: how long `./loom.sh demo` takes on a fresh Debian machine, packages included.
# Builds a minimal Debian 12 (bookworm) with debootstrap in a new folder under ${TMPDIR:-/var/tmp}, clones this
# repository's HEAD into it (uncommitted changes are not measured), and runs `time ./loom.sh demo` there under
# chroot: apt-get update and install, configure, build, the default scene with its render, `loom compare`.
# Prints what the demo printed after its build, apt's start and end times and the total. Needs root, debootstrap and the
# network; run it on a quiet machine (other jobs slow the compiler). The folder it made is removed at the end,
# after its mounts are released; nothing else is touched.
# Environment: LOOM_DEBIAN_MIRROR (default http://deb.debian.org/debian), LOOM_DEBIAN_SUITE (default bookworm).
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
if [ "$(id -u)" -ne 0 ]; then
  echo "bench/fresh_demo.sh: error: needs root (debootstrap, chroot, mount)" >&2
  exit 1
fi
command -v debootstrap >/dev/null 2>&1 || {
  echo "bench/fresh_demo.sh: error: debootstrap not found (Debian package: debootstrap)" >&2
  exit 1
}

root="$(mktemp -d "${TMPDIR:-/var/tmp}/loom-fresh-demo.XXXXXX")"
mounted=()
cleanup() {
  local failed=0
  for ((i = ${#mounted[@]} - 1; i >= 0; i--)); do
    umount -R "${mounted[$i]}" || failed=1
  done
  # A folder with a mount still inside is left alone: removing it would reach the host's /dev, /proc or /sys.
  if [ "$failed" -eq 0 ] && ! grep -q " $root/" /proc/mounts; then
    rm -rf "$root"
  else
    echo "bench/fresh_demo.sh: mounts remain under $root; not removed" >&2
  fi
}
trap cleanup EXIT

suite="${LOOM_DEBIAN_SUITE:-bookworm}"
echo "# debootstrap --variant=minbase $suite (not timed)"
debootstrap --variant=minbase "$suite" "$root" "${LOOM_DEBIAN_MIRROR:-http://deb.debian.org/debian}" >/dev/null
chroot "$root" apt-get clean
cp /etc/resolv.conf "$root/etc/resolv.conf"
for m in proc sys dev; do
  case "$m" in
    proc) mount -t proc proc "$root/proc" ;;
    sys) mount -t sysfs sys "$root/sys" ;;
    dev) mount --rbind /dev "$root/dev" ;;
  esac
  mounted+=("$root/$m")
done
git clone -q "$here" "$root/root/loom"
echo "# commit $(git -C "$here" rev-parse --short HEAD), $(nproc) cores, load average $(cut -d' ' -f1-3 /proc/loadavg)"

# The demo's full output (apt, compiler) goes to a log beside the folder; what it printed after the build is
# shown, the whole log only when it fails.
log="$root.log"
start=$(date +%s)
if ! chroot "$root" env -i HOME=/root PATH=/usr/sbin:/usr/bin:/sbin:/bin LANG=C.UTF-8 \
  bash -c 'cd /root/loom && ./loom.sh demo' >"$log" 2>&1; then
  cat "$log"
  rm -f "$log"
  echo "bench/fresh_demo.sh: error: ./loom.sh demo failed on the fresh machine" >&2
  exit 1
fi
end=$(date +%s)
sed -n '/^loom: rendered/,$p' "$log"
rm -f "$log"
echo
echo "# apt (from the fresh machine's /var/log/apt/history.log):"
grep -E '^(Start-Date|End-Date)' "$root/var/log/apt/history.log" | sed 's/^/#   /'
echo "# ./loom.sh demo on a fresh $suite: $((end - start)) s in all (packages, build, run)"
