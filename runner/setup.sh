#!/usr/bin/env bash
# Installs what grains needs (Debian packages, a Python virtual environment) and builds it.
# Sourced by runner/main.sh and tests/run.sh; safe to run again: it only installs what is missing.
set -euo pipefail
GRAINS_ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
GRAINS_BUILD="${GRAINS_BUILD:-$GRAINS_ROOT/build}"
GRAINS_VENV="${GRAINS_VENV:-$GRAINS_ROOT/.venv}"

grains_apt_packages=(g++ make cmake libeigen3-dev libsundials-dev libhdf5-dev hdf5-tools catch2
                     libtomlplusplus-dev libcli11-dev libfmt-dev python3-venv)

grains_install_system() {
  local missing=()
  for p in "${grains_apt_packages[@]}"; do
    dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
  done
  command -v cmake >/dev/null && missing=("${missing[@]/cmake}")
  # A python3 that can make a virtual environment with pip needs no python3-venv (one not from Debian, say);
  # Debian's python3 without that package lacks ensurepip, and `python3 -m venv` fails (a fresh Debian 12 did).
  python3 -c "import ensurepip, venv" 2>/dev/null && missing=("${missing[@]/python3-venv}")
  local real=()
  for p in "${missing[@]}"; do [ -n "$p" ] && real+=("$p"); done
  [ ${#real[@]} -eq 0 ] && return 0
  echo "grains: installing Debian packages: ${real[*]}" >&2
  local sudo=""
  [ "$(id -u)" -ne 0 ] && sudo="sudo"
  $sudo apt-get update -q >/dev/null
  DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -q "${real[@]}" >/dev/null
}

grains_install_python() {
  # Without pip the environment is a failed creation's remains (python3 -m venv without ensurepip): made anew.
  if [ ! -x "$GRAINS_VENV/bin/python" ] || [ ! -x "$GRAINS_VENV/bin/pip" ]; then
    echo "grains: creating Python environment in $GRAINS_VENV" >&2
    python3 -m venv --clear "$GRAINS_VENV"
  fi
  if ! "$GRAINS_VENV/bin/python" -c "import numpy, h5py, matplotlib, pytest, scipy, fmpy, dask" 2>/dev/null; then
    "$GRAINS_VENV/bin/pip" install -q --disable-pip-version-check -r "$GRAINS_ROOT/runner/requirements.txt"
  fi
}

grains_build() {
  cmake -S "$GRAINS_ROOT" -B "$GRAINS_BUILD" -DCMAKE_BUILD_TYPE=Release >/dev/null
  # The compiler's diagnostics only (not file names that hold "error"); a failed build stops here, even
  # when an older binary is still in place.
  local log="$GRAINS_BUILD/build.log"
  if ! cmake --build "$GRAINS_BUILD" -j "$(nproc)" -- --no-print-directory >"$log" 2>&1; then
    tail -n 40 "$log" >&2
    echo "grains: build failed (whole log: $log)" >&2
    exit 1
  fi
  grep -E "(warning|error):" "$log" || true
  test -x "$GRAINS_BUILD/runner/grains" || { echo "grains: build failed" >&2; exit 1; }
}

grains_setup() {
  grains_install_system
  grains_install_python
  grains_build
}
