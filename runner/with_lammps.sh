#!/usr/bin/env bash
# Runs one of the runner's side-by-side scripts after installing what it needs (LAMMPS and Open MPI from
# Debian's packages, the Python environment):  bash runner/with_lammps.sh compare_lammps.py [options]
set -euo pipefail
here="$(dirname "${BASH_SOURCE[0]}")"
# The script named is checked before the setup installs and builds anything.
if [ $# -eq 0 ] || [ ! -f "$here/${1:-}" ] || [ "${1%.py}" = "$1" ]; then
  echo "usage: bash runner/with_lammps.sh SCRIPT.py [options]   (SCRIPT: one of $(cd "$here" && ls bench*.py compare_lammps*.py | tr '\n' ' '))" >&2
  [ $# -gt 0 ] && echo "runner/with_lammps.sh: '$1' is not a script in runner/" >&2
  exit 2
fi
source "$here/setup.sh"
grains_apt_packages+=(lammps openmpi-bin)
grains_setup
script="$1"
shift
"$GRAINS_VENV/bin/python" "$GRAINS_ROOT/runner/$script" "$@"
