"""The course of one stage of a `grains consolidate` output, from its trace (grains/trace/*, programme.trace_every),
and the campaign's picture of every sample's first compression (P* = 0 to 0.01), where the type-2 samples take the
solid fraction the paper's Table II compares.

    python runner/stage_traces.py STAGES.h5 [STAGES.h5 ...] -o first-compression.png

(the stage tables beside the files, as grains consolidate writes them: STEM.h5 and its table named in the file).
A sample still in its first compression (a campaign running, or a programme stopped there) is drawn dashed as far
as its trace goes, its legend saying "still running" or "stopped"; one without a trace row of that stage yet (or
run without programme.trace_every) is left out, with a note saying so. A damaged file or table is refused in one
line naming the dataset or the table's line (stage_course, in_order), exit status 2.
"""
import argparse
import math
import sys
from pathlib import Path
from typing import NamedTuple, Optional

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import dataset_checks  # noqa: E402
import run_files  # noqa: E402
import tool_exits  # noqa: E402
from consolidation_fit import BRANCH, FLAG, SOLID_FRACTION, StageTable, TableError, Values, stage_table_of  # noqa: E402


# The stages a programme runs before its first compression, by programme.preparation: type 2's aggregation and its
# relaxation at P* = 0 (programme_stages in engine/protocols/consolidation_programme.cpp); type 1 and none start there.
# Not read from the output: its table rows (phase, branch) and stage records are those of the stages that ended, and
# nothing in it says whether the stage under way is still preparation or the first compression (a ramped one's first
# trace rows have target 0, as the relaxation's do; and a file may have no trace).
PREPARATION_STAGES = {"type2": 2}


class Course(NamedTuple):
    """A sample's first compression: its trace within the stage, and where the stage ended (NaN: it has not)."""
    label: str
    t: np.ndarray           # time since the stage began
    phi: np.ndarray
    end_phi: float          # its table row's Phi
    reached: bool           # equilibrium
    end_time: float
    unfinished: Optional[str] = None   # None: the stage ended; "still running" or "stopped": under way in the file


def first_loading_stage(rows):
    """The index of the first loading stage (the prepared state at the start pressure) among a stage table's rows,
    and the time its predecessor ended at; None when the table has none yet."""
    for k, row in enumerate(rows):
        if row["branch"] == "loading":
            return int(row["stage"]), float(rows[k - 1]["time"]) if k else 0.0
    return None


def stage_course(h5, stage, start_time):
    """(time since the stage began, Phi, P*) of the trace rows of `stage`; empty arrays for a file without a trace.
    The trace's series are cut to the rows all hold (a run still writing appends to them one by one); FramesError,
    naming the dataset, for one missing or not numbers, and, in a file whose status says its run is complete, for one
    whose parts differ in length, whose steps do not increase, or a Phi outside (0, 1] (they ended in tracebacks, or
    drew a first compression without its course)."""
    def read(f):
        if "grains/trace/stage" not in f:
            return (np.array([]),) * 3
        ended, shown = run_files.ended_in(f), f"'{h5}'"
        why = f" (its status is '{run_files.status_in(f)}': no run is adding rows to it)"
        parts = {}
        for name in ("stage", "solid_fraction", "pressure_reduced"):
            element = f"grains/trace/{name}"
            step = dataset_checks.numbers(f, shown, f"{element}/step", 1)
            for part in ("time", "value"):
                parts[name, part] = dataset_checks.numbers(f, shown, f"{element}/{part}", 1)
                if ended:
                    dataset_checks.one_per_step(shown, element, step, part, parts[name, part], why)
            if ended:
                dataset_checks.increasing(shown, f"{element}/step", step)
        phi = parts["solid_fraction", "value"]
        if ended and (bad := [i for i, v in enumerate(phi) if not SOLID_FRACTION.within(v)]):
            raise dataset_checks.FramesError(f"{shown}: grains/trace/solid_fraction/value holds {phi[bad[0]]} (row {bad[0]}); "
                                             f"{SOLID_FRACTION.allowed}")
        rows = min(len(v) for v in parts.values())
        here = parts["stage", "value"][:rows] == stage
        return (parts["stage", "time"][:rows][here] - start_time, phi[:rows][here],
                parts["pressure_reduced", "value"][:rows][here])
    return run_files.read_unlocked(h5, read)


def first_compression_under_way(h5, rows):
    """(stage index, the time it began at, "still running" or "stopped") when the programme in h5, whose stage table
    has `rows` (its finished stages), is inside its first compression; None when it is not (still preparing, or its
    file says it ended). Its status says which: 'running' or 'resumed ...' while a process writes it (a killed one's
    reads the same), 'interrupted ...' (Ctrl-C) or 'failed ...' once it stopped."""
    status, ended = run_files.read_unlocked(h5, lambda f: (run_files.status_in(f) or "", run_files.ended_in(f)))
    preparation = (run_files.stored(h5) or {}).get("programme", {}).get("preparation", "none")
    if ended or len(rows) != PREPARATION_STAGES.get(preparation, 0):
        return None
    state = "still running" if status == "running" or status.startswith("resumed") else "stopped"
    return len(rows), float(rows[-1]["time"]) if rows else 0.0, state


def labels_of(paths):
    """Each file's name without its suffix, or, where files share it (every campaign names its samples alike), the
    shortest end of its path that tells it from the others: a/x/s.h5 and b/x/s.h5 are a/x/s and b/x/s; files that
    differ by their suffix alone keep it (a/s.h5 and a/s.h5md)."""
    paths = [p.absolute() for p in paths]
    beside = {}   # (folder, stem) -> the files there of that stem
    for p in paths:
        beside.setdefault((p.parent, p.stem), set()).add(p)
    suffixed = {stem for (_, stem), files in beside.items() if len(files) > 1}   # these stems' files keep their suffix
    parts = [(*p.parent.parts[1:], p.name if p.stem in suffixed else p.stem) for p in paths]   # [1:]: not the root
    lengths = [1] * len(paths)
    while True:
        labels = ["/".join(whole[-n:]) for whole, n in zip(parts, lengths)]
        files = {}   # label -> the files it names (a file given twice is one)
        for path, label in zip(paths, labels):
            files.setdefault(label, set()).add(path)
        shared = [k for k, label in enumerate(labels) if len(files[label]) > 1 and lengths[k] < len(parts[k])]
        if not shared:
            return labels
        for k in shared:
            lengths[k] += 1


def untraced(h5, stage):
    """Why the first compression under way in h5 (stage `stage`) has no trace rows to draw."""
    scene = run_files.stored(h5) or {}
    target = scene.get("cell", {}).get("pressure")
    what = f"stage {stage}, to P* = {target:g}" if isinstance(target, (int, float)) else f"stage {stage}"
    if scene.get("programme", {}).get("trace_every") == 0:
        return f"its programme runs without a trace (programme.trace_every = 0), so its first compression ({what}) has none"
    return f"no trace rows for its first compression ({what}) yet"


STAGE = Values("a whole number", int, lambda v: v >= 0, "a stage's index is at least 0")
END_TIME = Values(within=math.isfinite, allowed="a finished stage ends at a finite time")


def in_order(stages):
    """TableError at the first row of a stage table (StageTable) that is not the next stage, ending no earlier than the
    one before: grains writes stage k's row k-th (first_loading_stage takes the row before a stage as its start; rows
    out of order, or a NaN or later time there, drew a first compression from another stage's start)."""
    for k, row in enumerate(stages.rows):
        where = f"stage table '{stages.path}' line {stages.lines[k]}"
        if int(row["stage"]) != k:
            raise TableError(f"{where}: column 'stage' = '{row['stage']}' is out of order: stage {k} belongs there "
                             "(grains writes one row a stage, in order from stage 0)")
        if k and float(row["time"]) < float(stages.rows[k - 1]["time"]):
            raise TableError(f"{where}: column 'time' = '{row['time']}' is out of order: stage {k} ends before stage "
                             f"{k - 1} (at {stages.rows[k - 1]['time']})")


def first_compressions(files):
    """For each stages file: its Course, the files without a table or a first compression begun left out, and so
    are those inside it without a trace row of it yet (saying so on stderr). A file h5py cannot open raises OSError
    naming it."""
    courses = []
    paths = list(map(Path, files))
    for h5, label in zip(paths, labels_of(paths)):
        try:
            courses += first_compression(h5, label)
        except OSError as error:
            raise OSError(f"'{h5}' cannot be read as the HDF5 file grains consolidate wrote ({error})") from None
    return courses


def first_compression(h5, label):
    """first_compressions' work for one file: [its Course], or [] where there is none to draw: a file not there (a
    campaign's archive keeps its tables only), one still preparing, or (said on stderr) one without a stage table or
    without trace rows of its first compression."""
    if not h5.is_file():
        return []
    import h5py  # late, as run_files imports it: --help works without it
    if not h5py.is_hdf5(h5):   # a stage table given in its place, say: read as one, it lacked the trace
        raise OSError("not an HDF5 file")
    table = stage_table_of(h5)
    if table is None:
        print(f"note: {h5}: left out of the first-compression figure: no stage table named in it or beside it "
              "(not a grains consolidate output?)", file=sys.stderr)
        return []
    # A programme's table stays empty until its first stage ends; one cut short or edited by hand is refused (a
    # TableError naming its line, column and value), not a KeyError.
    stages = StageTable(table, empty=True)
    if stages.header:
        stages.columns("stage", "branch", "phi", "time", "reached")
        stages.check({"stage": STAGE, "branch": BRANCH, "phi": SOLID_FRACTION, "time": END_TIME, "reached": FLAG})
        in_order(stages)
    return course_of(h5, label, stages.rows)


def course_of(h5, label, rows):
    """first_compression's reading of the stage table's rows (and the file's trace)."""
    first = first_loading_stage(rows)
    if first is None:
        under_way = first_compression_under_way(h5, rows)
        if under_way is None:
            return []
        stage, start, state = under_way
        t, phi, _ = stage_course(h5, stage, start)
        if not len(t):   # nothing to draw: it had an empty legend entry
            print(f"note: {h5}: left out of the first-compression figure: {untraced(h5, stage)}", file=sys.stderr)
            return []
        return [Course(label, t, phi, math.nan, False, math.nan, state)]
    stage, start = first
    t, phi, _ = stage_course(h5, stage, start)
    row = rows[[int(r["stage"]) for r in rows].index(stage)]
    return [Course(label, t, phi, float(row["phi"]), row["reached"] == "1", float(row["time"]) - start)]


def first_compression_figure(panels, reference=None):
    """panels: {title: first_compressions(...)}; reference: {title: (Phi, bar)} drawn as a band of twice the bar. A
    course still under way is dashed, without an end."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, axes = plt.subplots(1, len(panels), figsize=(5.5 * len(panels), 4), squeeze=False, sharey=True)
    for ax, (title, courses) in zip(axes[0], panels.items()):
        for c in courses:
            if c.unfinished:
                ax.plot(c.t, c.phi, "--", lw=1, label=f"{c.label} ({c.unfinished})")
                continue
            line, = ax.plot(c.t, c.phi, lw=1, label=c.label)
            ax.plot([c.end_time], [c.end_phi], "o", color=line.get_color(), mfc=None if c.reached else "none", ms=5)
        if reference and title in reference:
            value, bar = reference[title]
            ax.axhspan(value - 2 * bar, value + 2 * bar, color="0.85", zorder=0, label="paper, ±2 bars")
        ax.set_title(f"{title}: the first compression to P* = 0.01", fontsize=10)
        ax.set_xlabel("time in the stage (the scene's units: T0 in the consolidation scenes)")
        ax.grid(alpha=0.3)
        if courses:
            note = "open: not in equilibrium" + ("; dashed: unfinished" if any(c.unfinished for c in courses) else "")
            ax.legend(fontsize=6.5, title=note, title_fontsize=6.5)
    axes[0, 0].set_ylabel("solid fraction Φ")
    fig.tight_layout()
    return fig


def plot_first_compressions(panels, path, reference=None):
    """Writes first_compression_figure(panels, reference) to `path`."""
    import matplotlib.pyplot as plt
    fig = first_compression_figure(panels, reference)
    fig.savefig(path, dpi=120)
    plt.close(fig)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("files", nargs="+", help="stages files of grains consolidate")
    ap.add_argument("-o", "--out", default="first-compression.png",
                    help="image to write (default: first-compression.png in the current folder)")
    args = ap.parse_args(argv)
    for f in args.files:
        if problem := run_files.not_a_run_file(f):
            ap.error(f"'{f}' {problem}")
    from plot import image_name_problem
    if problem := image_name_problem("-o/--out", args.out):   # said before the files are read, not after
        ap.error(problem)
    try:
        courses = first_compressions(args.files)
    except (OSError, ValueError) as error:
        ap.error(str(error))
    if not courses:
        ap.error("nothing to draw: no file has a stage table with a loading stage beside it, or a first compression "
                 "under way with trace rows")
    plot_first_compressions({"samples": courses}, args.out)
    print(args.out)
    return 0


if __name__ == "__main__":
    sys.exit(tool_exits.run_read_only(main, "stage_traces.py"))
