#!/usr/bin/env bash
# Loom's two README commands, set-up included:
#   ./loom.sh demo   install what is missing, build (Release, -j2), run and render the default scene
#   ./loom.sh test   the same set-up, then the whole test suite (ctest, output on failure)
# Environment: LOOM_BUILD_DIR (default: build), LOOM_OUT (demo output, default: out/demo).
set -euo pipefail

here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
cd "$here"
build_dir="${LOOM_BUILD_DIR:-build}"

# Debian packages, installed only when missing (a second run installs nothing). The demo needs the first two
# lists only (the video list is installed in the background while the demo builds); the test suite (GoogleTest, benchmarks, the viewer under Xvfb, clang sanitizers and fuzzers, the
# format check, assimp's test models) adds the second.
demo_packages=(
  build-essential cmake pkg-config
  libeigen3-dev nlohmann-json3-dev
  libbullet-dev libfcl-dev libccd-dev libgmp-dev libqhull-dev
  libassimp-dev zlib1g-dev
  libosmesa6-dev libstb-dev
)
# Only the renderer's last step (PNG frames -> MP4/GIF) runs ffmpeg; it is the biggest download of the demo.
video_packages=(ffmpeg)
test_packages=(
  libgtest-dev libgmock-dev libbenchmark-dev
  gnuplot-nox assimp-testmodels libtinygltf-dev
  libglfw3-dev libimgui-dev libgl1-mesa-dri xvfb xauth
  clang-14 libfuzzer-14-dev libomp-14-dev clang-format-14
)
packages=("${demo_packages[@]}" "${video_packages[@]}")

# install_missing [PACKAGE...]: apt-get install those of the packages (default: $packages) not installed.
install_missing() {
  local missing=()
  [ $# -gt 0 ] || set -- "${packages[@]}"
  for p in "$@"; do
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

# ccache, when the machine has it, makes a rebuild after a small change cheap.
launcher=()
command -v ccache >/dev/null 2>&1 && launcher=(-DCMAKE_CXX_COMPILER_LAUNCHER=ccache)

# configure_and_build demo|test: the demo configures without tests and benchmarks and builds the `loom`
# program alone; the test suite turns them (and the viewer) on and builds everything.
configure_and_build() {
  if [ "$1" = demo ]; then
    if [ ! -f "$build_dir/CMakeCache.txt" ]; then
      cmake -S . -B "$build_dir" -DCMAKE_BUILD_TYPE=Release -DLOOM_BUILD_TESTS=OFF -DLOOM_BUILD_BENCH=OFF \
        "${launcher[@]}"
    fi
    cmake --build "$build_dir" -j2 --target loom
  else
    cmake -S . -B "$build_dir" -DCMAKE_BUILD_TYPE=Release -DLOOM_BUILD_TESTS=ON -DLOOM_BUILD_BENCH=ON \
      -DLOOM_WITH_VIEWER=ON "${launcher[@]}"
    cmake --build "$build_dir" -j2
  fi
}

# The format check: every tracked C++ file (or the files named) against .clang-format; lists the files
# clang-format would change and fails when there is one.
format_check() {
  local files=("$@")
  if [ ${#files[@]} -eq 0 ]; then
    mapfile -t files < <(git ls-files '*.cpp' '*.h' | grep -v '^tests/data/')
  fi
  local bad=()
  for f in "${files[@]}"; do
    clang-format-14 --style=file --dry-run --Werror "$f" >/dev/null 2>&1 || bad+=("$f")
  done
  if [ ${#bad[@]} -gt 0 ]; then
    echo "loom.sh: these files do not follow .clang-format (run ./loom.sh format):" >&2
    printf '  %s\n' "${bad[@]}" >&2
    return 1
  fi
  echo "loom.sh: format check: ${#files[@]} files follow .clang-format"
}

# One clang-14 build in build-asan serves the sanitizers and the fuzzers (one build of the
# libraries instead of two): every library and the fast test executables with ASan + UBSan at -O1 (-g1:
# line tables for the reports), the code also with libFuzzer's coverage hooks (fuzzer-no-link) so the fuzz
# targets (tests/fuzz) link against the same objects. No Bullet, viewer or benchmarks: the fast tests do not
# use them. Fast tests: the cloth, collision, scene, export and CLI executables (ctest label = executable),
# minus the slow ones below.
asan_dir="${LOOM_ASAN_DIR:-build-asan}"
asan_suites='loom_(cloth|collision|scene|export|cli)_tests'
# Tests that take more than a few seconds under ASan (docs/validation.md, "Bad input, sanitizers, fuzzing");
# they run in the normal (Release) suite.
asan_exclude='Fabric|Buckling|Refinement|ImplicitHardCases|StaticSolver|BendingEnergyIsResolution|StrainLimitedRun|TethersHold|PinnedVerticesFollowTheirPath|FixedPointIsTheBackwardEulerStep|ChebyshevReaches|HangingSheetSettles|Xpbd|PinsFollowTheirTargetsExactly|ResultsDoNotDependOnTheThreadCount|Accuracy|CollisionScenes|Census|Compare|Sigint|ResumeIsBitIdentical|FrameNamesPast|consumer_package|FlagInWindScene|PillowScene'
asan_build() {
  if [ ! -f "$asan_dir/CMakeCache.txt" ]; then
    CC=clang-14 CXX=clang++-14 cmake -S . -B "$asan_dir" -DCMAKE_BUILD_TYPE=Debug -DCMAKE_CXX_FLAGS_DEBUG=-g1 \
      -DLOOM_BUILD_FUZZ=ON -DLOOM_BUILD_BENCH=OFF -DLOOM_WITH_BULLET=OFF -DLOOM_WITH_VIEWER=OFF \
      -DCMAKE_CXX_FLAGS="-O1 -fsanitize=address,undefined,fuzzer-no-link -fno-sanitize-recover=all -fno-omit-frame-pointer"
  fi
  cmake --build "$asan_dir" -j2 --target "$@" loom_fuzz_scene loom_fuzz_obj loom_fuzz_bvh loom_fuzz_checkpoint
}
# What CI runs under the sanitizers (from `./loom.sh test`): the scene, export and CLI executables (the CLI
# tests drive the sanitized `loom` binary through the bad-input table, hostile output folders, checkpoints and exports). The
# cloth and collision test executables under ASan are `./loom.sh test --sanitize` only: their build and run
# (about 20 min measured on a loaded 2-core machine) would more than double CI's time.
asan_ci_targets=(loom_scene_tests loom_export_tests loom_cli_tests)
asan_all_targets=(loom_cloth_tests loom_collision_tests "${asan_ci_targets[@]}")
sanitize_test() {
  local suites="$1"
  ASAN_OPTIONS=detect_leaks=1:abort_on_error=1:strict_string_checks=1 LSAN_OPTIONS="suppressions=$here/tests/lsan.supp" \
  UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1 \
    ctest --test-dir "$asan_dir" --output-on-failure -j2 -L "$suites" -E "$asan_exclude"
}

# libFuzzer targets (tests/fuzz: scene parser, OBJ loader, BVH loader, checkpoint readers), each run SECONDS
# from its seed corpus (tests/fuzz/corpus/<target>; new inputs go to build-asan/corpus/<target> so the repository's
# seeds stay small). A crash fails with the reproducer's path under build-asan/crashes/<target>/.
fuzz_run() {
  local seconds="$1"
  for t in scene obj bvh checkpoint; do
    mkdir -p "$asan_dir/corpus/$t" "$asan_dir/crashes/$t"
    echo "loom.sh: fuzzing the $t target for $seconds s"
    ASAN_OPTIONS=detect_leaks=1 LSAN_OPTIONS="suppressions=$here/tests/lsan.supp" "$asan_dir/tests/fuzz/loom_fuzz_$t" -max_total_time="$seconds" -timeout=10 \
      -rss_limit_mb=2048 -max_len=65536 -artifact_prefix="$asan_dir/crashes/$t/" -print_final_stats=1 \
      "$asan_dir/corpus/$t" "tests/fuzz/corpus/$t" 2>&1 | tail -n 12
  done
}

usage() {
  cat <<'USAGE'
Usage: ./loom.sh demo | test | bench | fuzz | format | gallery
  demo   install missing Debian packages, build (Release, -j2), run the default scene
  test   install missing Debian packages, build, run the whole test suite (ctest); then (what CI runs)
         the ASan + UBSan build (clang-14, build-asan), the fast tests under it and 15 s of each fuzz target
  test --sanitize  only the ASan + UBSan build and the fast tests under it
  fuzz [SECONDS]   build the libFuzzer targets (build-asan) and run each for SECONDS (60)
  bench [NAME...|--docs]  run the benchmarks (all or NAMEd) into bench/results/, update docs/benchmarks.md
  format [--check] [FILES]  apply (or check) .clang-format on every tracked C++ file or FILES
  gallery  render every scene in scenes/ small (GIF + last frame) into docs/gallery/ (README images)
USAGE
}

cmd="${1:-}"
case "$cmd" in
  demo)
    install_missing "${demo_packages[@]}"
    # ffmpeg downloads and unpacks while the compiler runs; the run waits for it before rendering.
    mkdir -p "$build_dir"
    video_log="$build_dir/apt-video.log"
    install_missing "${video_packages[@]}" >"$video_log" 2>&1 &
    video_pid=$!
    configure_and_build demo
    if ! wait "$video_pid"; then
      cat "$video_log" >&2
      echo "loom.sh: error: installing ${video_packages[*]} failed (log: $video_log)" >&2
      exit 1
    fi
    out="${LOOM_OUT:-out/demo}"
    # loom run owns its output folder (docs/guarantees.md): out/demo is reused by its manifest; a folder of
    # the default name left by a loom without manifests is this script's own, so it may be overwritten.
    overwrite=()
    if [ -z "${LOOM_OUT:-}" ] && [ -d "$out" ] && [ ! -f "$out/.loom-manifest" ]; then overwrite=(--overwrite); fi
    "$build_dir/apps/loom" run --out "$out" --profile --render "${overwrite[@]}"
    # What the same character costs in Bullet's own soft body, in the same process and on the same rig:
    # `loom compare` runs the scene's first 2 s in Loom and in Bullet classic and prints both.
    if [ -z "${LOOM_OUT:-}" ]; then
      echo
      echo "loom.sh: the default scene beside Bullet classic (loom compare, first 2 s):"
      "$build_dir/apps/loom" compare scenes/character_layers.json --out out/demo_compare --frames 120 || true
    fi
    echo
    echo "loom.sh: the default scene's output is in $out/:"
    echo "  $out/frames/frame_NNNNN.obj   one OBJ per frame (open in Blender, MeshLab, ...)"
    echo "  $out/stats.csv                per-frame energies, strain and per-stage milliseconds"
    echo "  $out/summary.json             totals: frames, ms_per_frame, stages, max_strain, finite"
    echo "  $out/render/frame_NNNNN.png   rendered frames (offscreen, software OpenGL)"
    echo "  $out/render.mp4, render.gif   the video and a short GIF preview"
    ;;
  test)
    packages+=("${test_packages[@]}")
    install_missing
    if [ "${2:-}" = "--sanitize" ]; then
      asan_build "${asan_all_targets[@]}"
      sanitize_test "$asan_suites"
      exit 0
    fi
    format_check
    configure_and_build test
    ctest --test-dir "$build_dir" --output-on-failure -j2
    # The sanitizer pass and a short fuzz pass (LOOM_SKIP_SANITIZE=1 skips both, e.g. for a quick
    # local run).
    if [ "${LOOM_SKIP_SANITIZE:-0}" != 1 ]; then
      asan_build "${asan_ci_targets[@]}"
      fuzz_run "${LOOM_FUZZ_SECONDS:-15}"
      sanitize_test 'loom_(scene|export|cli)_tests'
    fi
    ;;
  fuzz)
    packages+=("${test_packages[@]}")
    install_missing
    asan_build
    fuzz_run "${2:-60}"
    ;;
  bench)
    # ./loom.sh bench [NAME... | --docs]: run the benchmarks into bench/results/ and splice them into
    # docs/benchmarks.md (bench/regenerate.sh).
    packages+=("${test_packages[@]}")
    install_missing
    shift
    [ "${1:-}" = --docs ] || configure_and_build test
    bash bench/regenerate.sh "$@"
    ;;
  format)
    # ./loom.sh format [--check] [FILES...]: apply .clang-format to every tracked C++ file (or FILES), or
    # check.
    shift
    if [ "${1:-}" = --check ]; then
      shift
      format_check "$@"
    else
      if [ $# -eq 0 ]; then mapfile -t files < <(git ls-files '*.cpp' '*.h' | grep -v '^tests/data/'); else files=("$@"); fi
      clang-format-14 --style=file -i "${files[@]}"
    fi
    ;;
  gallery)
    # README images: every shipped scene rendered small (320x240, every 2nd frame), GIF + last frame ->
    # docs/gallery/ (each GIF well under 1 MB: 4 s at 15 fps, 96 colours).
    install_missing
    configure_and_build demo
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
