"""Reproduction campaign of the consolidation paper (not part of the test suite; hours of run time).

    python runner/consolidation_campaign.py [--samples 3] [--first-seed 1] [--count 1400] [--jobs 2] [--out campaign]
                                            [--scene consolidation ...] [--set key=value ...]

For each scene (type 2 without rolling resistance: models/consolidation.toml; with mu_R / a = 0.005:
models/consolidation-rr.toml) and each sample seed (1..samples unless --first-seed moves them), runs
`grains consolidate` (preparation, loading to P* = 13.33, unloading), `--jobs` samples at a time (Dask), each on
the threads the engine's automatic choice gives it (one per 2000 disks at most) within its share of the cores,
unless --threads says otherwise. A sample whose stage table already exists in --out is not run again if it ran the scene and
overrides given now (its HDF5 file says which; the thread count aside), else the campaign refuses, naming the
settings that differ; an unfinished one continues from its last checkpoint, so an interrupted campaign (Ctrl-C:
exit status 130) resumes when the same command runs again. Then it fits each sample's loading branch (runner/consolidation_fit.py) and prints
Phi and z at the first loading stage (P* = 0.01), lambda and Phimax, and the fractal dimension d_F of the
density correlations at P* = 0 and 0.01 (runner/density_correlations.py, from each sample's HDF5 file), as
mean +- sample standard deviation, against the paper's values (physics.md section 9 table and the paper's
section IV); and lambda and Phimax fitted to the loading curve averaged over the samples, with the fit's
standard errors, as the paper averages its data over the samples and fits the mean (its Fig. 11, Table III),
and their spread over --resamples resamplings of the samples (the mean curve rebuilt and refitted from samples
drawn with replacement), the uncertainty the fit's error leaves out. A value passes when the mean lies within twice the paper's error bar (where the paper gives
none, within 2 % for Phi and 5 % for z, lambda and d_F). The
table goes to OUT/summary.md, a plot of every sample's Phi(P*), the mean curve and its fit to OUT/campaign.png, every
sample's first compression (Phi against time in the P* = 0.01 stage, from its trace) to OUT/first-compression.png, and the finished
samples' scattering intensity I(k) at P* = 0, 0.01, 0.178 and 1, pooled per scene, to
OUT/SCENE-intensity.png and .csv, and their normal-force distributions (runner/force_distribution.py, the paper's
Figs. 18 and 19) to OUT/SCENE-forces.png and .csv.

With --report nothing is run: the summary is made from the tables already in --out, the finished ones and
the unfinished ones (SCENE-seedN.partial.csv, written stage by stage), which the table marks as partial;
it refuses tables run with other settings than those given, as a campaign does.
"""
import argparse
import functools
import math
import os
import pathlib
import subprocess
import sys

import numpy as np

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent))
from consolidation_fit import (BRANCH, FLAG, NUMBER, REDUCED_PRESSURE, SOLID_FRACTION, TEXT, StageTable, TableError,  # noqa: E402
                               crossover_curve, fit_crossover, fit_regime_two, guess_from_line)
import density_correlations  # noqa: E402
import force_distribution  # noqa: E402
from density_correlations import analyse, loading_frame, read_frames, target_pressure  # noqa: E402
import child_runs  # noqa: E402
import run_files  # noqa: E402
import run_reuse  # noqa: E402
import scene_check  # noqa: E402
import tool_args  # noqa: E402
import tool_exits  # noqa: E402
from stage_traces import first_compressions, plot_first_compressions  # noqa: E402

ROOT = pathlib.Path(__file__).resolve().parents[1]
# value, error bar (None: the paper gives only "about" or no bar)
# d_F: fractal dimension of the density correlations at P* = 0 and 0.01 (paper, section IV: 1.52 with
# rolling resistance at both; about 1.9 without, with blob sizes behaving "similarly" under load)
PAPER = {
    "consolidation": {"phi_0.01": (0.472, 0.008), "z_0.01": (3.1, None), "lambda": (0.349, 0.019), "phi_max": (0.7808, None),
                      "d_F_0": (1.9, None), "d_F_0.01": (1.9, None)},
    "consolidation-rr": {"phi_0.01": (0.524, 0.008), "z_0.01": (3.0, None), "lambda": (0.194, 0.004), "phi_max": (0.7745, None),
                         "d_F_0": (1.52, None), "d_F_0.01": (1.52, None)},
}
# The paper's fit of its mean loading curve (physics.md section 9 table): P0*, Phi0, lambda, Phimax, alpha; drawn
# beside ours, so the plot shows where the curves part, not only Phi(0.01).
PAPER_FIT = {"consolidation": (0.0237, 0.469, 0.349, 0.7808, 0.91), "consolidation-rr": (0.0316, 0.515, 0.194, 0.7745, 1.08)}
# P1*, where its regime II line meets Phimax, as its Table III states it (its parameters, rounded, give 0.272 and 0.904).
PAPER_P1 = {"consolidation": (0.271, 0.033), "consolidation-rr": (0.900, 0.064)}
RELATIVE_WHEN_NO_BAR = {"phi_0.01": 0.02, "z_0.01": 0.05, "lambda": 0.05, "phi_max": 0.02, "d_F_0": 0.05, "d_F_0.01": 0.05}


REPORTING = False   # main(): --report given


def consolidate(grains, scene_file, overrides, stem, label):
    """Runs `grains consolidate` on scene_file with the overrides unless STEM.csv exists; the table is
    written as STEM.partial.csv and renamed when the programme ends, the output goes to STEM.h5 and the
    console to STEM.log. A finished sample (STEM.csv) is taken only if it ran the scene and overrides given
    now (its STEM.h5 says which; the thread count aside), else run_reuse.Stale is raised. An interrupted run
    (its partial table and output left) continues from its last checkpoint (`grains resume`: a stage's end, or
    where Ctrl-C stopped it) if it was started with the same scene and overrides, or runs again from the start,
    over its file (`grains consolidate --overwrite`), when it was not or cannot. Raises child_runs.Interrupted
    when Ctrl-C stops the run. Returns the path of the table."""
    table = stem.with_suffix(".csv")
    partial, h5 = stem.with_suffix(".partial.csv"), stem.with_suffix(".h5")
    if problem := run_files.not_a_file_to_write(h5, "a sample's", label):   # below, an unfinished sample's file is replaced
        raise child_runs.RunFailed(problem)
    now = scene_check.resolve(grains, scene_file, overrides)
    if table.exists():
        differs = run_reuse.difference(now, h5) if h5.exists() else None   # no HDF5 file: an archived table (docs/)
        if differs:
            raise run_reuse.Stale(f"{table}: {differs}")
        return table
    if partial.exists() and h5.exists() and run_reuse.difference(now, h5) is None:
        if run_files.ended(h5):   # it ended, but the table was not renamed (the tool stopped just then)
            finish(partial, table, h5)
            return table
        print(f"  resuming {label} from its last checkpoint (log: {stem.with_suffix('.log')})", flush=True)
        with stem.with_suffix(".log").open("a") as log:
            code = child_runs.run_child([grains, "resume", h5], stdout=log, stderr=subprocess.STDOUT)
        if code == child_runs.INTERRUPTED:   # its checkpoint is kept for the next try
            raise child_runs.Interrupted(label)
        if code == 0:
            finish(partial, table, h5)
            print(f"  finished {label} (resumed)", flush=True)
            return table
    # An unfinished sample's file left here (other settings, or its resume failed) is replaced on purpose: grains
    # refuses to write over a programme it could resume unless told so. --overwrite rather than deleting it first:
    # grains replaces the file only once it has checked the scene and made the new one (FILE.part, renamed over it).
    cmd = [grains, "consolidate", scene_file, "--table", partial, "--out", h5, "--overwrite"]
    for o in overrides:
        cmd += ["--set", o]
    print(f"  started {label} (log: {stem.with_suffix('.log')})", flush=True)
    with stem.with_suffix(".log").open("w") as log:
        code = child_runs.run_child(cmd, stdout=log, stderr=subprocess.STDOUT)
    if code == child_runs.INTERRUPTED:
        raise child_runs.Interrupted(label)
    if code != 0:
        raise child_runs.RunFailed(f"{label}: grains consolidate exited with {code}; see {stem}.log")
    finish(partial, table, h5)
    print(f"  finished {label}", flush=True)
    return table


def finish(partial, table, h5):
    """A programme ended: its table takes its final name, and the HDF5 file names that one (the tools reading the
    file find the table by it)."""
    import h5py
    if not partial.is_file():   # a grains that ended well without writing it (another program given as --grains)
        raise child_runs.RunFailed(f"{table.stem}: the programme ended without its stage table {partial}; see "
                                   f"{table.with_suffix('.log')}")
    partial.rename(table)
    with h5py.File(h5, "r+") as f:
        f["grains"].attrs["stage_table"] = np.bytes_(table.name.encode())   # fixed length, as grains writes it


def refuse_occupied_names(ap, samples):
    """Before any sample runs (a report writes none): exits with status 2 when a sample's file name holds a folder
    or FIFO (run_files.not_a_file_to_write; checked again where each sample starts), which the campaign would
    otherwise meet only on reaching that sample, the samples before it run or under way. `samples` as
    check_samples'."""
    occupied = [problem for _, _, stem in samples
                if (problem := run_files.not_a_file_to_write(stem.with_suffix(".h5"), "a sample's", stem.name))]
    if occupied:
        ap.exit(2, f"{ap.prog}: error: " + "\n".join(occupied) + "\n")


def check_samples(ap, grains, samples, report=False):
    """Before anything runs: exits with status 2 when the engine refuses a sample's scene and overrides (its
    message), or when a finished sample in --out (with --report, an unfinished one too) ran other settings
    than those given now. `samples`: (scene file, overrides, stem) of each."""
    stale = []
    for scene_file, overrides, stem in samples:
        try:
            now = scene_check.resolve(grains, scene_file, overrides)
        except scene_check.SceneError as error:
            ap.exit(2, f"{ap.prog}: {error}\n")
        tables = [stem.with_suffix(".csv")] + ([stem.with_suffix(".partial.csv")] if report else [])
        table = next((t for t in tables if t.exists()), None)
        if table and not stem.with_suffix(".h5").exists():   # an archived table (docs/campaign-*) keeps no HDF5 file
            print(f"note: {table}: no {stem.name}.h5 beside it, so the settings it ran are not checked", file=sys.stderr)
            continue
        differs = table and run_reuse.difference(now, stem.with_suffix(".h5"))
        if differs:
            stale.append(f"  - {table}: {differs}")
    if stale:
        ap.exit(2, f"{ap.prog}: error: {len(stale)} sample(s) in --out were run with other settings than those given now "
                   f"(give another --out, or delete those samples' files to run them again):\n" + "\n".join(stale) + "\n")


def check_arguments(ap, args):
    """The checks shared with runner/initial_states.py: counts of at least 1, --out a folder (with --report it
    must exist; tool_args.make_out makes it once the samples' scenes passed check_samples), and an executable
    grains binary unless only reporting (the report checks it once it has found tables)."""
    tool_args.refuse_controlled(ap, args.set, {"particles.seed": "--first-seed and --samples", "particles.count": "--count",
                                               "run.threads": "--threads" if hasattr(args, "threads") else "one thread each"})
    for name, value in (("--samples", args.samples), ("--count", args.count), ("--jobs", args.jobs), ("--first-seed", args.first_seed)):
        if value < 1:
            ap.error(f"{name} = {value}: must be at least 1")
    out = pathlib.Path(args.out)
    tool_args.check_out(ap, out, args.report)
    if not args.report:
        tool_args.require_binary(ap, "--grains", args.grains)


def provenance(args, names):
    """The summary's first line: which samples, and the scene overrides they ran with (a table read later must
    say what protocol it measured)."""
    last = args.first_seed + args.samples - 1
    sets = " ".join(f"`--set {o}`" for o in args.set) or "none"
    return f"{', '.join(names)}: seeds {args.first_seed}–{last}, {args.count} disks; scene overrides: {sets}.\n\n"


# The engine's automatic thread count (run.threads = 0) allows one thread per this many particles: below it a
# second thread costs more than it brings (docs/speed.md, "Two threads on small systems").
PARTICLES_PER_THREAD = 2000


def default_threads(count, jobs, cores):
    """Threads per sample: the engine's automatic choice, within the cores each of `jobs` samples at once gets."""
    return max(1, min(cores // jobs, count // PARTICLES_PER_THREAD))


def sample(scene, seed, count, threads, overrides, out):
    """(scene file, overrides, stem) of one sample."""
    own = [f"particles.seed={seed}", f"particles.count={count}", f"run.threads={threads}"]
    return ROOT / "models" / f"{scene}.toml", own + list(overrides), out / f"{scene}-seed{seed}"


def run_sample(grains, scene, seed, count, threads, overrides, out):
    """Runs one sample unless its table exists; returns the path of its stage table."""
    return consolidate(grains, *sample(scene, seed, count, threads, overrides, out), f"{scene} seed {seed}")


def existing_table(out, scene, seed):
    """The sample's finished table, else its unfinished one, else None; and whether it is unfinished."""
    stem = out / f"{scene}-seed{seed}"
    for path, partial in ((stem.with_suffix(".csv"), False), (stem.with_suffix(".partial.csv"), True)):
        if path.exists():
            return path, partial
    return None, False


def summarise(table):
    """Phi and z at the first loading stage (reached or not), lambda and Phimax from the reached loading stages.
    None when the table has no loading stage yet (a sample still aggregating). TableError for a table that is no
    campaign's (a folder or FIFO at its name, a column missing, a value that is no number or out of range)."""
    stages = StageTable(table, empty=True)   # a sample's table stays empty until its first stage (the aggregation) ends
    if stages.header:
        stages.columns("branch", "reached", "P_star", "phi", "coordination", "phase")
    target = {"target_pressure": NUMBER} if "target_pressure" in stages.header else {}   # older tables have none
    stages.check({"phase": TEXT, "branch": BRANCH, "P_star": NUMBER, "phi": SOLID_FRACTION, "reached": FLAG,
                  "coordination": NUMBER, **target})
    rows = stages.rows
    fitted = [i for i, r in enumerate(rows) if r["branch"] == "loading" and r["reached"] == "1"]
    stages.check({"P_star": REDUCED_PRESSURE}, fitted)
    loading = [r for r in rows if r["branch"] == "loading"]
    if not loading:
        return None
    first = loading[0]
    reached = [r for r in loading if r["reached"] == "1"]
    p = np.array([float(r["P_star"]) for r in reached])
    phi = np.array([float(r["phi"]) for r in reached])
    result = {"phi_0.01": float(first["phi"]), "z_0.01": float(first["coordination"]),
              "first_reached": first["reached"] == "1", "lambda": math.nan, "phi_max": math.nan,
              "unreached": sum(r["reached"] != "1" for r in rows if r["phase"] != "aggregation"), "p": p, "phi": phi,
              "all_p": np.array([target_pressure(r) for r in loading]), "all_phi": np.array([float(r["phi"]) for r in loading]),
              "all_reached": np.array([r["reached"] == "1" for r in loading])}
    try:
        crossover = fit_loading(p, phi)
        result.update({"lambda": crossover["lambda"], "phi_max": crossover["phi_max"]})
    except (ValueError, RuntimeError) as error:   # too few equilibrated stages, or no convergence
        print(f"  {table.name}: no fit ({error})", flush=True)
    result.update(fractal_dimensions(table))
    return result


def fit_loading(p, phi):
    """The regimes II-III fit of a loading branch, started from the regime II line's values."""
    regime2 = fit_regime_two(p, phi)
    return fit_crossover(p, phi, guess=guess_from_line(regime2, phi))


def mean_curve(results):
    """The loading branch averaged over the samples, as the paper averages its data over the samples and fits
    the mean (its Fig. 11 and Table III): at each target P*, the mean P* and Phi of the samples in equilibrium
    there, kept where at least half of the samples are. Returns (P*, Phi, samples per stage)."""
    stages = {}
    for r in results:
        targets = r["all_p"][r["all_reached"]]   # in the order of r["p"], r["phi"]: both are the reached stages
        for target, p, phi in zip(targets, r["p"], r["phi"]):
            stages.setdefault(float(f"{target:.9g}"), []).append((p, phi))   # one programme: the same targets
    kept = sorted(k for k, v in stages.items() if 2 * len(v) >= len(results))
    p = np.array([np.mean([a for a, _ in stages[k]]) for k in kept])
    phi = np.array([np.mean([b for _, b in stages[k]]) for k in kept])
    return p, phi, [len(stages[k]) for k in kept]


def resampled_spread(results, resamples, seed=1, label=None):
    """The standard deviation of the mean curve's fitted values over resamples of the samples (drawn with
    replacement, the mean curve rebuilt and refitted each time): the spread between samples, which the fit's
    own error on one mean curve leaves out (on ten samples per law it was 2.5-4 times the fit's error).
    Returns ({key: sd}, fits that converged). With `label`, says how far it got (a fit takes seconds: 40 of them
    on two laws were minutes with nothing printed)."""
    rng = np.random.default_rng(seed)
    fits = []
    for k in range(resamples):
        if label and k % 10 == 0:
            print(f"  {label}: resample {k + 1}-{min(k + 10, resamples)} of {resamples}", file=sys.stderr, flush=True)
        pick = [results[i] for i in rng.integers(0, len(results), len(results))]
        try:
            fits.append(fit_loading(*mean_curve(pick)[:2]))
        except (ValueError, RuntimeError):   # too few stages kept, or a degenerate fit
            continue
    if len(fits) < 2:
        return {}, len(fits)
    return {k: float(np.std([f[k] for f in fits], ddof=1)) for k in ("lambda", "phi_max")}, len(fits)


def paper_curve(scene):
    """The paper's own loading curve (its Table III fit) at the programme's target pressures, 0.01 x 10^(k/8) up to
    13.33: (P*, Phi)."""
    p0, phi0, lam, phi_max, alpha = PAPER_FIT[scene]
    p = 0.01 * 10 ** (np.arange(0, 26) / 8)
    return p, 1 / crossover_curve(p, (1 / phi0, lam, phi_max, alpha), p0)


@functools.cache   # one fit per scene, however many rows quote it
def paper_line(scene):
    """lambda of the regime II line alone fitted to the paper's own curve at the programme's target pressures: what
    our line is to be compared with (0.3275 without rolling resistance, where the crossover's lambda is 0.349; 0.194
    with it)."""
    return fit_regime_two(*paper_curve(scene))["lambda"]


def regime_two_line(scene, p, phi):
    """Table row: lambda of the regime II line alone (P* <= 0.1, P0* found as the kink) of the mean curve, against
    the same line fitted to the paper's curve, with the paper's bar. The crossover form's lambda also answers for how
    soon the curve bends to Phimax; the line tells the start of the rise apart (docs/reproduction-consolidation.md)."""
    value, bar = paper_line(scene), PAPER[scene]["lambda"][1]
    paper = f"{value:.4f} ± {bar} (the paper's fitted curve's line)"
    try:
        line = fit_regime_two(p, phi)
    except ValueError as error:
        return f"| {scene} | lambda of the mean curve's regime II line alone (P* <= 0.1) | no fit ({error}) | {paper} | |"
    verdict = "yes" if abs(line["lambda"] - value) <= 2 * bar else "NO"
    return (f"| {scene} | lambda of the mean curve's regime II line alone (P* <= 0.1) | {line['lambda']:.4f} ± "
            f"{line['lambda_err']:.4f} (fit); {line['stages']} stages, P0* {line['P0']:.3g} | {paper} | {verdict} |")


def mean_curve_lines(scene, results, resamples=0):
    """Table rows: lambda and Phimax fitted to the mean loading curve, with the fit's standard errors and,
    with `resamples`, the spread over resampled samples, and the regime II line's lambda. The verdict compares the
    value with twice the paper's bar (the issue's criterion); the spread says how well our value itself is known."""
    p, phi, counts = mean_curve(results)
    try:
        fit = fit_loading(p, phi)
    except (ValueError, RuntimeError) as error:
        return [f"| {scene} | lambda, Phimax of the mean curve | no fit ({error}) | | |"]
    spread, converged = resampled_spread(results, resamples, label=scene) if resamples else ({}, 0)
    lines = []
    for key in ("lambda", "phi_max"):
        value, bar = PAPER[scene][key]
        allowed = 2 * bar if bar else RELATIVE_WHEN_NO_BAR[key] * value
        verdict = "yes" if abs(fit[key] - value) <= allowed else "NO"
        samples = f" ± {spread[key]:.4f} (samples, {converged} resamples)" if key in spread else ""
        lines.append(f"| {scene} | {key} of the mean curve | {fit[key]:.4f} ± {fit[key + '_err']:.4f} (fit){samples}; "
                     f"{len(p)} stages ({fit['stages']} from P0* on), {min(counts)}–{max(counts)} samples each | "
                     f"{value}{f' ± {bar}' if bar else ''} | {verdict} |")
    return lines + [regime_two_line(scene, p, phi)]


def fractal_dimensions(table):
    """d_F of the sample's snapshots at P* = 0 and 0.01 (runner/density_correlations.py, default fit),
    from the HDF5 file beside its table; NaN where the file or the stage is missing or unreadable (a
    sample still running)."""
    h5 = table.parent / (table.name.split(".")[0] + ".h5")
    found = {"d_F_0": math.nan, "d_F_0.01": math.nan}
    try:
        positions, radii, edges, p_star, _ = read_frames(h5)
    except (OSError, KeyError, ValueError):
        return found
    for key, target in (("d_F_0", 0.0), ("d_F_0.01", 0.01)):
        i = loading_frame(p_star, target)
        if i is not None:
            try:
                found[key] = analyse([(positions[i], radii[i], edges[i])])["d_F"]
            except ValueError:   # too small a cell for the fit's range: no d_F, not the campaign's end
                pass
    return found


def table_lines(scene, results, resamples=0):
    lines = []
    for key, (value, bar) in PAPER[scene].items():
        x = np.array([r.get(key, math.nan) for r in results], float)
        x = x[np.isfinite(x)]
        if x.size == 0:
            lines.append(f"| {scene} | {key} | no sample | {value} | – |")
            continue
        allowed = 2 * bar if bar else RELATIVE_WHEN_NO_BAR[key] * value
        spread = f" ± {x.std(ddof=1):.4f}" if x.size > 1 else ""
        verdict = "yes" if abs(x.mean() - value) <= allowed else "NO"
        lines.append(f"| {scene} | {key} | {x.mean():.4f}{spread} ({x.size}) | {value}{f' ± {bar}' if bar else ''} | {verdict} |")
    if len(results) > 1:
        lines += mean_curve_lines(scene, results, resamples)
    first = sum(r["first_reached"] for r in results)
    lines.append(f"| {scene} | P* = 0.01 stage in equilibrium | {first} of {len(results)} | | |")
    lines.append(f"| {scene} | stages not in equilibrium (all samples) | {sum(r['unreached'] for r in results)} | 0 | |")
    unfinished = sum(r.get("partial", False) for r in results)
    if unfinished:
        lines.append(f"| {scene} | samples whose programme had not finished | {unfinished} of {len(results)} | | |")
    return lines


def plot(summaries, path):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(figsize=(7, 4.5))
    colours = {"consolidation": "tab:blue", "consolidation-rr": "tab:red"}
    for scene, results in summaries.items():
        for k, r in enumerate(results):
            label = f"{scene} (open: not in equilibrium, at its target P*)" if k == 0 else None
            ax.plot(r["all_p"], r["all_phi"], "-", color=colours.get(scene), alpha=0.4, lw=1)
            ax.plot(r["p"], r["phi"], "o", color=colours.get(scene), ms=3, label=label)
            missed = ~r["all_reached"]
            ax.plot(r["all_p"][missed], r["all_phi"][missed], "o", mfc="none", color=colours.get(scene), ms=4)
        p, phi, _ = mean_curve(results) if len(results) > 1 else ([], [], [])
        if len(p):   # the mean curve and its fit, as the paper's Fig. 11 draws them (none: no stage to average)
            ax.plot(p, phi, "D", color=colours.get(scene), mec="black", ms=5, label=f"{scene}: mean over the samples")
            try:
                fit = fit_loading(p, phi)
                grid = np.geomspace(p.min(), p.max(), 200)
                inv = crossover_curve(grid, (1 / fit["phi0"], fit["lambda"], fit["phi_max"], fit["alpha"]), fit["P0"])
                ax.plot(grid, 1 / inv, "--", color=colours.get(scene), lw=1.5,
                        label=f"fit to the mean: λ = {fit['lambda']:.3g}, Φmax = {fit['phi_max']:.4g}")
            except (ValueError, RuntimeError):
                pass   # the table says why
        p0, phi0, lam, phi_max, alpha = PAPER_FIT[scene]
        grid = np.geomspace(0.01, 13.33, 200)   # the paper's programme
        inv = crossover_curve(grid, (1 / phi0, lam, phi_max, alpha), p0)
        ax.plot(grid, 1 / inv, ":", color=colours.get(scene), lw=1.5,
                label=f"paper {scene}: its fit, λ = {lam:.3g}, Φmax = {phi_max:.4g}")
        value, bar = PAPER[scene]["phi_0.01"]
        ax.errorbar([0.01], [value], yerr=[2 * bar], fmt="s", color=colours.get(scene), capsize=4, mfc="white",
                    label=f"paper {scene}, P* = 0.01 (±2 bars)")
    ax.set_xscale("log")
    ax.set_xlabel("P* = a P / F0")
    ax.set_ylabel("solid fraction Φ")
    ax.set_title("Type-2 consolidation, loading branch, every sample")
    ax.legend(fontsize=6.5)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)
    return fig


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--samples", type=int, default=3, help="samples per scene (default 3)")
    ap.add_argument("--first-seed", type=int, default=1, help="seeds FIRST_SEED .. FIRST_SEED + SAMPLES - 1 (default 1)")
    ap.add_argument("--count", type=int, default=1400, help="disks per sample (default 1400, the paper's)")
    ap.add_argument("--jobs", type=int, default=os.cpu_count() or 1, help="samples run at once (default: the cores)")
    ap.add_argument("--threads", type=int, default=0,
                    help=f"threads per sample (default: one per {PARTICLES_PER_THREAD} disks at most, as the engine's "
                         "automatic choice, within cores / jobs; at least 1)")
    ap.add_argument("--scene", action="append", choices=list(PAPER), help="scene to run (repeatable; default both)")
    ap.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                    help="scene override passed to every run, e.g. programme.stage_budget=1000000")
    ap.add_argument("--out", default="campaign", help="folder for tables, HDF5 files, logs, summary (default campaign)")
    ap.add_argument("--grains", default=str(ROOT / "build" / "runner" / "grains"), help="the grains binary (default: build/runner/grains)")
    ap.add_argument("--resamples", type=int, default=40,
                    help="resamples of the samples for the mean curve's spread (default 40, about a second each; 0: none)")
    ap.add_argument("--report", action="store_true",
                    help="run nothing: summarise the tables already in --out, unfinished ones included")
    args = ap.parse_args()
    global REPORTING
    REPORTING = args.report   # for the interruption's message (argparse takes --rep for --report too)
    if args.resamples < 0:
        ap.error(f"--resamples = {args.resamples}: must be 0 (none) or more")
    check_arguments(ap, args)
    threads = args.threads or default_threads(args.count, args.jobs, os.cpu_count() or 1)
    scenes = list(dict.fromkeys(args.scene)) if args.scene else list(PAPER)   # each once, in the order given
    seeds = range(args.first_seed, args.first_seed + args.samples)
    out = pathlib.Path(args.out)
    samples = [sample(scene, seed, args.count, threads, args.set, out) for scene in scenes for seed in seeds]

    if args.report:
        found = {(scene, seed): existing_table(out, scene, seed) for scene in scenes for seed in seeds}
        tables = {key: found[key][0] for key in found if found[key][0] is not None}
        partial = {key for key in found if found[key][1]}
        if not tables:   # as the other campaign tools do: nothing to summarise is an error, not an empty report
            ap.error(f"--report: no stage table of {', '.join(scenes)} for seeds {seeds.start}..{seeds.stop - 1} in {out}")
        tool_args.require_binary(ap, "--grains", args.grains)   # to say whether the tables ran what the summary will say they did
        check_samples(ap, args.grains, samples, report=True)
    else:
        refuse_occupied_names(ap, samples)
        check_samples(ap, args.grains, samples)
        tool_args.make_out(ap, out)
        import dask
        tasks = {(scene, seed): dask.delayed(run_sample)(args.grains, scene, seed, args.count, threads, args.set, out)
                 for scene in scenes for seed in seeds}
        print(f"campaign: {len(tasks)} samples of {args.count} disks, {args.jobs} at a time, {threads} thread(s) each, "
              f"logs in {out}/", flush=True)
        tables = dict(zip(tasks, dask.compute(*tasks.values(), scheduler="threads", num_workers=args.jobs)))
        partial = set()

    summaries = {}
    for scene in scenes:
        summaries[scene] = []
        for seed in seeds:
            if (scene, seed) not in tables:
                print(f"  {scene} seed {seed}: no table in {out}", flush=True)
                continue
            try:
                result = summarise(tables[(scene, seed)])
            except TableError as error:   # one line naming the table, the line and the value, not a traceback
                ap.exit(2, f"{ap.prog}: error: {error}\n")
            if result is None:
                print(f"  {scene} seed {seed}: no loading stage yet", flush=True)
                continue
            result["partial"] = (scene, seed) in partial
            summaries[scene].append(result)
    lines = ["| scene | quantity | measured: mean ± sd (samples) | paper | within 2× paper bar |", "|---|---|---|---|---|"]
    for scene in scenes:
        lines += table_lines(scene, summaries[scene], args.resamples)
    text = "\n".join(lines)
    print(text)
    (out / "summary.md").write_text(provenance(args, scenes) + text + "\n")
    plot(summaries, out / "campaign.png")
    print(f"wrote {out / 'summary.md'} and {out / 'campaign.png'}")
    # Every sample's first compression, from the traces of its file (finished or not): Phi against time.
    try:
        courses = {scene: first_compressions([out / f"{scene}-seed{seed}.h5" for seed in seeds if (scene, seed) in tables])
                   for scene in scenes}
    except (OSError, ValueError) as error:   # a sample's file damaged: the summary above stands, the figure is left out
        print(f"note: no first-compression figure: {error}", file=sys.stderr)
        courses = {}
    if any(courses.values()):
        plot_first_compressions(courses, out / "first-compression.png", {s: PAPER[s]["phi_0.01"] for s in scenes})
        print(f"wrote {out / 'first-compression.png'}")
    for scene in scenes:   # the samples' density correlations, pooled: OUT/SCENE-intensity.{csv,png}
        samples = []
        for seed in seeds:
            h5 = out / f"{scene}-seed{seed}.h5"
            if (scene, seed) in tables and (scene, seed) not in partial and h5.is_file():
                try:
                    samples.append((h5, *read_frames(h5)))
                except (OSError, KeyError, ValueError) as error:
                    print(f"  {h5.name}: no density correlations ({error})", flush=True)
        if samples:
            density_correlations.report(samples, [0.0, 0.01, 0.178, 1.0], out=out / f"{scene}-intensity.png",
                                        table=out / f"{scene}-intensity.csv")
            try:   # and their normal-force distributions: OUT/SCENE-forces.{csv,png}
                force_distribution.report([h5 for h5, *_ in samples], [0.01, 0.178, 1.0, 2.37], [2.37, 5.62, 13.3],
                                          out / f"{scene}-forces.png", out / f"{scene}-forces.csv")
            except (OSError, KeyError, ValueError) as error:
                print(f"  no force distributions ({error})", flush=True)


if __name__ == "__main__":
    child_runs.stop_children_on_term()
    try:
        main()
    except (KeyboardInterrupt, child_runs.Interrupted):
        if REPORTING:   # a report runs nothing: there is nothing to resume
            print(f"{pathlib.Path(__file__).name}: interrupted; nothing was run", file=sys.stderr)
            sys.exit(child_runs.INTERRUPTED)
        sys.exit(tool_exits.interrupted(pathlib.Path(__file__).name, "finished samples are kept, interrupted ones continue "
                                                               "from their last checkpoint"))
    except child_runs.RunFailed as error:
        sys.exit(tool_exits.failed(pathlib.Path(__file__).name, error))
