#!/usr/bin/env bash
# Benchmarks (not part of the test suite): grains vs LAMMPS on the gas scene. Installs LAMMPS if missing.
set -euo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/setup.sh"
grains_apt_packages+=(lammps openmpi-bin)
grains_setup
"$GRAINS_VENV/bin/python" "$GRAINS_ROOT/runner/bench.py" "$@"
