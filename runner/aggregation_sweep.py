"""The aggregation paper's campaigns: the cold cloud of models/aggregation.toml swept over the contact
damping ratio zeta and the normalised stiffness k* = k_n / k_g (physics.md sections 2, 8; not part of
the test suite: minutes to an hour of run time).

    python runner/aggregation_sweep.py [--damping Z ...] [--stiffness K ...] [--fixed-stiffness K]
                                       [--fixed-damping auto|Z] [--map] [--seeds 1] [--jobs 2] [--out sweep]
                                       [--set key=value ...] [--report]

Three sweeps, each point a `grains run` of the scene to its end (3 t_ff) with its own seed(s):
  - damping: zeta over --damping at k* = --fixed-stiffness (default: the scene's own, ~6.5e3);
  - stiffness: k* over --stiffness at zeta = --fixed-damping; `auto` (default) takes, as the paper does,
    the smallest swept zeta whose cloud ends as a dense aggregate (final N_c / N <= 0.05); `--stiffness`
    with no value leaves this sweep out;
  - with --map, every (zeta, k*) pair, for the map of the fractal dimension.
zeta sets the restitution e = exp(-pi zeta / sqrt(1 - zeta^2)) (0 <= zeta < 1) and k* the contact
duration t_c = sqrt(m* (pi^2 + ln^2 e) / (k* k_g)), m* = m / 2 and k_g = G m^2 / (4 R^3) of the scene's
grains (one size; with the --set overrides), so that the calibration (physics.md section 2) gives k_n = k* k_g; every run's own
k* (the `normalised_stiffness` observable) is checked against it. The time step stays t_c / n_c, so
stiffer contacts cost more steps (about sqrt(k*)). Where n_c is below what the engine's damped-packing
rule asks for at a point (the strongest dampings: `grains check` warns and names the steps per contact),
that point runs at the rule's n_c instead, and its files carry it (z0p9-k6469-n92-s1); --keep-step runs
every point at the scene's n_c. Where a point's time step is over twice the scene's (soft contacts), its
aggregation checks and records come as often in time as the scene's do, not every as many steps (tagged
a.. and o.. in its file names).

Per point (median over seeds): t_agg / t_ff, final N_c / N and f_max, D_f of the largest cluster, the
virial ratio Q's first peak and whether a second one follows. Writes OUT/sweep.csv, OUT/summary.md (the
paper's qualitative findings, each with what the sweep shows, and the points whose runs the engine
warned about, at start-up or while running: the energy check), OUT/damping.png, OUT/stiffness.png and,
with --map, OUT/map.png and OUT/virial-map.png (Q against time at every point of the map). A run whose output is complete is not run again, so an interrupted sweep
(Ctrl-C: exit status 130) resumes (the run it stopped runs again from its start, over its file: --overwrite), but
only if it ran the scene that would run now (its HDF5 file's
parameters/scene.toml; the thread count aside): else the sweep refuses, naming the settings that differ;
--report runs nothing.
"""
import argparse
import csv
import math
import os
import pathlib
import re
import subprocess
import sys

import numpy as np

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent))
import child_runs  # noqa: E402
import run_files  # noqa: E402
import run_reuse  # noqa: E402
import scene_check  # noqa: E402
import tool_args  # noqa: E402
import tool_exits  # noqa: E402

ROOT = pathlib.Path(__file__).resolve().parents[1]
SCENE = ROOT / "models" / "aggregation.toml"
DAMPING = [0.0, 0.002, 0.005, 0.01, 0.02, 0.05, 0.1, 0.2, 0.3, 0.5, 0.7, 0.9]
STIFFNESS = [1e1, 1e2, 1e3, 1e4, 1e5, 1e6]
DENSE = 0.05   # final N_c / N at or below which the cloud counts as one dense aggregate
UNDECIDED = "not decided: rests on runs that heated up (‡)"   # a finding's verdict when its figures heated up


def restitution(zeta):
    """e of the linear spring-dashpot with damping ratio zeta < 1 (physics.md section 2, inverted)."""
    return math.exp(-math.pi * zeta / math.sqrt(1 - zeta * zeta))


def damping_ratio(e):
    return -math.log(e) / math.sqrt(math.pi ** 2 + math.log(e) ** 2)


def grain(scene):
    """(m*, k_g) of the scene's grains (the scene as resolved with the overrides): the sweep converts k* for one
    grain size only."""
    p = scene["particles"]
    if p.get("size_distribution", "constant") != "constant":
        raise ValueError("particles: the sweep needs one grain size (particles.diameter), not a size distribution")
    m, radius, g = float(p.get("mass", 1.0)), float(p.get("diameter", 1.0)) / 2, float(scene["gravity"].get("G", 1.0))
    return m / 2, g * m * m / (4 * radius ** 3)


def contact_duration(zeta, k_star, m_star, k_g):
    ln_e = math.log(restitution(zeta))
    return math.sqrt(m_star * (math.pi ** 2 + ln_e ** 2) / (k_star * k_g))


def scene_point(scene, m_star, k_g):
    """(zeta, k*) of the scene as written."""
    e, t_c = float(scene["contact"]["restitution"]), float(scene["contact"]["duration"])
    return damping_ratio(e), m_star * (math.pi ** 2 + math.log(e) ** 2) / t_c ** 2 / k_g


# The per-point settings that name a run's files, with their tags: z0p9-k6469-n92-s1 ran at 92 steps per
# contact, z0p1-k10-a4o8-s1 with its analysis every 4 steps and its records every 8.
RUN_TAGS = {"time.steps_per_contact": "n", "analysis.every": "a", "output.observables_every": "o"}


def stiffness_tag(k_star):
    """k* as run names carry it: four digits."""
    return f"{k_star:.4g}"


def run_name(zeta, k_star, seed, own=None):
    """File stem of a run, without dots (zeta 0.05, k* 6468.8, seed 1: z0p05-k6469-s1), tagged with the
    settings of its own (`own`, a dict over RUN_TAGS' keys) when it has any."""
    tags = "".join(f"{tag}{own[key]}" for key, tag in RUN_TAGS.items() if own and key in own)
    return f"z{zeta:g}-k{stiffness_tag(k_star)}{'-' + tags if tags else ''}-s{seed}".replace(".", "p")


def point_settings(zeta, k_star, m_star, k_g):
    return [f"contact.restitution={restitution(zeta):.17g}",
            f"contact.duration={contact_duration(zeta, k_star, m_star, k_g):.17g}"]


def stable_steps_per_contact(grains, zeta, k_star, m_star, k_g, overrides):
    """The steps per contact the engine's damped-packing rule asks for at this point, if more than the scene
    (with the overrides) takes; else None. `grains check` applies the rule and names the number in its warning."""
    cmd = [str(grains), "check", str(SCENE)]
    for s in [*point_settings(zeta, k_star, m_star, k_g), *overrides]:
        cmd += ["--set", s]
    done = subprocess.run(cmd, capture_output=True, text=True)
    if done.returncode != 0:
        raise scene_check.SceneError(f"zeta {zeta:g}, k* {k_star:g}: {done.stderr.strip()}")
    found = re.search(r"time\.steps_per_contact (\d+) or more", done.stderr)
    if not found and "damped contacts" in done.stderr:   # the warning is there but its wording changed
        raise RuntimeError(f"zeta {zeta}: cannot read the steps per contact from grains check's warning: {done.stderr.strip()}")
    return int(found.group(1)) if found else None


# What a run writes unless the --set overrides say otherwise: no snapshots (a sweep reads only the observables).
RUN_DEFAULTS = {"output.snapshots_every": "0"}


def run_settings(zeta, k_star, seed, m_star, k_g, threads, overrides, own=None):
    """The --set settings of a run, each key once (grains refuses a key given twice with two values). The point's
    own settings (`own`: steps per contact, cadences) replace the scene's and any override's; an override replaces
    the sweep's defaults (RUN_DEFAULTS)."""
    if own:
        overrides = [s for s in overrides if s.split("=", 1)[0].strip() not in own] + [f"{k}={v}" for k, v in own.items()]
    given = {s.split("=", 1)[0].strip() for s in overrides}
    defaults = [f"{k}={v}" for k, v in RUN_DEFAULTS.items() if k not in given]
    return [*point_settings(zeta, k_star, m_star, k_g), f"particles.seed={seed}", f"run.threads={threads}",
            *defaults, *overrides]


def not_a_run_name(h5):
    """Why the sweep cannot write a run at `h5`, or None (run_files.not_a_file_to_write)."""
    return run_files.not_a_file_to_write(h5, "a run's", "that point")


def run_point(grains, zeta, k_star, seed, m_star, k_g, threads, overrides, out, own=None):
    """One run unless its complete output exists (main has checked that such a run ran the settings asked for
    now); returns the path of its HDF5 file. Raises child_runs.RunFailed when the run's name holds something other
    than a file (not_a_run_name)."""
    stem = out / run_name(zeta, k_star, seed, own)
    h5 = out / f"{stem.name}.h5"
    if h5.exists() and run_files.ended(h5):
        return h5
    if problem := not_a_run_name(h5):   # checked by main before any run; here too, as this is where it would go
        raise child_runs.RunFailed(problem)
    # An interrupted run's file is run again from the start, on purpose (grains refuses to write over a run it could
    # resume unless told so). --overwrite rather than deleting it first: grains replaces the file only once it has
    # checked the scene and made the new one (FILE.part, renamed over it).
    cmd = [str(grains), "run", str(SCENE), "--out", str(h5), "--quiet", "--overwrite"]
    for s in run_settings(zeta, k_star, seed, m_star, k_g, threads, overrides, own):
        cmd += ["--set", s]
    with (out / f"{stem.name}.log").open("w") as log:
        code = child_runs.run_child(cmd, stdout=log, stderr=subprocess.STDOUT)
    if code == child_runs.INTERRUPTED:
        raise child_runs.Interrupted(stem.name)
    if code != 0:
        raise child_runs.RunFailed(f"zeta {zeta}, k* {k_star:g}, seed {seed}: grains run exited with {code}; see {stem}.log")
    print(f"  finished zeta {zeta:g}, k* {k_star:g}, seed {seed}", flush=True)
    return h5


def virial_peaks(t, q):
    """The first peak of Q(t / t_ff) (its height and time) and the height of a second one.

    The first peak is the first local maximum that stands out: the highest Q before Q first falls 20 % below
    it (to 1 / 1.2 of it, the margin that counts a second peak), among maxima that reach 10 % of Q's highest
    value, so that neither noise on the rise nor an early bump of a few collisions counts; Q's highest value
    when Q never falls so. (Not always Q's highest value: a later, higher peak, or a run that heats up, would
    be taken for the first.) The second is the point after the first peak that stands highest
    above the lowest Q between them, counted as a peak when it rises at least 20 % above that low and reaches
    1 % of the first peak (else 0: a decay, or noise at the level of a frozen aggregate)."""
    t, q = np.asarray(t, float), np.asarray(q, float)
    fall, floor = 1.2, 0.1
    highest = np.maximum.accumulate(q)   # Q's highest value so far
    fallen = np.flatnonzero((q * fall <= highest) & (highest >= floor * np.max(q)) & (highest > 0))
    first = int(np.argmax(q[:fallen[0] + 1])) if fallen.size else int(np.argmax(q))
    after = q[first:]
    lowest = np.minimum.accumulate(after)
    rise = np.divide(after, lowest, out=np.ones_like(after), where=lowest > 0)
    j = int(np.argmax(rise))
    second = after[j] if rise[j] >= fall and after[j] >= 0.01 * q[first] else 0.0
    return q[first], t[first], float(second)


def measure(h5, k_star):
    """The point's observables from one run's HDF5 file."""
    import h5py
    with h5py.File(h5, "r") as f:
        o = f["observables"]

        def series(name):
            return o[name]["value"][()]

        achieved = float(series("normalised_stiffness")[-1])
        if not math.isclose(achieved, k_star, rel_tol=1e-6):
            raise ValueError(f"{h5.name}: the run's k* is {achieved:.6g}, not the requested {k_star:.6g}")
        t_ff = float(series("free_fall_time")[-1])
        q1, t1, q2 = virial_peaks(series("time_over_free_fall"), series("virial_ratio"))
        warnings = [w.decode() if isinstance(w, bytes) else str(w) for w in f["grains/warnings"][()]] \
            if "grains/warnings" in f else []
        return {"warnings": warnings,"t_agg_over_t_ff": float(series("aggregation_time")[-1]) / t_ff,
                "cluster_index": float(series("cluster_index")[-1]),
                "largest_cluster_fraction": float(series("largest_cluster_fraction")[-1]),
                "fractal_dimension": float(series("fractal_dimension")[-1]),
                "q_first_peak": float(q1), "q_first_peak_time": float(t1), "q_second_peak": float(q2),
                "t": series("time_over_free_fall"), "q": series("virial_ratio")}


def median_point(runs):
    """Medians over seeds (NaN aggregation times count as never: the median is NaN when half or more are)."""
    keys = ["t_agg_over_t_ff", "cluster_index", "largest_cluster_fraction", "fractal_dimension", "q_first_peak",
            "q_first_peak_time", "q_second_peak"]
    point = {}
    for k in keys:
        values = np.array([r[k] for r in runs], float)
        if k == "t_agg_over_t_ff":
            values = np.where(np.isnan(values), np.inf, values)
            m = float(np.median(values))
            point[k] = m if math.isfinite(m) else math.nan
        else:
            point[k] = float(np.nanmedian(values)) if np.any(np.isfinite(values)) else math.nan
    point["seeds"] = len(runs)
    point["warned_runs"] = sum(bool(r["warnings"]) for r in runs)
    point["heated_runs"] = sum(heated(r["warnings"]) for r in runs)
    point["warnings"] = sorted({w if len(w) <= 160 else w[:159] + "…" for r in runs for w in r["warnings"]})
    point["t"], point["q"] = runs[0]["t"], runs[0]["q"]
    return point


def heated(warnings):
    """Whether the engine's energy check found the run's total energy rising: its integration was not resolved
    (at soft contacts, grains that gravity pushes through each other), and its figures are not the model's."""
    return any(w.startswith("energy check") for w in warnings)


def marked(p, text):
    """A point's figure in the findings, marked ‡ when the median includes runs that heated up."""
    return f"{text}‡" if p.get("heated_runs") else text


TOO_FEW = "not decided: a rank correlation needs 3 points or more, with a spread"


def verdict(holds, tested):
    """yes or no, or, when a point the verdict turns on heated up, not decided."""
    if any(p.get("heated_runs") for p in tested):
        return UNDECIDED
    return "yes" if holds else "no"


def warned_points(points):
    """Lines naming the points whose runs the engine warned about (at start-up, a time step past one of its
    rules; while running, the energy check: E rose, the run heats itself; their figures, late ones above all,
    are not to be trusted), or none."""
    warned = {(p["zeta"], p["k_star"]): p for p in points if p["warned_runs"]}
    if not warned:
        return []
    lines = ["", "Runs the engine warned about (see their logs; e.g. a time step past the damped-packing rule with "
                 "--keep-step, to be rerun with --set time.steps_per_contact=N as the warning says, or an energy check: "
                 "contacts too soft for the gravitational load):"]
    for (z, k), p in sorted(warned.items()):
        lines.append(f"- zeta {z:g}, k* {k:.3g}: {p['warned_runs']} of {p['seeds']} run(s); {'; '.join(p['warnings'])}")
    return lines


def raised_points(points, scene_steps):
    """A line naming the dampings that ran at the damped-packing rule's steps per contact, or none."""
    raised = sorted({(p["zeta"], p["steps_per_contact"]) for p in points if p["steps_per_contact"] != scene_steps})
    if not raised:
        return []
    return ["", f"Run at the steps per contact the engine's damped-packing rule asks for (the scene takes {scene_steps}): "
                + ", ".join(f"zeta {z:g} at {n}" for z, n in raised) + "."]


def spearman(x, y):
    """Spearman's rank correlation of the finite pairs, ties sharing their mean rank (NaN with fewer than 3, or
    when one side is constant)."""
    from scipy.stats import rankdata
    x, y = np.asarray(x, float), np.asarray(y, float)
    keep = np.isfinite(x) & np.isfinite(y)
    if keep.sum() < 3:
        return math.nan
    rx, ry = rankdata(x[keep]), rankdata(y[keep])
    if rx.std() == 0 or ry.std() == 0:
        return math.nan
    return float(np.corrcoef(rx, ry)[0, 1])


def findings(damping, stiffness, fixed_stiffness, fixed_damping):
    """The paper's qualitative findings (physics.md section 8), each with what the sweep shows. A figure whose
    runs heated up is marked ‡, and a finding that turns on such a figure is not decided."""
    def listed(points, key, form, axis):   # "0.70 (zeta 0.1), ..." or "... (k* 1e+03)", each heated figure marked
        label, axis_form = ("zeta", "g") if axis == "zeta" else ("k*", ".3g")
        return ", ".join(f"{marked(p, format(p[key], form))} ({label} {p[axis]:{axis_form}})" for p in points)
    lines = ["| paper's finding | this sweep | holds |", "|---|---|---|"]
    z = [p["zeta"] for p in damping]
    t_agg = [p["t_agg_over_t_ff"] for p in damping]
    index = [p["cluster_index"] for p in damping]
    rho = spearman(z, t_agg)   # rank correlation over the points that aggregate
    defined = [p for p in damping if math.isfinite(p["t_agg_over_t_ff"])]
    correlation = f"rank correlation with zeta {rho:+.2f}" if math.isfinite(rho) else "no rank correlation"
    lines.append(f"| t_agg / t_ff falls as damping grows (k* = {fixed_stiffness:.3g}) | {correlation} over "
                 f"{len(defined)} point(s) where the cloud aggregates; {listed(defined, 't_agg_over_t_ff', '.2f', 'zeta')} "
                 f"| {verdict(rho < -0.5, defined) if math.isfinite(rho) else TOO_FEW} |")
    def enough(needed, points, holds, tested):   # a trend needs points enough to show one
        return verdict(holds, tested) if len(points) >= needed else f"not decided: needs {needed} points or more"

    rises = max((b - a for a, b in zip(index, index[1:])), default=0.0)
    crossing = next((f"{z[i]:g}–{z[i + 1]:g}" for i in range(len(z) - 1) if index[i] > 0.5 >= index[i + 1]), "")
    lines.append(f"| N_c / N falls (logistically) from ~1 to ~0 with damping | {listed(damping, 'cluster_index', '.3f', 'zeta')}; "
                 f"{'crosses 0.5 between zeta ' + crossing if crossing else 'does not cross 0.5'}; "
                 f"{f'largest rise between neighbours {rises:+.3f}' if rises > 0 else 'no rise between neighbours'} "
                 f"| {enough(3, damping, index[0] > 0.5 and index[-1] < 0.1 and rises <= 0.05, damping)} |")
    second = [p["q_second_peak"] > 0 for p in damping]
    lines.append(f"| Q: a first peak in every run, a second for all but the strongest damping | first peaks "
                 f"{min(p['q_first_peak'] for p in damping):.3g}–{max(p['q_first_peak'] for p in damping):.3g}; "
                 f"a second peak at zeta {', '.join(marked(p, format(p['zeta'], 'g')) for p, s in zip(damping, second) if s) or 'none'} "
                 f"| {enough(2, damping, all(second[:-1]) and not second[-1], damping)} |")
    def intermediate(holds, tested):   # a minimum at an intermediate k* needs a point on either side of it
        return verdict(holds, tested) if len(stiffness) >= 3 else "not decided: an intermediate k* needs 3 points or more"

    if stiffness:
        ki = [p["cluster_index"] for p in stiffness]
        kt = [p["t_agg_over_t_ff"] for p in stiffness]
        low = int(np.argmin(ki))
        soft, stiff = stiffness[0], stiffness[-1]
        lines.append(f"| vs k* (zeta = {fixed_damping:g}): N_c / N high when soft, lowest at an intermediate k* "
                     f"| {listed(stiffness, 'cluster_index', '.3f', 'k_star')} "
                     f"| {intermediate(0 < low < len(ki) - 1 and ki[0] > 0.5 and ki[-1] > ki[low], [soft, stiffness[low], stiff])} |")
        lines.append(f"| ... and rising toward ~0.6 for very stiff contacts | {marked(stiff, format(ki[-1], '.3f'))} at k* "
                     f"{stiff['k_star']:.3g} | {enough(2, stiffness, ki[-1] >= 0.3, [stiff])} |")
        finite = [p for p in stiffness if math.isfinite(p["t_agg_over_t_ff"])]
        best = min(range(len(kt)), key=lambda i: kt[i] if math.isfinite(kt[i]) else math.inf)
        minimum = bool(finite) and 0 < best < len(kt) - 1 and math.isfinite(kt[0]) and math.isfinite(kt[-1])
        lines.append(f"| t_agg / t_ff has a minimum at an intermediate k* | "
                     f"{listed(finite, 't_agg_over_t_ff', '.2f', 'k_star') or 'no aggregation'} | {intermediate(minimum, finite)} |")
    return lines


def pyplot():
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    return plt


def plot_q(ax, points, colours):
    """Q(t / t_ff) of each point's first seed, coloured by its zeta."""
    for p in sorted(points, key=lambda p: p["zeta"]):
        ax.plot(p["t"], p["q"], color=colours[p["zeta"]], lw=1, label=f"ζ = {p['zeta']:g}")
    ax.set_yscale("log")
    ax.set_xlabel("t / t_ff")


def plot_sweep(points, x_key, title, path):
    """N_c / N and t_agg / t_ff against the swept parameter; for the damping sweep also Q(t / t_ff)."""
    plt = pyplot()
    damping = x_key == "zeta"
    fig, axes = plt.subplots(1, 3 if damping else 2, figsize=(13 if damping else 9, 4))
    x = [p[x_key] for p in points]
    axes[1].sharex(axes[0])   # both against the same range, with the points that have no t_agg
    for ax, key, label in zip(axes, ("cluster_index", "t_agg_over_t_ff"), ("final N_c / N", "t_agg / t_ff")):
        ax.plot(x, [p[key] for p in points], "o-")
        never = [p[x_key] for p in points if not math.isfinite(p[key])]
        if never:   # no aggregation time (NaN): marked at the panel's top, where the line just left them out
            ax.plot(never, [0.95] * len(never), "v", color="0.4", transform=ax.get_xaxis_transform(),
                    label="never aggregated (f_max < threshold to the end)" if key == "t_agg_over_t_ff" else "no value")
            ax.legend(fontsize=7)
        hot = [p for p in points if p.get("heated_runs")]   # figures of runs that heated up: ringed, not trusted
        if hot:
            ax.plot([p[x_key] for p in hot], [p[key] for p in hot], "o", ms=11, mfc="none", mec="red",
                    label="runs heated up (energy rose)")
            ax.legend(fontsize=7)
        ax.set_ylabel(label)
        ax.set_xlabel("damping ratio ζ" if damping else "k* = k_n / k_g")
        if damping:
            ax.set_xscale("symlog", linthresh=0.01)   # zeta = 0 and the small zeta of the transition both visible
        else:
            ax.set_xscale("log")
        if len(set(x)) == 1 and x[0] > 0:   # one point (a report on a sweep in part): a range around it, not none
            ax.set_xlim(x[0] / 3, x[0] * 3)
    if damping:
        plot_q(axes[2], points, dict(zip(x, plt.cm.viridis(np.linspace(0, 0.9, len(points))))))
        axes[2].set_ylabel("Q = K / |W| (first seed)")
        axes[2].legend(fontsize=6, ncol=2)
    fig.suptitle(title)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return fig


def plot_map(points, damping, stiffness, path):
    """Maps over (k*, zeta) of D_f of the largest cluster and of the final N_c / N."""
    plt = pyplot()
    fig, axes = plt.subplots(1, 2, figsize=(12, 5))
    for ax, key, label, limits in ((axes[0], "fractal_dimension", "D_f of the largest cluster (blank: none)", (1, 3.05)),
                                   (axes[1], "cluster_index", "final N_c / N", (0, 1))):
        grid = np.full((len(damping), len(stiffness)), np.nan)
        for p in points:
            grid[damping.index(p["zeta"]), stiffness.index(p["k_star"])] = p[key]
        # (D_f up to 3.05: the fits of compact aggregates scatter a little above 3)
        image = ax.imshow(grid, origin="lower", aspect="auto", cmap="viridis", vmin=limits[0], vmax=limits[1])
        for p in points:
            x, y = stiffness.index(p["k_star"]), damping.index(p["zeta"])
            # a value beyond the colour scale (D_f below 1: a cluster sunk into the softened core) is written in its
            # cell: its colour alone said 1. No value (NaN: no cluster) is a blank cell, not a number ("nan" was
            # written there, white on white, and pushed the cell's dagger off centre)
            outside = math.isfinite(p[key]) and not limits[0] <= p[key] <= limits[1]
            if outside:
                ax.text(x, y + 0.22, f"{p[key]:.2f}", ha="center", va="center", color="white", fontsize=7)
            if p.get("heated_runs"):   # runs that heated up (energy rose): their figures are not the model's
                ax.text(x, y - 0.22 if outside else y, "‡", ha="center", va="center", color="red")
        ax.set_xticks(range(len(stiffness)), [f"{k:.0e}" for k in stiffness], rotation=45)
        ax.set_yticks(range(len(damping)), [f"{z:g}" for z in damping])
        ax.set_xlabel("k*")
        ax.set_ylabel("ζ")
        fig.colorbar(image, ax=ax, label=label, extend="both" if key == "fractal_dimension" else "neither")
    fig.suptitle("At 3 t_ff, median of the seeds (‡: runs that heated up; a number: D_f outside the colour scale)")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return fig


def stiffness_shapes(grid, damping, stiffness):
    """The map's rows (one zeta each) where N_c / N has the paper's shape against k*: above 0.5 at the
    softest, lowest at an intermediate k*, back above 0.3 at the stiffest; a finding line. A row whose shape
    turns on runs that heated up is marked and does not count."""
    rows, counted = [], 0
    for z in dict.fromkeys(damping):
        row = sorted((p for p in grid if p["zeta"] == z), key=lambda p: p["k_star"])
        if not row:   # a report on a map in part
            continue
        ki = [p["cluster_index"] for p in row]
        low = int(np.argmin(ki))
        if 0 < low < len(ki) - 1 and ki[0] > 0.5 and ki[-1] >= 0.3:
            rows.append(f"zeta {z:g} ({', '.join(marked(p, format(v, '.3f')) for p, v in zip(row, ki))})")
            counted += not any(p.get("heated_runs") for p in (row[0], row[low], row[-1]))
    holds = "yes" if counted else UNDECIDED if rows else "no"
    return (f"| the same shape anywhere on the map (k* {', '.join(f'{k:.0e}' for k in dict.fromkeys(stiffness))}) "
            f"| {'; '.join(rows) or 'no row has that shape'} | {holds} |")


def virial_shapes(grid, stiffness):
    """The paper's Q finding column by column of the map: at each k*, the dampings whose Q rises to a second
    peak, and whether they are all but the strongest (a finding line; a column with runs that heated up,
    marked, does not count)."""
    columns, holds = [], []
    for k in dict.fromkeys(stiffness):
        column = sorted((p for p in grid if p["k_star"] == k), key=lambda p: p["zeta"])
        peaked = [p for p in column if p["q_second_peak"] > 0]
        columns.append(f"k* {k:.0e}: {', '.join(marked(p, format(p['zeta'], 'g')) for p in peaked) or 'none'}")
        # the paper's pattern: the weakest dampings (three or more, from the weakest on) have one, the rest none
        if (len(peaked) >= 3 and peaked == column[:len(peaked)] and len(peaked) < len(column)
                and not any(p.get("heated_runs") for p in column)):
            holds.append(f"{k:.0e} (ζ up to {peaked[-1]['zeta']:g}, none above)")
    return (f"| Q's second peak on the map (the paper: for all but the strongest damping; here the ζ with one, per k*) "
            f"| {'; '.join(columns)} | {'at k* ' + ', '.join(holds) if holds else 'no'} |")


def plot_virial_map(points, damping, stiffness, path):
    """Q(t / t_ff) of the first seed at every point of the map, one panel per k*."""
    plt = pyplot()
    cols = min(3, len(stiffness))
    rows = (len(stiffness) + cols - 1) // cols
    fig, axes = plt.subplots(rows, cols, figsize=(4.5 * cols, 3.4 * rows), squeeze=False, sharey=True)
    colours = dict(zip(damping, plt.cm.viridis(np.linspace(0, 0.9, len(damping)))))
    for ax, k in zip(axes.flat, stiffness):
        plot_q(ax, [p for p in points if p["k_star"] == k], colours)
        ax.set_title(f"k* = {k:.0e}", fontsize=9)
    for ax in axes[:, 0]:
        ax.set_ylabel("Q = K / |W|")
    for ax in list(axes.flat)[len(stiffness):]:
        ax.axis("off")
    axes.flat[0].legend(fontsize=6, ncol=2)
    fig.suptitle("Virial ratio over the map (first seed)")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0].split("\n    python")[0].replace("\n", " "))
    ap.add_argument("--damping", type=float, nargs="+", default=DAMPING,
                    help=f"damping ratios zeta in [0, 1) of the damping sweep (default: {' '.join(map(str, DAMPING))})")
    # The stiffness sweep follows the damping sweep unless asked not to: a user who gave two dampings got eight runs.
    ap.add_argument("--stiffness", type=float, nargs="*", default=STIFFNESS,
                    help="normalised stiffnesses k* > 0 of the stiffness sweep, which follows the damping sweep "
                         f"(default: {' '.join(f'{k:g}' for k in STIFFNESS)}); --stiffness with no value: the damping sweep alone (no --map or --fixed-damping)")
    ap.add_argument("--fixed-stiffness", type=float, help="k* of the damping sweep (default: the scene's)")
    ap.add_argument("--fixed-damping", default="auto", help="zeta of the stiffness sweep, or auto (default)")
    ap.add_argument("--map", action="store_true", help="also every (zeta, k*) pair, for the fractal-dimension map")
    ap.add_argument("--seeds", type=int, default=1, help="seeds per point, 1..N (default 1)")
    ap.add_argument("--jobs", type=int, default=os.cpu_count() or 1, help="runs at once (default: the cores)")
    ap.add_argument("--threads", type=int, default=0, help="threads per run (default: cores / jobs, at least 1)")
    ap.add_argument("--set", action="append", default=[], metavar="KEY=VALUE", help="scene override for every run")
    ap.add_argument("--out", default="sweep", help="folder for the runs, table, summary and plots (default sweep)")
    ap.add_argument("--grains", default=str(ROOT / "build" / "runner" / "grains"), help="the grains binary (default: build/runner/grains)")
    ap.add_argument("--keep-step", action="store_true",
                    help="run every point at the scene's steps per contact, even past the damped-packing rule")
    ap.add_argument("--report", action="store_true", help="run nothing: summarise the runs already in --out (give the same --set as the runs)")
    args = ap.parse_args(argv)
    for z in args.damping:
        if not 0 <= z < 1:
            ap.error(f"--damping: {z} is outside [0, 1) (zeta >= 1 has no restitution above 0)")
    for k in args.stiffness + ([args.fixed_stiffness] if args.fixed_stiffness is not None else []):
        if not (k > 0 and math.isfinite(k)):
            ap.error(f"--stiffness / --fixed-stiffness: {k}; k* must be positive and finite")
    if args.fixed_damping != "auto":
        try:
            fixed = float(args.fixed_damping)
        except ValueError:
            ap.error(f"--fixed-damping: {args.fixed_damping!r}; give auto or a number in [0, 1)")
        if not 0 <= fixed < 1:
            ap.error(f"--fixed-damping: {fixed} is outside [0, 1)")
    if not args.stiffness:   # --stiffness with no value: no stiffness sweep, so nothing these would act on
        for asked, name in ((args.map, "--map (every --damping with every --stiffness)"),
                            (args.fixed_damping != "auto", f"--fixed-damping {args.fixed_damping} (the stiffness sweep's zeta)")):
            if asked:
                ap.error(f"{name} needs stiffnesses, but --stiffness was given no value (the damping sweep alone): "
                         "give --stiffness values or leave it out")
    for name, value in (("--seeds", args.seeds), ("--jobs", args.jobs)):
        if value < 1:
            ap.error(f"{name} = {value}: must be at least 1")
    out = pathlib.Path(args.out)
    tool_args.check_out(ap, out, args.report)
    if args.threads < 0:
        ap.error(f"--threads = {args.threads}: must be 0 (automatic) or more")
    tool_args.refuse_controlled(ap, args.set, {"contact.restitution": "--damping, --fixed-damping",
                                               "contact.duration": "--stiffness, --fixed-stiffness",
                                               "particles.seed": "--seeds", "run.threads": "--threads"})
    # grains resolves the scene with the overrides, applies the damped-packing rule and says what the runs ran
    if not pathlib.Path(args.grains).is_file():
        ap.error(f"--grains {args.grains}: no such file (build first: cmake --build build)")
    if not os.access(args.grains, os.X_OK):
        ap.error(f"--grains {args.grains}: not executable")
    try:
        scene = scene_check.resolve(args.grains, SCENE, args.set)   # the grain's mass, size and G with the overrides
        m_star, k_g = grain(scene)
    except (scene_check.SceneError, ValueError) as error:
        ap.exit(2, f"{ap.prog}: {error}\n")
    fixed_stiffness = args.fixed_stiffness or scene_point(scene, m_star, k_g)[1]
    # Run names carry k* to 4 digits: values that name their runs alike are one point, the first one's (the
    # scene's k* = 6468.79 and a --stiffness 6469 were two points under one name, and the second was refused
    # as a run with other settings).
    named = {}
    def one_per_name(k):
        kept = named.setdefault(stiffness_tag(k), k)
        if kept != k:
            print(f"note: k* = {k:g} names its runs as k* = {kept:g} does: taken as that point", flush=True)
        return kept
    fixed_stiffness = one_per_name(fixed_stiffness)
    # The findings read the sweeps in order (the weakest damping first, the strongest last; the softest contacts
    # first): values are taken sorted, each once (a given order decided the verdicts; a value given twice was announced
    # as two points and run as one).
    def in_order(values, name):
        kept = sorted(dict.fromkeys(values))
        if len(kept) < len(values):
            print(f"note: {name} values given more than once are one point each: {len(kept)} points", flush=True)
        return kept
    args.damping = in_order(args.damping, "--damping")
    args.stiffness = in_order([one_per_name(k) for k in args.stiffness], "--stiffness")
    threads = args.threads or max(1, (os.cpu_count() or 1) // args.jobs)
    seeds = range(1, args.seeds + 1)
    def setting(key):   # the scene's value of a [section] key, with the overrides
        section, name = key.split(".")
        return int(scene[section][name])

    scene_steps = setting("time.steps_per_contact")
    scene_dt = float(scene["contact"]["duration"]) / scene_steps

    rule = {}

    def own_settings(z, k):
        """What the point runs with of its own: the damped-packing rule's steps per contact where the scene's are
        too few, and, where its time step is more than twice the scene's (soft contacts), the analysis and the
        records as often in time as the scene has them (their steps scaled down): at k* = 10 the scene's 100
        steps between checks would be 0.44 t_ff."""
        own = {}
        if not args.keep_step and z not in rule:   # the rule's steps per contact depend on zeta alone
            rule[z] = stable_steps_per_contact(args.grains, z, k, m_star, k_g, args.set)
        n = None if args.keep_step else rule[z]
        if n:
            own["time.steps_per_contact"] = n
        dt = contact_duration(z, k, m_star, k_g) / (n or scene_steps)
        if dt > 2 * scene_dt:   # not for the few percent damping alone lengthens a contact at the scene's k*
            for key in ("analysis.every", "output.observables_every"):
                own[key] = max(1, round(setting(key) * scene_dt / dt))
        return own

    def points(pairs):
        """Runs (or, with --report, finds) every seed of each (zeta, k*) pair; returns the measured points."""
        pairs = list(dict.fromkeys(pairs))
        try:
            own = {(z, k): own_settings(z, k) for z, k in pairs}
        except scene_check.SceneError as error:
            ap.exit(2, f"{ap.prog}: {error}\n")
        files = {(z, k, s): out / f"{run_name(z, k, s, own[(z, k)])}.h5" for z, k in pairs for s in seeds}
        occupied = [problem for problem in map(not_a_run_name, files.values()) if problem]
        if occupied:   # before any run: the sweep would stop at the first of them, its other runs under way
            ap.exit(2, f"{ap.prog}: error: " + "\n".join(occupied) + "\n")
        if args.report:   # what is complete; a point without a complete run is left out, and said so
            missing = [f for f in files.values() if not run_files.ended(f)]
            if missing:
                print(f"note: --report: {len(missing)} of {len(files)} run(s) are not complete (left out; their points "
                      f"too, where no seed is complete): {', '.join(map(str, missing[:3]))}{' ...' if len(missing) > 3 else ''}",
                      flush=True)
            files = {key: f for key, f in files.items() if run_files.ended(f)}
            pairs = [(z, k) for z, k in pairs if any((z, k, s) in files for s in seeds)]
        stale = []   # complete runs are taken as they are only if they ran what would run now
        for (z, k, s), h5 in files.items():
            if run_files.ended(h5):
                now = scene_check.resolve(args.grains, SCENE, run_settings(z, k, s, m_star, k_g, threads, args.set, own[(z, k)]))
                differs = run_reuse.difference(now, h5)
                if differs:
                    stale.append(f"  - {h5}: {differs}")
        if stale:
            ap.exit(2, f"{ap.prog}: error: {len(stale)} complete run(s) in --out were run with other settings than "
                       f"those given now (give another --out, or delete those runs' files to run them again):\n" + "\n".join(stale) + "\n")
        if not args.report:
            import dask
            tasks = {(z, k, s): dask.delayed(run_point)(args.grains, z, k, s, m_star, k_g, threads, args.set, out,
                                                        own[(z, k)])
                     for z, k in pairs for s in seeds}
            files = dict(zip(tasks, dask.compute(*tasks.values(), scheduler="threads", num_workers=args.jobs)))
        measured = []
        for z, k in pairs:
            point = median_point([measure(files[(z, k, s)], k) for s in seeds if (z, k, s) in files])
            measured.append({"zeta": z, "restitution": restitution(z), "k_star": k,
                             "steps_per_contact": own[(z, k)].get("time.steps_per_contact", scene_steps),
                             "analysis_every": own[(z, k)].get("analysis.every", setting("analysis.every")), **point})
        return measured

    # Every point that may run, resolved by grains before the first run: a point the scene refuses (a k* whose
    # contact stiffness underflows, say) stopped the sweep only when its turn came, after the damping sweep's runs.
    # With --fixed-damping auto the stiffness sweep's zeta is one of --damping, so every pairing is checked.
    stiffness_zetas = args.damping if args.fixed_damping == "auto" else [float(args.fixed_damping)]
    maybe = [(z, fixed_stiffness) for z in args.damping] + [(z, k) for z in stiffness_zetas for k in args.stiffness]
    if args.map:
        maybe += [(z, k) for z in args.damping for k in args.stiffness]
    refused = []
    for z, k in dict.fromkeys(maybe):
        try:
            scene_check.resolve(args.grains, SCENE, run_settings(z, k, 1, m_star, k_g, threads, args.set, own_settings(z, k)))
        except scene_check.SceneError as error:
            refused.append(f"  - zeta {z:g}, k* {k:g}: {str(error).removeprefix(f'zeta {z:g}, k* {k:g}: ')}")
    if refused:
        ap.exit(2, f"{ap.prog}: error: grains refuses {len(refused)} of the sweep's points (nothing was run):\n"
                   + "\n".join(refused) + "\n")
    tool_args.make_out(ap, out)   # only now, so that a sweep refused above leaves no folder behind
    print(f"damping sweep: {len(args.damping)} points at k* = {fixed_stiffness:.4g}, {args.seeds} seed(s) each", flush=True)
    damping = points([(z, fixed_stiffness) for z in args.damping])
    if not damping:   # --report, with no complete run of the damping sweep
        ap.exit(2, f"{ap.prog}: error: --report: no complete run of the damping sweep in {out}\n")
    if not args.stiffness:
        fixed_damping = None
    elif args.fixed_damping == "auto":
        dense = [p["zeta"] for p in damping if p["cluster_index"] <= DENSE]
        if not dense:
            ap.error(f"--fixed-damping auto: no swept zeta ends as a dense aggregate (final N_c / N <= {DENSE}); give one")
        fixed_damping = min(dense)
    else:
        fixed_damping = float(args.fixed_damping)
    if args.stiffness:
        print(f"stiffness sweep: {len(args.stiffness)} points at zeta = {fixed_damping:g}", flush=True)
    stiffness = points([(fixed_damping, k) for k in args.stiffness])
    grid = points([(z, k) for z in args.damping for k in args.stiffness]) if args.map else []

    fields = ["sweep", "zeta", "restitution", "k_star", "steps_per_contact", "analysis_every", "seeds", "t_agg_over_t_ff", "cluster_index",
              "largest_cluster_fraction", "fractal_dimension", "q_first_peak", "q_first_peak_time", "q_second_peak",
              "warned_runs", "heated_runs"]
    with (out / "sweep.csv").open("w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=fields, extrasaction="ignore")
        writer.writeheader()
        for name, rows in (("damping", damping), ("stiffness", stiffness), ("map", grid)):
            for r in rows:
                writer.writerow({"sweep": name, **r})
    lines = findings(damping, stiffness, fixed_stiffness, fixed_damping)
    if grid:
        lines += [stiffness_shapes(grid, args.damping, args.stiffness), virial_shapes(grid, args.stiffness)]
    lines += raised_points(damping + stiffness + grid, scene_steps) + warned_points(damping + stiffness + grid)
    text = "\n".join(lines)
    print(text)
    (out / "summary.md").write_text(text + "\n")
    plot_sweep(damping, "zeta", f"Damping sweep at k* = {fixed_stiffness:.3g}, median of {args.seeds} seed(s)", out / "damping.png")
    if stiffness:
        plot_sweep(stiffness, "k_star", f"Stiffness sweep at ζ = {fixed_damping:g}, median of {args.seeds} seed(s)", out / "stiffness.png")
    if grid:
        plot_map(grid, list(dict.fromkeys(args.damping)), list(dict.fromkeys(args.stiffness)), out / "map.png")
        plot_virial_map(grid, list(dict.fromkeys(args.damping)), list(dict.fromkeys(args.stiffness)), out / "virial-map.png")
    print(f"wrote {out / 'sweep.csv'}, {out / 'summary.md'} and the plots in {out}/")
    return 0


if __name__ == "__main__":
    child_runs.stop_children_on_term()
    try:
        sys.exit(main())
    except (KeyboardInterrupt, child_runs.Interrupted):
        sys.exit(tool_exits.interrupted(pathlib.Path(__file__).name, "complete runs are kept, interrupted ones run again"))
    except child_runs.RunFailed as error:
        sys.exit(tool_exits.failed(pathlib.Path(__file__).name, error))
