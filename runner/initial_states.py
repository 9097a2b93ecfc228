"""The consolidation paper's other initial states (its Table II), measured against the paper.

    python runner/initial_states.py [--samples 4] [--first-seed 1] [--count 1400] [--jobs 2] [--out initial-states]
                                    [--state cohesionless ...] [--set key=value ...] [--report]

Runs, for each sample seed, `grains consolidate` on the preparation only (programme.load = false,
programme.unload = false) of
  - the cohesionless packing (models/cohesionless.toml: F0 = 0, compressed at P / K_N = 1e-5), and
  - the type-1 packing (models/consolidation-type1.toml: the cohesive gas at rest, compressed at P* = 0.01),
each without rolling resistance and with mu_R / a = 0.005 (rolling.coefficient), `--jobs` at a time (Dask,
one thread each). A run whose table already exists in --out is not run again if it ran the settings given now
(else refused, as by runner/consolidation_campaign.py); an unfinished one is resumed, or run again over its file
(--overwrite) where it cannot be, as there. Prints Phi and z of the
equilibrated state, mean +- sample standard deviation, against the paper's Phi (physics.md section 9 table:
cohesionless 0.811 +- 0.001 and 0.805 +- 0.002; type 1 0.723 +- 0.001 and 0.688 +- 0.001, N = 1400, 4
samples each); a value passes when the mean lies within twice the paper's error bar. The table goes to
OUT/summary.md and a plot of every sample against the paper to OUT/initial-states.png; --report makes
them from the tables already in --out. Type-2 samples are the campaign's (runner/consolidation_campaign.py).
"""
import argparse
import os
import pathlib
import sys

import numpy as np

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent))
from consolidation_campaign import (ROOT, check_arguments, check_samples, consolidate, provenance,  # noqa: E402
                                    refuse_occupied_names)
from consolidation_fit import FLAG, NUMBER, SOLID_FRACTION, STEPS, StageTable, TableError  # noqa: E402
import child_runs  # noqa: E402
import tool_args  # noqa: E402
import tool_exits  # noqa: E402
# name: (scene file, overrides, paper's Phi and error bar)
STATES = {
    "cohesionless": ("cohesionless", [], (0.811, 0.001)),
    "cohesionless-rr": ("cohesionless", ["rolling.coefficient=0.005"], (0.805, 0.002)),
    "type1": ("consolidation-type1", [], (0.723, 0.001)),
    "type1-rr": ("consolidation-type1", ["rolling.coefficient=0.005"], (0.688, 0.001)),
}


def preparation(state, seed, count, overrides, out):
    """(scene file, overrides, stem) of one preparation."""
    scene, own, _ = STATES[state]
    fixed = [f"particles.seed={seed}", f"particles.count={count}", "run.threads=1", "programme.load=false",
             "programme.unload=false"]
    return ROOT / "models" / f"{scene}.toml", fixed + own + list(overrides), out / f"{state}-seed{seed}"


def run(grains, state, seed, count, overrides, out):
    """One preparation unless its table exists; returns the path of its stage table."""
    return consolidate(grains, *preparation(state, seed, count, overrides, out), f"{state} seed {seed}")


def final_state(table):
    """The last row of a preparation's stage table (its equilibrated state, whose values the summary gives), once the
    table is known to hold one; TableError else."""
    stages = StageTable(table)
    stages.columns("phi", "coordination", "reached", "steps")
    stages.check({"phi": SOLID_FRACTION, "coordination": NUMBER, "reached": FLAG, "steps": STEPS})
    return stages.rows[-1]


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--samples", type=int, default=4, help="samples per state (default 4, as the paper)")
    ap.add_argument("--first-seed", type=int, default=1, help="seeds FIRST_SEED .. FIRST_SEED + SAMPLES - 1 (default 1)")
    ap.add_argument("--count", type=int, default=1400, help="disks per sample (default 1400, the paper's)")
    ap.add_argument("--jobs", type=int, default=os.cpu_count() or 1, help="runs at once (default: the cores)")
    ap.add_argument("--state", action="append", choices=list(STATES), help="state to run (repeatable; default all)")
    ap.add_argument("--set", action="append", default=[], metavar="KEY=VALUE", help="scene override for every run")
    ap.add_argument("--out", default="initial-states", help="folder for tables, HDF5 files, logs, summary (default initial-states)")
    ap.add_argument("--grains", default=str(ROOT / "build" / "runner" / "grains"), help="the grains binary (default: build/runner/grains)")
    ap.add_argument("--report", action="store_true", help="run nothing: summarise the tables already in --out")
    args = ap.parse_args()
    tool_args.refuse_controlled(ap, args.set, {"programme.load": "a preparation stops before loading",
                                               "programme.unload": "a preparation stops before loading",
                                               "rolling.coefficient": "the state: a name ending in -rr has it"})
    check_arguments(ap, args)
    states = args.state or list(STATES)
    seeds = range(args.first_seed, args.first_seed + args.samples)
    out = pathlib.Path(args.out)
    runs = [preparation(s, seed, args.count, args.set, out) for s in states for seed in seeds]

    if args.report:   # what is there, as the consolidation campaign's report does; nothing at all is an error
        tables = {(s, seed): out / f"{s}-seed{seed}.csv" for s in states for seed in seeds}
        for (s, seed), table in tables.items():
            if not table.exists():
                print(f"  {s} seed {seed}: no table in {out}", flush=True)
        tables = {key: table for key, table in tables.items() if table.exists()}
        if not tables:
            ap.error(f"--report: no table of {', '.join(states)} for seeds {seeds.start}..{seeds.stop - 1} in {out}")
        tool_args.require_binary(ap, "--grains", args.grains)   # to say whether the tables ran what the summary will say they did
    check_samples(ap, args.grains, runs)
    if not args.report:
        refuse_occupied_names(ap, runs)
        tool_args.make_out(ap, out)
        import dask
        tasks = {(s, seed): dask.delayed(run)(args.grains, s, seed, args.count, args.set, out) for s in states for seed in seeds}
        print(f"initial states: {len(tasks)} runs of {args.count} disks, {args.jobs} at a time, logs in {out}/", flush=True)
        tables = dict(zip(tasks, dask.compute(*tasks.values(), scheduler="threads", num_workers=args.jobs)))

    lines = ["| state | Phi: mean ± sd (samples) | paper | within 2× paper bar | z | in equilibrium | steps (mean) |",
             "|---|---|---|---|---|---|---|"]
    final = {}
    for s in states:
        try:
            rows = [final_state(tables[(s, seed)]) for seed in seeds if (s, seed) in tables]
        except TableError as error:   # one line naming the table, the line and the value, not a traceback
            ap.exit(2, f"{ap.prog}: error: {error}\n")
        if not rows:
            continue
        final[s] = rows
        phi = np.array([float(r["phi"]) for r in rows])
        z = np.array([float(r["coordination"]) for r in rows])
        value, bar = STATES[s][2]
        spread = lambda x: f" ± {x.std(ddof=1):.4f}" if x.size > 1 else ""
        verdict = "yes" if abs(phi.mean() - value) <= 2 * bar else "NO"
        reached = sum(r["reached"] == "1" for r in rows)
        lines.append(f"| {s} | {phi.mean():.4f}{spread(phi)} ({phi.size}) | {value} ± {bar} | {verdict} | "
                     f"{z.mean():.3f}{spread(z)} | {reached} of {len(rows)} | {np.mean([int(r['steps']) for r in rows]):,.0f} |")
    text = "\n".join(lines)
    print(text)
    (out / "summary.md").write_text(provenance(args, states) + text + "\n")
    plot(final, out / "initial-states.png")
    print(f"wrote {out / 'summary.md'} and {out / 'initial-states.png'}")


def plot(final, path):
    """Every sample's Phi (open: not in equilibrium) beside the paper's value and its doubled error bar."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, axes = plt.subplots(1, len(final), figsize=(max(2.2 * len(final), 5), 3.9))
    for ax, (s, rows) in zip(np.atleast_1d(axes), final.items()):
        value, bar = STATES[s][2]
        ax.errorbar([0], [value], yerr=[2 * bar], fmt="s", color="black", capsize=5, mfc="white", label="paper (±2 bars)")
        for k, r in enumerate(rows):
            reached = r["reached"] == "1"
            ax.plot([0.4 + 0.08 * k], [float(r["phi"])], "o", color="tab:blue", mfc="tab:blue" if reached else "none",
                    label="grains, one per sample (open: not in equilibrium)" if k == 0 else None)
        ax.set_xlim(-0.4, 1.0)
        ax.set_xticks([])
        ax.set_title(s, fontsize=9)
        ax.margins(y=0.3)
    np.atleast_1d(axes)[0].set_ylabel("solid fraction Φ")
    # below the panels: too wide for one, and it covered a panel's samples
    fig.legend(*np.atleast_1d(axes)[0].get_legend_handles_labels(), fontsize=8, loc="lower center", ncol=2)
    fig.tight_layout(rect=(0, 0.08, 1, 1))
    fig.savefig(path, dpi=120)
    plt.close(fig)
    return fig


if __name__ == "__main__":
    child_runs.stop_children_on_term()
    try:
        main()
    except (KeyboardInterrupt, child_runs.Interrupted):
        sys.exit(tool_exits.interrupted(pathlib.Path(__file__).name, "finished runs are kept, interrupted ones continue from "
                                                               "their last checkpoint"))
    except child_runs.RunFailed as error:
        sys.exit(tool_exits.failed(pathlib.Path(__file__).name, error))
