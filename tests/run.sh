#!/usr/bin/env bash
# Every test: install what is missing, build, run the C++ suite (CTest) and the Python suite (pytest).
set -euo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/../runner/setup.sh"
grains_setup
cd "$GRAINS_BUILD"
ctest --output-on-failure -j "$(nproc)"
cd "$GRAINS_ROOT"
GRAINS_BIN="$GRAINS_BUILD/runner/grains" "$GRAINS_VENV/bin/python" -m pytest -q tests/python
