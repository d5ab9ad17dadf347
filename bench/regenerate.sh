#!/usr/bin/env bash
# ./loom.sh bench [NAME... | --docs]: runs the benchmarks (all, or those NAMEd) on the Release build in build/, writes
# each one's raw output to bench/results/NAME.txt (first line: the command), then splices every results file
# into docs/benchmarks.md between its markers
#   <!-- results: bench/results/NAME.txt -->  ...  <!-- /results -->
# so the document shows the current figures. Takes hours for all (the accuracy sweeps dominate); run it on a
# quiet machine. NAMEs: the keys of `benches` below; fresh_demo (root and the network: ./loom.sh demo on a
# debootstrapped Debian) runs only when named.
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$here"
build="${LOOM_BUILD_DIR:-build}"
loom="$build/apps/loom"
tmp_out="$(mktemp -d)"
trap 'rm -rf "$tmp_out"' EXIT

declare -A benches=(
  [collision_20k_50k]="$build/bench/loom_bench_collision --benchmark_counters_tabular=true"
  [character_clips]="$build/bench/loom_bench_character_clips"
  [hybrid_character]="$build/bench/loom_bench_hybrid_character"
  [garment_crowd]="$build/bench/loom_bench_garment_crowd"
  [bullet_cloth]="$build/bench/loom_bench_bullet_cloth --benchmark_min_time=0.01"
  [step]="$build/bench/loom_bench_step --benchmark_repetitions=3 --benchmark_report_aggregates_only=true"
  [realtime]="$loom bench realtime --out $tmp_out/realtime"
  [accuracy]="$loom bench accuracy --sizes 32,64 --threads 1 --out $tmp_out/accuracy"
  [fresh_demo]="bench/fresh_demo.sh"
  [threads_n128]="env -u OMP_WAIT_POLICY $loom bench accuracy --sizes 128 --threads 1,2 --out $tmp_out/threads"
)
names=("$@")
if [ "${1:-}" = --docs ]; then names=(); fi  # --docs: only splice the current results into the document
[ ${#names[@]} -eq 0 ] && [ "${1:-}" != --docs ] && names=(step collision_20k_50k bullet_cloth hybrid_character garment_crowd character_clips realtime accuracy threads_n128)

for name in "${names[@]+"${names[@]}"}"; do
  cmd="${benches[$name]:-}"
  if [ -z "$cmd" ]; then
    echo "bench/regenerate.sh: unknown benchmark '$name' (known: ${!benches[*]})" >&2
    exit 2
  fi
  first_word="${cmd%% *}"
  [ "$first_word" = env ] && first_word="$loom"
  if [ ! -x "$first_word" ]; then
    echo "bench/regenerate.sh: $name: $first_word is not built (./loom.sh test builds it); skipped" >&2
    continue
  fi
  echo "bench/regenerate.sh: running $name: $cmd"
  out="bench/results/$name.txt"
  {
    echo "# $cmd"
    echo "# $(date -u +%Y-%m-%dT%H:%MZ), $(nproc) cores, load average $(cut -d' ' -f1-3 /proc/loadavg)"
    $cmd 2>&1
  } > "$out.partial"
  mv "$out.partial" "$out"
  # Sweeps that write a CSV and a plot into their --out folder keep those beside the log.
  for f in "$tmp_out/$name"/*.csv "$tmp_out/$name"/*.png; do
    [ -e "$f" ] || continue
    base="$(basename "$f")"
    case "$base" in "$name"*) cp "$f" "bench/results/$base" ;; *) cp "$f" "bench/results/${name}_$base" ;; esac
  done
done

# Splice each results file between its markers in docs/benchmarks.md.
doc=docs/benchmarks.md
awk '
  /<!-- results: [^ ]+ -->/ {
    print
    match($0, /results: [^ ]+/)
    file = substr($0, RSTART + 9, RLENGTH - 9)
    print "```"
    while ((getline line < file) > 0) print line
    close(file)
    print "```"
    skip = 1
    next
  }
  /<!-- \/results -->/ { skip = 0 }
  !skip { print }
' "$doc" > "$doc.partial"
mv "$doc.partial" "$doc"
echo "bench/regenerate.sh: results in bench/results/, docs/benchmarks.md updated"
