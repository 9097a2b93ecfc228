"""The course of one stage of a `grains consolidate` output, from its trace (grains/trace/*, programme.trace_every),
and the campaign's picture of every sample's first compression (P* = 0 to 0.01), where the type-2 samples take the
solid fraction the paper's Table II compares.

    python runner/stage_traces.py STAGES.h5 [STAGES.h5 ...] -o first-compression.png

(the stage tables beside the files, as grains consolidate writes them: STEM.h5 and its table named in the file).
"""
import argparse
import csv
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import reuse  # noqa: E402
from consolidation_fit import stage_table_of  # noqa: E402


def first_loading_stage(rows):
    """The index of the first loading stage (the prepared state at the start pressure) among a stage table's rows,
    and the time its predecessor ended at; None when the table has none yet."""
    for k, row in enumerate(rows):
        if row["branch"] == "loading":
            return int(row["stage"]), float(rows[k - 1]["time"]) if k else 0.0
    return None


def stage_course(h5, stage, start_time):
    """(time since the stage began, Phi, P*) of the trace rows of `stage`; empty arrays for a file without a trace."""
    def read(f):
        if "grains/trace/stage" not in f:
            return (np.array([]),) * 3
        t = f["grains/trace"]
        rows = min(len(t[n]["value"]) for n in ("stage", "solid_fraction", "pressure_reduced"))
        here = t["stage/value"][:rows] == stage
        return (t["stage/time"][:rows][here] - start_time, t["solid_fraction/value"][:rows][here],
                t["pressure_reduced/value"][:rows][here])
    return reuse.read_unlocked(h5, read)


def first_compressions(files):
    """For each stages file: (label, time since the stage began, Phi, its table's end Phi, whether it reached
    equilibrium), the files without a table or a loading stage left out."""
    courses = []
    for h5 in map(Path, files):
        table = stage_table_of(h5) if h5.is_file() else None
        if table is None:
            continue
        with open(table, newline="") as f:
            rows = list(csv.DictReader(f))
        first = first_loading_stage(rows)
        if first is None:
            continue
        stage, start = first
        t, phi, _ = stage_course(h5, stage, start)
        row = rows[[int(r["stage"]) for r in rows].index(stage)]
        courses.append((h5.stem, t, phi, float(row["phi"]), row["reached"] == "1", float(row["time"]) - start))
    return courses


def plot_first_compressions(panels, path, reference=None):
    """panels: {title: first_compressions(...)}; reference: {title: (Phi, bar)} drawn as a band of twice the bar."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, axes = plt.subplots(1, len(panels), figsize=(5.5 * len(panels), 4), squeeze=False, sharey=True)
    for ax, (title, courses) in zip(axes[0], panels.items()):
        for k, (label, t, phi, end_phi, reached, end_time) in enumerate(courses):
            line, = ax.plot(t, phi, lw=1, label=label)
            ax.plot([end_time], [end_phi], "o", color=line.get_color(), mfc=None if reached else "none", ms=5)
        if reference and title in reference:
            value, bar = reference[title]
            ax.axhspan(value - 2 * bar, value + 2 * bar, color="0.85", zorder=0, label="paper, ±2 bars")
        ax.set_title(f"{title}: the first compression to P* = 0.01", fontsize=10)
        ax.set_xlabel("time in the stage (the scene's units: T0 in the consolidation scenes)")
        ax.grid(alpha=0.3)
        if courses:
            ax.legend(fontsize=6.5, title="open: not in equilibrium", title_fontsize=6.5)
    axes[0, 0].set_ylabel("solid fraction Φ")
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("files", nargs="+", help="stages files of grains consolidate")
    ap.add_argument("-o", "--out", default="first-compression.png", help="image to write")
    args = ap.parse_args(argv)
    for f in args.files:
        if problem := reuse.not_a_run_file(f):
            ap.error(f"'{f}' {problem}")
    courses = first_compressions(args.files)
    if not courses:
        ap.error("no file has a stage table with a loading stage beside it")
    plot_first_compressions({"samples": courses}, args.out)
    print(args.out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
