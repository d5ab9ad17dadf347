#!/usr/bin/env bash
# Loom's two README commands, set-up included:
#   ./loom.sh demo   install what is missing, build (Release, -j2), run and render the default scene
#   ./loom.sh test   the same set-up, then the whole test suite (ctest, output on failure)
# Environment: LOOM_BUILD_DIR (default: build), LOOM_OUT (demo output, default: out/demo).
set -euo pipefail

here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
cd "$here"
build_dir="${LOOM_BUILD_DIR:-build}"

# Debian packages Loom builds with. Installed only when missing, so a second run installs nothing.
packages=(
  build-essential cmake pkg-config
  libeigen3-dev nlohmann-json3-dev
  libgtest-dev libgmock-dev libbenchmark-dev
  libbullet-dev libfcl-dev libccd-dev
  gnuplot-nox
  libgmp-dev libqhull-dev
  libassimp-dev assimp-testmodels
  libtinygltf-dev libosmesa6-dev libstb-dev ffmpeg
  libglfw3-dev libimgui-dev libgl1-mesa-dri xvfb xauth
  clang-14 libfuzzer-14-dev
)

install_missing() {
  local missing=()
  for p in "${packages[@]}"; do
    dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
  done
  [ ${#missing[@]} -eq 0 ] && return 0
  echo "loom.sh: installing Debian packages: ${missing[*]}"
  local sudo=()
  if [ "$(id -u)" -ne 0 ]; then
    if command -v sudo >/dev/null 2>&1; then
      sudo=(sudo)
    else
      echo "loom.sh: error: missing packages (${missing[*]}) and not root, no sudo" >&2
      exit 1
    fi
  fi
  "${sudo[@]}" env DEBIAN_FRONTEND=noninteractive apt-get update -qq
  "${sudo[@]}" env DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends "${missing[@]}"
}

configure_and_build() {
  if [ ! -f "$build_dir/CMakeCache.txt" ]; then
    cmake -S . -B "$build_dir" -DCMAKE_BUILD_TYPE=Release -DLOOM_WITH_VIEWER=ON
  fi
  cmake --build "$build_dir" -j2
}

# Issue 8. ASan + UBSan build of the test suite in build-asan (Debug, -O1 so the numeric tests finish) and
# the fast tests: everything but the stability suite and the tests that build, render or benchmark.
sanitize_build_and_test() {
  local dir="${LOOM_ASAN_DIR:-build-asan}"
  if [ ! -f "$dir/CMakeCache.txt" ]; then
    cmake -S . -B "$dir" -DCMAKE_BUILD_TYPE=Debug -DLOOM_BUILD_BENCH=OFF -DLOOM_WITH_VIEWER=OFF \
      -DCMAKE_CXX_FLAGS="-O1 -fsanitize=address,undefined -fno-sanitize-recover=all -fno-omit-frame-pointer"
  fi
  cmake --build "$dir" -j2
  ASAN_OPTIONS=detect_leaks=1:abort_on_error=1 UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1 \
    ctest --test-dir "$dir" --output-on-failure -j2 -LE stability -E "$sanitize_exclude"
}
sanitize_exclude='consumer_package|Render|Viewer|BenchAccuracy|Fabric|Refinement|Implicit|Accuracy'

# Issue 8. libFuzzer targets (tests/fuzz) built with clang-14 in build-fuzz; each runs SECONDS (default 60)
# from its seed corpus (tests/fuzz/corpus/<target>, copied to build-fuzz/corpus so the repository's seeds
# stay small). A crash stops with the reproducer's path.
fuzz_build() {
  local dir="${LOOM_FUZZ_DIR:-build-fuzz}"
  if [ ! -f "$dir/CMakeCache.txt" ]; then
    CC=clang-14 CXX=clang++-14 cmake -S . -B "$dir" -DCMAKE_BUILD_TYPE=RelWithDebInfo -DLOOM_BUILD_FUZZ=ON \
      -DLOOM_BUILD_TESTS=OFF -DLOOM_BUILD_BENCH=OFF -DLOOM_WITH_BULLET=OFF -DLOOM_WITH_VIEWER=OFF \
      -DCMAKE_CXX_FLAGS="-fsanitize=fuzzer-no-link,address,undefined -fno-sanitize-recover=all"
  fi
  cmake --build "$dir" -j2 --target loom_fuzz_scene loom_fuzz_obj
}
fuzz_run() {
  local dir="${LOOM_FUZZ_DIR:-build-fuzz}" seconds="$1"
  for t in scene obj; do
    mkdir -p "$dir/corpus/$t" "$dir/crashes/$t"
    echo "loom.sh: fuzzing the $t target for $seconds s"
    "$dir/tests/fuzz/loom_fuzz_$t" -max_total_time="$seconds" -timeout=10 -rss_limit_mb=2048 -max_len=65536 \
      -artifact_prefix="$dir/crashes/$t/" -print_final_stats=1 "$dir/corpus/$t" "tests/fuzz/corpus/$t" 2>&1 | tail -n 12
  done
}

usage() {
  cat <<'USAGE'
Usage: ./loom.sh demo | test | gallery
  demo   install missing Debian packages, build (Release, -j2), run the default scene
  test   install missing Debian packages, build, run the whole test suite (ctest); with a fuzz build
         (build-fuzz, from ./loom.sh fuzz) also a 10 s pass of each fuzz target
  test --sanitize  ASan + UBSan build (build-asan, Debug -O1) and the fast tests under it
  fuzz [SECONDS]   build the libFuzzer targets (clang-14, build-fuzz) and run each for SECONDS (60)
  gallery  render every scene in scenes/ small (GIF + last frame) into docs/gallery/ (README images)
USAGE
}

cmd="${1:-}"
case "$cmd" in
  demo)
    install_missing
    configure_and_build
    out="${LOOM_OUT:-out/demo}"
    "$build_dir/apps/loom" run --out "$out" --profile --render
    echo
    echo "loom.sh: the default scene's output is in $out/:"
    echo "  $out/frames/frame_NNNNN.obj   one OBJ per frame (open in Blender, MeshLab, ...)"
    echo "  $out/stats.csv                per-frame energies, strain and per-stage milliseconds"
    echo "  $out/summary.json             totals: frames, ms_per_frame, stages, max_strain, finite"
    echo "  $out/render/frame_NNNNN.png   rendered frames (offscreen, software OpenGL)"
    echo "  $out/render.mp4, render.gif   the video and a short GIF preview"
    ;;
  test)
    install_missing
    if [ "${2:-}" = "--sanitize" ]; then
      sanitize_build_and_test
      exit 0
    fi
    configure_and_build
    ctest --test-dir "$build_dir" --output-on-failure -j2
    if [ -x "${LOOM_FUZZ_DIR:-build-fuzz}/tests/fuzz/loom_fuzz_scene" ]; then
      fuzz_build
      fuzz_run 10
    fi
    ;;
  fuzz)
    install_missing
    fuzz_build
    fuzz_run "${2:-60}"
    ;;
  gallery)
    # README images: every shipped scene rendered small (320x240, every 2nd frame), GIF + last frame ->
    # docs/gallery/ (each GIF well under 1 MB: 4 s at 15 fps, 96 colours).
    install_missing
    configure_and_build
    mkdir -p docs/gallery
    for scene in scenes/*.json; do
      name="$(basename "$scene" .json)"
      "$build_dir/apps/loom" run "$scene" --out "out/gallery/$name" --render \
        --set 'output.formats=[]' --set 'output.render={"width": 320, "height": 240, "every": 2}'
      cp "out/gallery/$name/render.gif" "docs/gallery/$name.gif"
      last="$(ls "out/gallery/$name/render/"frame_*.png | tail -n 1)"
      cp "$last" "docs/gallery/$name.png"
    done
    echo "loom.sh: gallery images in docs/gallery/"
    ;;
  -h|--help|help)
    usage
    ;;
  *)
    usage >&2
    exit 2
    ;;
esac
