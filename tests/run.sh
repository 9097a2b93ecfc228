#!/usr/bin/env bash
# Every test: install what is missing, build, run the C++ suite (CTest) and the Python suite (pytest).
set -euo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/../runner/setup.sh"
# The tests also emulate processors without AVX (tests/python/test_any_x86_64.py).
grains_apt_packages+=(qemu-user)
grains_setup
cd "$GRAINS_BUILD"
# Tests run side by side, and many run two OpenMP threads: a thread waiting for the next parallel region
# spins (libgomp's default) while the other test's process wants the core. Waiting threads sleep at once
# here: two two-thread tests side by side took 3.9 and 7.7 s (2.97 and 6.2 s alone) against 82 s each
# with a short spin (GOMP_SPINCOUNT=10000) and 443 s with the default one.
export OMP_WAIT_POLICY="${OMP_WAIT_POLICY:-passive}"
ctest --output-on-failure -j "$(nproc)"
cd "$GRAINS_ROOT"
GRAINS_BIN="$GRAINS_BUILD/runner/grains" "$GRAINS_VENV/bin/python" -m pytest -q -rs tests/python   # -rs: name any skipped test
