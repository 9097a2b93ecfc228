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

# Debian 12's SUNDIALS is compiled without optimisation: its packaging passes -DCMAKE_C_FLAGS=-fcommon, which
# takes the place of the usual -O2, and every vector operation of CVODE's goes through the stack. Built here
# at -O2 from the same source package, CVODE took a third of the processor time it takes in Debian's build, with
# bit-identical results (docs/speed.md, "CVODE"). Built once per build folder; when the source cannot be fetched
# or built, the engine links the system's SUNDIALS as before, and says so here.
GRAINS_SUNDIALS="$GRAINS_BUILD/sundials"
GRAINS_SUNDIALS_CMAKE="$GRAINS_SUNDIALS/lib/cmake/sundials"   # its package configuration, which CMake is given

# A build folder configured for a build type other than Release (a developer's checked build, README "Checked
# builds") is built as it is configured: the setup made it a Release build and built SUNDIALS into it when a test
# ran runner/main.sh against it.
grains_other_build() {
  [ -f "$GRAINS_BUILD/CMakeCache.txt" ] \
    && [ "$(sed -n 's/^CMAKE_BUILD_TYPE:[A-Z]*=//p' "$GRAINS_BUILD/CMakeCache.txt")" != "Release" ]
}

grains_build_sundials() {
  [ -f "$GRAINS_SUNDIALS_CMAKE/SUNDIALSConfig.cmake" ] && return 0
  grains_other_build && return 0
  local work="$GRAINS_BUILD/sundials-source" version
  # Tried once: a machine that cannot fetch the source would otherwise try again at every command.
  if [ -f "$work/failed" ]; then
    echo "grains: linking the system's SUNDIALS, unoptimised (building it failed before: $work/log; remove $work to try again)" >&2
    return 0
  fi
  version="$(dpkg-query -W -f='${source:Version}' libsundials-dev 2>/dev/null)" || version=""
  rm -rf "$work" && mkdir -p "$work/sources" "$work/lists/partial" "$work/cache/archives/partial"
  # The source twins (deb-src) of the system's Debian archive entries, in apt state of our own.
  local f
  for f in /etc/apt/sources.list.d/*.sources; do
    [ -f "$f" ] && grep -q "debian-archive-keyring" "$f" && sed -E 's/^Types:.*/Types: deb-src/' "$f" >"$work/sources/$(basename "$f")"
  done
  [ -f /etc/apt/sources.list ] && { grep -E '^deb ' /etc/apt/sources.list | sed 's/^deb /deb-src /' >"$work/sources/system.list" || true; }
  local apt=(apt-get -q -o Dir::Etc::SourceList=/dev/null -o Dir::Etc::SourceParts="$work/sources"
             -o Dir::State::Lists="$work/lists" -o Dir::Cache="$work/cache" -o APT::Sandbox::User=root)
  echo "grains: building SUNDIALS ${version:-?} at -O2 from Debian's source package (once, in $GRAINS_SUNDIALS)" >&2
  if [ -n "$version" ] && "${apt[@]}" update >"$work/log" 2>&1 \
     && (cd "$work" && "${apt[@]}" source --download-only "sundials=$version" >>"$work/log" 2>&1) \
     && tar -xf "$work"/sundials_*.orig.tar.* -C "$work" \
     && cmake -S "$(find "$work" -mindepth 1 -maxdepth 1 -type d -name 'sundials-*' | head -n 1)" -B "$work/build" \
          -DCMAKE_BUILD_TYPE=None -DCMAKE_C_FLAGS="-O2 -fcommon" -DCMAKE_POSITION_INDEPENDENT_CODE=ON \
          -DBUILD_SHARED_LIBS=OFF -DBUILD_STATIC_LIBS=ON -DBUILD_ARKODE=OFF -DBUILD_CVODES=OFF -DBUILD_IDA=OFF \
          -DBUILD_IDAS=OFF -DBUILD_KINSOL=OFF -DEXAMPLES_ENABLE_C=OFF -DEXAMPLES_ENABLE_CXX=OFF \
          -DCMAKE_INSTALL_PREFIX="$GRAINS_SUNDIALS" -DCMAKE_INSTALL_LIBDIR=lib >>"$work/log" 2>&1 \
     && cmake --build "$work/build" -j "$(nproc)" >>"$work/log" 2>&1 \
     && cmake --install "$work/build" >>"$work/log" 2>&1; then
    rm -rf "$work"
  else
    rm -rf "$GRAINS_SUNDIALS"
    touch "$work/failed"
    echo "grains: could not build SUNDIALS (log: $work/log): linking the system's, unoptimised" >&2
  fi
}

grains_build() {
  local sundials=() type=(-DCMAKE_BUILD_TYPE=Release)
  [ -f "$GRAINS_SUNDIALS_CMAKE/SUNDIALSConfig.cmake" ] && sundials=(-DSUNDIALS_DIR="$GRAINS_SUNDIALS_CMAKE")
  grains_other_build && type=()
  cmake -S "$GRAINS_ROOT" -B "$GRAINS_BUILD" "${type[@]}" "${sundials[@]}" >/dev/null
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
  grains_build_sundials
  grains_build
}
