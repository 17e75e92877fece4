#!/usr/bin/env bash
# One entry point behind the README's two commands:
#   ./quickstart.sh render   install missing Debian packages, build, render the default scene
#   ./quickstart.sh test     install missing Debian packages, build, run the whole test suite
# Idempotent and non-interactive; needs root (or sudo) only when a package is missing.
set -euo pipefail
cd "$(dirname "$0")"

PACKAGES=(
  cmake ninja-build g++ pkg-config
  libembree-dev libtbb-dev
  libopenimageio-dev libopenexr-dev libopencolorio-dev
  openimageio-tools  # Debian's OpenImageIO CMake config imports iconvert, oiiotool, ... from here
  python3-imath   # Debian's Imath CMake config references its Python binding library
  libtinygltf-dev libpugixml-dev
  libcli11-dev libfmt-dev libgtest-dev libgmock-dev libbenchmark-dev
  libdraco-dev                 # KHR_draco_mesh_compression in glTF files
  libopenmpi-dev openmpi-bin   # optional at configure time: mpirun renders across machines
  time                         # /usr/bin/time: the memory benchmarks' peak-RSS measurements
)
BUILD_DIR=${PT_BUILD_DIR:-build}
JOBS=${PT_JOBS:-$(nproc)}

install_missing() {
  local missing=()
  for p in "${PACKAGES[@]}"; do
    dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
  done
  [ ${#missing[@]} -eq 0 ] && return 0
  echo "quickstart: installing missing Debian packages: ${missing[*]}" >&2
  local sudo=""
  if [ "$(id -u)" -ne 0 ]; then
    command -v sudo >/dev/null || { echo "quickstart: need root to install ${missing[*]}" >&2; exit 2; }
    sudo=sudo
  fi
  $sudo env DEBIAN_FRONTEND=noninteractive apt-get update -qq
  $sudo env DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends "${missing[@]}"
}

build() {
  cmake -S . -B "$BUILD_DIR" -G Ninja -DCMAKE_BUILD_TYPE=Release >/dev/null
  cmake --build "$BUILD_DIR" -j "$JOBS"
}

case "${1:-}" in
  packages)
    # The install list, one a line: tests/deps checks that every file CMake imports is
    # owned by one of these packages or by one of their dependencies.
    printf '%s\n' "${PACKAGES[@]}"
    ;;
  render)
    install_missing
    build
    mkdir -p out
    "$BUILD_DIR"/tools/pathtracer -r 480 360 -s 64 -l 4 -m 5 -f out/cornell.png scenes/cornell.dae
    echo "quickstart: rendered scenes/cornell.dae to $(pwd)/out/cornell.png"
    ;;
  test)
    install_missing
    build
    ctest --test-dir "$BUILD_DIR" --output-on-failure -j "$JOBS" --timeout 900
    ;;
  *)
    echo "usage: $0 render|test|packages" >&2
    exit 2
    ;;
esac
