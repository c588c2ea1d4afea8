#!/usr/bin/env bash
# Shared set-up for the two front-door commands: installs the Debian packages the build needs
# (apt-get, as root), configures and builds. Sourced by ioct-demo and ioct-test; defines
# IOCT_ROOT, IOCT_PRESET and IOCT_BIN for them.
set -euo pipefail

IOCT_ROOT=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)

ioct_packages=(
  cmake ninja-build g++ pkg-config
  libboost-dev libfftw3-dev libpng-dev libturbojpeg0-dev libcli11-dev nlohmann-json3-dev
  libtomlplusplus-dev libhdf5-dev
  libusb-1.0-0-dev libgpiod-dev
  libgtest-dev libgmock-dev libbenchmark-dev umockdev libumockdev-dev
  chromium  # the live view's browser tests drive it headless (tests/view)
  systemd   # systemd-analyze, -sysusers, -tmpfiles: the units' tests (tests/rt, tests/unpriv)
  python3   # tools/ioct-soak
  clang libclang-rt-14-dev  # libFuzzer for the fuzz preset (tools/ioct-fuzz)
  clang-tidy  # tools/ioct-tidy (.clang-tidy)
)

ioct_install_packages() {
  local missing=()
  for p in "${ioct_packages[@]}"; do
    dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q '^install ok installed$' || missing+=("$p")
  done
  [ ${#missing[@]} -eq 0 ] && return 0
  if [ "$(id -u)" -ne 0 ]; then
    echo "ioct: these Debian packages are missing: ${missing[*]}" >&2
    echo "ioct: run this command as root (sudo) so it can install them, or install them yourself:" >&2
    echo "      apt-get install ${missing[*]}" >&2
    exit 1
  fi
  echo "ioct: installing ${missing[*]}" >&2
  export DEBIAN_FRONTEND=noninteractive
  apt-get update -qq
  apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
}

# CUDA stages are built when nvcc is there (on PATH or in the toolkit's usual place).
ioct_choose_preset() {
  if command -v nvcc >/dev/null 2>&1; then
    IOCT_PRESET=release
  elif [ -x /usr/local/cuda/bin/nvcc ]; then
    export CUDACXX=/usr/local/cuda/bin/nvcc
    IOCT_PRESET=release
  else
    IOCT_PRESET=nocuda
  fi
}

# ioct_build [preset] [target...]
ioct_build() {
  local preset=$1
  shift
  cmake --preset "$preset" -S "$IOCT_ROOT" >/dev/null
  if [ $# -gt 0 ]; then
    cmake --build --preset "$preset" --target "$@"
  else
    cmake --build --preset "$preset"
  fi
}

ioct_install_packages
ioct_choose_preset
IOCT_BIN="$IOCT_ROOT/build/$IOCT_PRESET/bin"
