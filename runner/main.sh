#!/usr/bin/env bash
# The main job: install what is missing, build, run the default scene, plot it.
#   bash runner/main.sh [SCENE.toml] [grains run options...]   (options alone: the default scene with them)
set -euo pipefail
# Help first, before any setup or run (--help went on to grains run's help, then plotted an old output).
for arg in "$@"; do
  case "$arg" in
    -h|--help)
      cat <<'USAGE'
usage: bash runner/main.sh [SCENE.toml] [grains run options...]
  Installs what is missing, builds, runs SCENE (default models/aggregation.toml) and plots it:
  out/SCENE.h5, .xdmf and .png (or --out FILE.h5, the plot beside it as FILE.png). The same command after an
  interruption resumes the unfinished run; --overwrite starts it again. grains run's options: grains run --help
  (build/runner/grains once built); the plot: runner/plot.py --help.
USAGE
      exit 0 ;;
  esac
done
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
# The output: out/NAME.h5, or the run's own --out FILE.h5 (the plot then goes beside it, FILE.png). The --set
# overrides, --quiet and --overwrite are noted too, for a run left unfinished there (below), and whether anything
# else was given (a misspelt option, a scene after the options): grains run is left to refuse that.
h5="" args=() sets=() quiet=() overwrite="" unread=""
while [ $# -gt 0 ]; do
  case "$1" in
    --out|--out=)
      if [ -z "${2:-}" ] || [ "$1" = "--out=" ]; then echo "runner/main.sh: --out needs a file name (FILE.h5)" >&2; exit 2; fi
      h5="$2"; shift 2 ;;
    --out=*) h5="${1#--out=}"; shift ;;
    --set) if [ $# -gt 1 ]; then sets+=("$2"); args+=("$1" "$2"); shift 2; else unread=1; args+=("$1"); shift; fi ;;
    --set=*) sets+=("${1#--set=}"); args+=("$1"); shift ;;
    --quiet) quiet=(--quiet); args+=("$1"); shift ;;
    --overwrite) overwrite=1; args+=("$1"); shift ;;
    *) unread=1; args+=("$1"); shift ;;
  esac
done
if [ -z "$h5" ]; then
  mkdir -p "$GRAINS_ROOT/out"
  h5="$GRAINS_ROOT/out/$name.h5"
fi
png="${h5%.h5}.png"
grains="$GRAINS_BUILD/runner/grains"
# The same command again after an interruption (Ctrl-C) goes on with the run it left: a run of this scene with these
# settings left unfinished in the output is resumed, not started again (--overwrite starts it again). One of other
# settings there is grains run's to refuse, naming the ways on; a finished one is replaced. With an argument main.sh
# did not read, grains run says what it makes of it: a resume would pass over it (`--quite` resumed the run).
if [ -z "$overwrite" ] && [ -z "$unread" ] && [ -f "$h5" ] && "$GRAINS_VENV/bin/python" "$GRAINS_ROOT/runner/same_unfinished_run.py" \
     "$grains" "$h5" "$scene" ${sets[@]+"${sets[@]}"}; then
  echo "runner/main.sh: $h5 holds an unfinished run of this scene with these settings: resuming it (grains resume;" \
       "--overwrite starts it again)" >&2
  resumed=0
  "$grains" resume "$h5" ${quiet[@]+"${quiet[@]}"} || resumed=$?
  [ "$resumed" -eq 130 ] && exit 130
  if [ "$resumed" -ne 0 ]; then
    echo "runner/main.sh: it could not be resumed (above): running the scene again" >&2
    "$grains" run "$scene" --out "$h5" ${args[@]+"${args[@]}"}
  fi
else
  "$grains" run "$scene" --out "$h5" ${args[@]+"${args[@]}"}
fi
# plot.py draws the scene's main observables by its kind (gravity: f_max, N_c / N and Q against t / t_ff; a
# pressure-controlled cell: P* and its target, Phi, z, K; others: energies, contacts, overlap).
"$GRAINS_VENV/bin/python" "$GRAINS_ROOT/runner/plot.py" "$h5" -o "$png"
