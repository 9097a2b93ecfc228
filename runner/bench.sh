#!/usr/bin/env bash
# Benchmarks (not part of the test suite): grains vs LAMMPS on the gas scene. Installs LAMMPS if missing.
exec bash "$(dirname "${BASH_SOURCE[0]}")/with_lammps.sh" bench.py "$@"
