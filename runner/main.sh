#!/usr/bin/env bash
# The main job: install what is missing, build, run the default scene, plot it.
#   bash runner/main.sh [SCENE.toml] [grains run options...]   (options alone: the default scene with them)
set -euo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/setup.sh"
grains_setup
# The default scene runs two threads. Threads waiting between parallel regions spin (libgomp's default):
# fastest on an idle machine (4.3 s against 7.6 s with sleeping waits), but on a busy one the spinning
# threads take the cores from the work (34 s against 8.6 s). So they sleep when something else is running:
# more than a quarter of the processor busy over a third of a second, now (the load average would still
# count the build just done).
busy_share() {
  local a b
  a=($(head -n 1 /proc/stat)); sleep 0.3; b=($(head -n 1 /proc/stat))
  awk -v t0="$(( a[1]+a[2]+a[3]+a[4]+a[5]+a[6]+a[7]+a[8] ))" -v i0="$(( a[4]+a[5] ))" \
      -v t1="$(( b[1]+b[2]+b[3]+b[4]+b[5]+b[6]+b[7]+b[8] ))" -v i1="$(( b[4]+b[5] ))" \
      'BEGIN { d = t1 - t0; print (d > 0 ? 1 - (i1 - i0) / d : 0) }'
}
if [ -z "${OMP_WAIT_POLICY:-}" ] && [ -r /proc/stat ] && awk -v s="$(busy_share)" 'BEGIN { exit !(s > 0.25) }'; then
  export OMP_WAIT_POLICY=passive
  echo "grains: the processor is busy; OpenMP threads will sleep while they wait (OMP_WAIT_POLICY=passive)" >&2
fi
# The scene is the first argument unless it is an option (then the default scene runs with the options).
scene="$GRAINS_ROOT/models/aggregation.toml"
if [ $# -gt 0 ] && [ "${1#-}" = "$1" ]; then scene="$1"; shift; fi
name="$(basename "$scene" .toml)"
# The output: out/NAME.h5, or the run's own --out FILE.h5 (the plot then goes beside it, FILE.png).
h5="" args=()
while [ $# -gt 0 ]; do
  case "$1" in
    --out|--out=)
      if [ -z "${2:-}" ] || [ "$1" = "--out=" ]; then echo "runner/main.sh: --out needs a file name (FILE.h5)" >&2; exit 2; fi
      h5="$2"; shift 2 ;;
    --out=*) h5="${1#--out=}"; shift ;;
    *) args+=("$1"); shift ;;
  esac
done
if [ -z "$h5" ]; then
  mkdir -p "$GRAINS_ROOT/out"
  h5="$GRAINS_ROOT/out/$name.h5"
fi
png="${h5%.h5}.png"
"$GRAINS_BUILD/runner/grains" run "$scene" --out "$h5" ${args[@]+"${args[@]}"}
# plot.py draws the scene's main observables by its kind (gravity: f_max, N_c / N and Q against t / t_ff; a
# pressure-controlled cell: P* and its target, Phi, z, K; others: energies, contacts, overlap).
"$GRAINS_VENV/bin/python" "$GRAINS_ROOT/runner/plot.py" "$h5" -o "$png"
