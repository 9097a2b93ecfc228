"""Plot the observables of a grains run.

    python runner/plot.py RUN.h5 [-o OUT.png] [--observables a,b,c] [--x NAME] [--stage N]

Reads observables/<name>/{time,value} from an H5MD file and draws each observable in its own
subplot over a shared time axis, or over another observable recorded at the same times
(`--x time_over_free_fall`: against t / t_ff). Without --observables it draws the scene's main ones,
chosen by what the file holds: a gravity scene f_max, N_c / N and Q against t / t_ff; a
pressure-controlled cell P* (with its target), Phi, z and K (for `grains consolidate`'s output, its trace within
the stages, grains/trace/*, with the one record per stage drawn as dots, the initial state's apart); a collision
log K, contacts, collisions and the adhesive fraction; any other scene K, the elastic energy, contacts and the largest overlap (`--stage N`: of a
programme's output, stage N only, from the previous stage's end to its own). The figure is titled with the scene's name and description; a quantity that is nowhere negative and whose
positive values span more than three decades is drawn on a log axis (its zeros, when at most a tenth of
the records, left out and said so), a panel without finite values says so, and the aggregation time,
when the run reached it, is marked. Prints the image's path
(-o: PNG, or another format matplotlib writes, e.g. .pdf or .svg). Exits with code 2 and a message naming the
file when it is missing, holds no observables or is damaged (a series that is no numbers, or, in a file whose status
says complete, cut short or with its steps out of order; the dataset named), or naming the option when -o has no
supported extension.
"""
import argparse
import sys
import textwrap
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import dataset_checks  # noqa: E402
import run_files  # noqa: E402
import tool_exits  # noqa: E402

MAX_PANELS = 6
# The default panels by the kind of scene: the first entry whose marker observable the file has gives the panels it
# has and the horizontal axis (None: time). A cell scene plotted as its energies said nothing of its pressure or
# packing, and Q of a gravity scene is what the aggregation paper reads.
KINDS = [
    ("time_over_free_fall", ["largest_cluster_fraction", "cluster_index", "virial_ratio"], "time_over_free_fall"),
    ("pressure_reduced", ["pressure_reduced", "solid_fraction", "coordination", "kinetic_energy"], None),
    ("adhesive_collision_fraction", ["kinetic_energy", "contacts", "collision_count", "adhesive_collision_fraction"], None),
    (None, ["kinetic_energy", "elastic_energy", "contacts", "max_overlap_ratio"], None),
]
# A panel's reference series, drawn dashed in it when the file has it.
COMPANIONS = {"pressure_reduced": ("pressure_target", "target"), "trace/pressure_reduced": ("trace/pressure_target", "target")}
TRACE = "trace/"   # names of grains consolidate's records within the stages, grains/trace/* (programme.trace_every)
TIME_LABEL = "time t (the scene's units)"
LABELS = {
    "largest_cluster_fraction": "f_max: mass fraction of the largest cluster",
    "cluster_index": "N_c / N: clusters per particle",
    "virial_ratio": "Q = K / |W|: virial ratio",
    "time_over_free_fall": "t / t_ff",
    "collision_count": "collisions (completed)",
    "adhesive_collision_fraction": "adhesive collisions / collisions",
    "kinetic_energy": "kinetic energy K",
    "gravity_potential_energy": "gravitational potential energy W",
    "elastic_energy": "elastic energy of the contacts",
    "contacts": "contacts",
    "max_overlap_ratio": "largest overlap / R_min",
    "pressure_reduced": "P* = a P / F0",
    "solid_fraction": "solid fraction Phi",
    "coordination": "coordination number z",
    "fractal_dimension": "fractal dimension D_f of the largest cluster",
}


def fail(message):
    print(f"plot.py: {message}", file=sys.stderr)
    sys.exit(2)


def read_run(path, read):
    """read(file) on the file, also while a run still writes it (run_files.read_unlocked); a file that never opens is
    reported."""
    try:
        return run_files.read_unlocked(path, read)
    except OSError as e:
        fail(f"cannot open '{path}' as HDF5: {e}")


def default_panels(available):
    """The panels (at most MAX_PANELS) and the horizontal axis (None: time) of a file with these observables."""
    for marker, names, x_name in KINDS:
        if marker is None or marker in available:
            return ([n for n in names if n in available] or available)[:MAX_PANELS], x_name


def read_observables(path, wanted, x_name=None, stage=None):
    """Returns {name: (time, value)} in file order, or the requested order when names are given, the (time, value)
    of `x_name` (None without it) and {name: (time, value)} of the panels' companions, all from one reading and cut
    at one step. Without `wanted`, the panels and (without `x_name`) the axis are the scene kind's default_panels.
    `stage`: only the records from that programme stage's start (the previous stage's end) to its end."""
    return read_run(path, lambda f: observables_of(f, path, wanted, x_name, stage))


def stage_window(f, group, path, stage):
    """The steps a programme's stage spans, from the stage records (observables/solid_fraction: the initial state,
    then one per finished stage); the stage under way runs to the file's end."""
    if "solid_fraction" not in group or "grains/trace" not in f:
        fail(f"'{path}' is not the output of grains consolidate with a trace (grains/trace, programme.trace_every): "
             "--stage needs one")
    ends = group["solid_fraction/step"][()]
    # A finished programme has no stage under way after its last record.
    stages = len(ends) - 1 if run_files.ended_in(f) else len(ends)
    if not 0 <= stage < stages:
        fail(f"--stage {stage}: '{path}' has stages 0 to {stages - 1} ({len(ends) - 1} finished)")
    return ends[stage], ends[stage + 1] if stage + 1 < len(ends) else float("inf")


def observables_of(f, path, wanted, x_name, stage=None):
    import h5py
    def series_in(g):   # H5MD's time-dependent elements (step, time, value); a time-independent one, a plain dataset,
        # or an element without its step has no course to draw (they ended the plot in a traceback)
        if not isinstance(g, h5py.Group):
            return []
        return [k for k, e in g.items() if isinstance(e, h5py.Group) and all(
            isinstance(e.get(part), h5py.Dataset) for part in ("step", "time", "value"))]

    group = f.get("observables")
    available = series_in(group)
    traces = f.get("grains/trace")
    available += [TRACE + k for k in series_in(traces)]

    def element(name):   # observables/<name>, or grains/trace/<name> for trace/<name>
        return f["grains/" + name] if name.startswith(TRACE) else group[name]

    if not available:
        fail(f"'{path}' has no observables with a course in time (step, time and value)")
    names = wanted
    if not wanted:
        traced = [n[len(TRACE):] for n in available if n.startswith(TRACE)]
        names, default_x = default_panels(traced or available)
        if traced:   # a stage's course rather than one point per stage
            names = [TRACE + n for n in names]
        x_name = default_x if x_name is None else x_name
    x_name = None if x_name == "time" else x_name   # --x time: the records' own time
    companions = [COMPANIONS[n][0] for n in names if n in COMPANIONS and COMPANIONS[n][0] in available]
    # The stage records beside a trace, drawn as dots in its panels: read and cut as the observables are.
    companions += [n[len(TRACE):] for n in names if n.startswith(TRACE) and n[len(TRACE):] in available]
    missing = [n for n in names + ([x_name] if x_name else []) if n not in available]
    if missing:
        others = [n for n in missing if isinstance(group, h5py.Group) and n in group]
        fail(f"'{path}' has no observable {', '.join(missing)}"
             f"{' with a course in time (step, time and value): ' + ', '.join(others) + ' has none' if others else ''} "
             f"(available: time, {', '.join(available)})")
    # A run killed inside a flush may leave a series rows ahead of the others, and a run still writing leaves a
    # series' steps, times and values of different lengths: keep the records every series holds whole.
    # A file whose status says its run ended holds every series whole, each step after the one before: one that does
    # not is damaged (a series cut short in it was drawn cut, rotated steps as one point), and is refused.
    rows, ended, shown = {}, run_files.ended_in(f), f"'{path}'"
    for n in dict.fromkeys(names + companions + ([x_name] if x_name else [])):
        name = element(n).name.lstrip("/")
        try:   # strings ended in matplotlib's AttributeError, a scalar step in a TypeError
            step, t = (dataset_checks.numbers(f, shown, f"{name}/{part}", 1) for part in ("step", "time"))
            v = dataset_checks.numbers(f, shown, f"{name}/value", (1, 2))   # a vector observable: one row of components a record
            if ended:
                for part, data in (("time", t), ("value", v)):
                    dataset_checks.one_per_step(shown, name, step, part, data, f" (its status is '{run_files.status_in(f)}': no "
                                                "run is adding rows to it)")
                dataset_checks.increasing(shown, f"{name}/step", step)
        except dataset_checks.FramesError as error:
            fail(str(error))
        whole = min(len(step), len(t), len(v))
        rows[n] = (step[:whole], t[:whole], v[:whole])
    # Up to the step grains says every series is whole at, and the step every series read holds (a run still writing:
    # a flush may come between the reading of the rows and of that mark). The observables and a trace (grains/trace/*)
    # each on their own: a stage under way has trace rows past the last stage record, and an older grains wrote none
    # at a stage's end (the trace ended before the last record).
    first, end = stage_window(f, group, path, stage) if stage is not None else (-1, float("inf"))
    mark = group.attrs.get("complete_to_step", float("inf")) if group is not None else float("inf")
    if not isinstance(mark, (int, float, np.number)) or np.isnan(mark):
        fail(f"'{path}': observables@complete_to_step is {mark!r}; grains writes there the step every series is whole "
             "to, a number")
    last = {traced: min([mark, end] + [step[-1] for n, (step, _, _) in rows.items() if len(step) and n.startswith(TRACE) == traced])
            for traced in (False, True)}
    series = {}
    for n, (step, t, v) in rows.items():
        keep = (step <= last[n.startswith(TRACE)]) & (step >= first)
        series[n] = (t[keep], v[keep])
    return {n: series[n] for n in names}, x_name, series.get(x_name), {n: series[n] for n in companions}


def read_context(path):
    """The figure's title (scene name and description), the aggregation time (NaN if none) and the label of P*."""
    import tomllib
    title, t_agg = path.name, float("nan")
    def read(f):
        text = f["parameters"].attrs.get("scene.toml") if "parameters" in f else None
        try:
            scene = tomllib.loads(text.decode() if isinstance(text, bytes) else str(text)) if text else {}
        except (tomllib.TOMLDecodeError, UnicodeDecodeError) as error:
            fail(f"'{path}': parameters@scene.toml, the scene the run ran, is not TOML ({error})")
        name = "observables/aggregation_time/value"
        try:
            values = dataset_checks.numbers(f, f"'{path}'", name, 1) if name in f else []
        except dataset_checks.FramesError as error:
            fail(str(error))
        return scene, float(values[-1]) if len(values) else float("nan")
    scene, t_agg = read_run(path, read)
    about = scene.get("scene", {})
    title = "\n".join(textwrap.fill(x, 80) for x in (about.get("name"), about.get("description")) if x) or title
    return title, t_agg, pressure_label(scene)


def pressure_label(scene):
    """What P* is in this scene (docs/scene-reference.md, cell.pressure and cell.force_unit): a P / F0 in 2D, a^2 P /
    F0 in 3D, and in a cohesionless cell (force_unit = 0) P a^(D-2) / k_n. One label for all read a P / F0 in 3D and
    in the cohesionless packing, whose P* is P / K_N."""
    three = scene.get("scene", {}).get("dimension") == 3
    if scene.get("cell", {}).get("force_unit") == 0:
        return "P* = a P / k_n" if three else "P* = P / K_N"
    return "P* = a² P / F0" if three else "P* = a P / F0"


def image_formats():
    """The file name extensions matplotlib can write (png, pdf, svg, ...)."""
    from matplotlib.backend_bases import FigureCanvasBase
    return FigureCanvasBase.get_supported_filetypes()


def image_name_problem(option, out):
    """Why `out` cannot name a plot (its folder missing, no image format matplotlib writes, or a folder, FIFO or device
    at the name, which matplotlib met only after the figure was drawn), or None."""
    if kind := run_files.not_a_regular_file(out):
        return f"{option} '{out}' is {kind}, not a file an image can be written to"
    if not Path(out).resolve().parent.is_dir():
        return f"{option}: the folder '{Path(out).parent}' of '{out}' does not exist"
    if Path(out).suffix[1:].lower() not in image_formats():
        return f"{option} '{out}': the file name must end with a supported image format: .{', .'.join(sorted(image_formats()))}"
    return None


def log_axis(values):
    """Whether a panel reads better on a log axis: nowhere negative, its positive values spanning more than three
    decades, and zero in at most a tenth of the records (then left out). Q of a cold cloud starts at 0 and decays over
    five decades after its peak: on a linear axis the decay, and a second peak, were a flat line at 0. A lone
    collision's contacts, zero most of the time, read better on a linear axis."""
    v = np.asarray(values, float)
    v = v[np.isfinite(v)]
    positive = v[v > 0]
    return bool(positive.size and not (v < 0).any() and positive.max() > 1e3 * positive.min()
                and (v == 0).sum() <= 0.1 * v.size)


def figure(series, x_name=None, x_values=None, title="", mark=float("nan"), companions=None, labels=None,
           starts_initial=True):
    """The figure of the panels in `series` ({name: (time, value)}); `companions`: {name: (time, value)} of the
    reference series drawn dashed in their panels (COMPANIONS), and of the stage records drawn as dots in a trace's;
    `mark`: the aggregation time on the plot's horizontal axis (NaN: none); `labels`: panel titles in place of
    LABELS'; `starts_initial`: the stage records begin with the programme's initial state (all of them, or --stage 0),
    drawn apart from the stages' ends."""
    import matplotlib

    matplotlib.use("Agg")  # no display needed
    import matplotlib.pyplot as plt

    companions = companions or {}
    labels = {**LABELS, **(labels or {})}
    fig, axes = plt.subplots(len(series), 1, sharex=True, squeeze=False, figsize=(7, 2.2 * len(series) + 0.9),
                             layout="constrained")   # room for a two-line title above the first panel
    for ax, (name, (t, v)) in zip(axes[:, 0], series.items()):
        # Vector observables ([frames, k]) get one line per component.
        reference = COMPANIONS.get(name, (None, None))
        stage_points = companions.get(name[len(TRACE):]) if name.startswith(TRACE) and x_values is None else None
        drawn_with = reference[0] in companions and (x_values is None or len(companions[reference[0]][1]) == len(v))
        ax.plot(t if x_values is None else x_values, v, lw=1, label="measured" if drawn_with else "_nolegend_")
        title_text = labels.get(name, labels.get(name.removeprefix(TRACE), name))
        if stage_points is not None:
            st, sv = stage_points
            ends = 1 if starts_initial and len(st) else 0   # the stage records after the initial state
            if ends:
                ax.plot(st[:1], sv[:1], "s", ms=5, mfc="none", color="C3", label="initial state")
            if len(st) > ends:
                ax.plot(st[ends:], sv[ends:], "o", ms=3, color="C3", label="end of a stage")
            ax.legend(fontsize=8, loc="best")
        if drawn_with:
            rt, rv = companions[reference[0]]
            ax.plot(rt if x_values is None else x_values, rv, "--", color="0.3", lw=1, label=reference[1])
            ax.legend(fontsize=8, loc="best")
        finite = np.asarray(v, float)[np.isfinite(v)]
        if not finite.size:   # a run just started, or a quantity never defined in it (NaN)
            ax.text(0.5, 0.5, "no values yet" if not np.size(v) else "no finite values (NaN)", transform=ax.transAxes,
                    ha="center", va="center", color="0.4")
        elif log_axis(v):
            ax.set_yscale("log", nonpositive="mask")
            if (finite == 0).any():
                title_text += " (log axis; zeros not drawn)"
        else:
            ax.ticklabel_format(axis="y", useOffset=False)   # Phi 0.35999 as it is, not as 1e-5 + 3.5999e-1
        ax.set_title(title_text, fontsize=10)
        if np.isfinite(mark):
            ax.axvline(mark, color="0.4", ls="--", lw=0.8, label="aggregation time")
        ax.grid(alpha=0.3)
    if np.isfinite(mark):
        axes[0, 0].legend(fontsize=8, loc="best")
    axes[-1, 0].set_xlabel(LABELS.get(x_name, x_name) if x_name else TIME_LABEL)
    fig.suptitle(title, fontsize=11)
    return fig


def plot(series, out, x_name=None, x_values=None, title="", mark=float("nan"), companions=None, labels=None,
         starts_initial=True):
    """Writes figure(...) to `out`."""
    import matplotlib.pyplot as plt

    fig = figure(series, x_name, x_values, title, mark, companions, labels, starts_initial)
    fig.savefig(out, dpi=120)
    plt.close(fig)


def main(argv=None):
    parser = argparse.ArgumentParser(description="Plot observables from a grains H5MD run file.")
    parser.add_argument("run", help="the run's .h5 file")
    parser.add_argument("-o", "--out", help="image to write: .png, .pdf, .svg, ... (default: RUN with .png)")
    parser.add_argument("--observables", help="comma-separated names (default: the scene's main ones, up to 6)")
    parser.add_argument("--x", help="observable for the horizontal axis (default: time)")
    parser.add_argument("--stage", type=int, help="grains consolidate's output: only this stage, from the previous "
                        "stage's end to its own (its trace and the two stage records)")
    args = parser.parse_args(argv)

    path = Path(args.run)
    if problem := run_files.not_a_run_file(path):
        fail(f"run file '{path}' {problem}")
    out = Path(args.out) if args.out else path.with_suffix(".png")
    if problem := image_name_problem("-o/--out" if args.out else "the image (RUN with .png; -o names another)", out):
        fail(problem)
    if out.resolve() == path.resolve():   # a run file named RUN.png, say: the plot would replace it
        fail(f"the image '{out}' is the run file itself: name another with -o")
    wanted = [n.strip() for n in args.observables.split(",") if n.strip()] if args.observables is not None else None
    if wanted == []:
        fail(f"--observables '{args.observables}': no name in it (comma-separated observables, e.g. kinetic_energy,pressure)")
    series, x_name, x_series, companions = read_observables(path, wanted, args.x, args.stage)
    title, mark, pressure = read_context(path)
    if args.stage is not None:
        title += f"\nstage {args.stage}"
    x_values = None
    if x_name:
        x_time, x_values = x_series
        for name, (t, _) in series.items():
            if len(t) != len(x_time) or (t != x_time).any():
                fail(f"'{name}' and the x-axis '{x_name}' are not recorded at the same times")
        # the aggregation time where the axis is at it (an axis that grows with time, as t / t_ff does)
        mark = float(np.interp(mark, x_time, x_values)) if (np.diff(x_values) > 0).all() else float("nan")
    # Stage N's records are the ends of stages N - 1 and N: only stage 0's first is the initial state.
    plot(series, out, x_name, x_values, title, mark, companions, {"pressure_reduced": pressure, TRACE + "pressure_reduced": pressure},
         args.stage in (None, 0))
    print(out)
    return 0


if __name__ == "__main__":
    sys.exit(tool_exits.run_read_only(main, "plot.py"))
