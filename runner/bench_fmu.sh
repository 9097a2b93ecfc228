#!/usr/bin/env bash
# FMU overhead benchmark (not part of the test suite): runner vs fmpy on the aggregation scene, empty doStep cost.
set -euo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/setup.sh"
grains_setup
"$GRAINS_VENV/bin/python" "$GRAINS_ROOT/runner/bench_fmu.py" --build "$GRAINS_BUILD" "$@"
