#!/usr/bin/env bash
# The main job: install what is missing, build, run the default scene, plot it.
#   bash runner/main.sh [SCENE.toml] [grains run options...]
set -euo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/setup.sh"
grains_setup
# The default scene runs two threads; on a machine whose cores are busy, threads spinning between
# parallel regions (libgomp's default) made it 4 times slower: waiting threads sleep instead.
export OMP_WAIT_POLICY="${OMP_WAIT_POLICY:-passive}"
scene="${1:-$GRAINS_ROOT/models/aggregation.toml}"
shift || true
mkdir -p "$GRAINS_ROOT/out"
name="$(basename "$scene" .toml)"
"$GRAINS_BUILD/runner/grains" run "$scene" --out "$GRAINS_ROOT/out/$name.h5" "$@"
# Gravity scenes: f_max, N_c / N and Q against t / t_ff; others: the energies and contacts against time.
if h5="$GRAINS_ROOT/out/$name.h5" "$GRAINS_VENV/bin/python" -c \
    'import h5py, os, sys; sys.exit("time_over_free_fall" not in h5py.File(os.environ["h5"])["observables"])'; then
  plot_args=(--observables largest_cluster_fraction,cluster_index,virial_ratio --x time_over_free_fall)
else
  plot_args=(--observables kinetic_energy,elastic_energy,contacts,max_overlap_ratio)
fi
"$GRAINS_VENV/bin/python" "$GRAINS_ROOT/runner/plot.py" "$GRAINS_ROOT/out/$name.h5" -o "$GRAINS_ROOT/out/$name.png" "${plot_args[@]}"
