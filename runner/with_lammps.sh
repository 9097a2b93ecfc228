#!/usr/bin/env bash
# Runs one of the runner's side-by-side scripts after installing what it needs (LAMMPS and Open MPI from
# Debian's packages, the Python environment):  bash runner/with_lammps.sh compare_lammps.py [options]
set -euo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/setup.sh"
grains_apt_packages+=(lammps openmpi-bin)
grains_setup
script="$1"
shift
"$GRAINS_VENV/bin/python" "$GRAINS_ROOT/runner/$script" "$@"
