#!/usr/bin/env bash
# Every test: install what is missing, build, run the C++ suite (CTest) and the Python suite (pytest).
set -euo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/../runner/setup.sh"
grains_setup
cd "$GRAINS_BUILD"
# Tests run side by side, and many run two OpenMP threads: a thread waiting for the next parallel region
# spins (libgomp's default) while the other test's process wants the core. A short spin, then sleep:
# alone, a two-thread test takes the same time (16.5 and 16.8 s); beside a one-thread run 28.8 s against
# 45.2 s (and 443 s beside another two-thread test in a CI run).
export GOMP_SPINCOUNT="${GOMP_SPINCOUNT:-10000}"
ctest --output-on-failure -j "$(nproc)"
cd "$GRAINS_ROOT"
GRAINS_BIN="$GRAINS_BUILD/runner/grains" "$GRAINS_VENV/bin/python" -m pytest -q tests/python
