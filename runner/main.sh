#!/usr/bin/env bash
# The main job: install what is missing, build, run the default scene, plot it.
#   bash runner/main.sh [SCENE.toml] [grains run options...]
set -euo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/setup.sh"
grains_setup
scene="${1:-$GRAINS_ROOT/models/gas.toml}"
shift || true
mkdir -p "$GRAINS_ROOT/out"
name="$(basename "$scene" .toml)"
"$GRAINS_BUILD/runner/grains" run "$scene" --out "$GRAINS_ROOT/out/$name.h5" "$@"
"$GRAINS_VENV/bin/python" "$GRAINS_ROOT/runner/plot.py" "$GRAINS_ROOT/out/$name.h5" -o "$GRAINS_ROOT/out/$name.png" \
  --observables kinetic_energy,elastic_energy,contacts,max_overlap_ratio
