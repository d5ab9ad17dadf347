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
  libgmp-dev
  libtinygltf-dev libosmesa6-dev libstb-dev ffmpeg
  libglfw3-dev libimgui-dev libgl1-mesa-dri xvfb xauth
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

usage() {
  cat <<'USAGE'
Usage: ./loom.sh demo | test | gallery
  demo   install missing Debian packages, build (Release, -j2), run the default scene
  test   install missing Debian packages, build, run the whole test suite (ctest)
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
    configure_and_build
    ctest --test-dir "$build_dir" --output-on-failure -j2
    ;;
  gallery)
    # README images: every shipped scene rendered small (320x240), GIF + last frame -> docs/gallery/.
    install_missing
    configure_and_build
    mkdir -p docs/gallery
    for scene in scenes/*.json; do
      name="$(basename "$scene" .json)"
      "$build_dir/apps/loom" run "$scene" --out "out/gallery/$name" --render \
        --set 'output.formats=[]' --set 'output.render={"width": 320, "height": 240}'
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
