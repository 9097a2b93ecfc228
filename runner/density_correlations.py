"""Density correlations of a disk packing (physics.md section 9; consolidation paper, section IV):
the scattering intensity I(k), its fractal dimension d_F and the blob size xi.

    python runner/density_correlations.py STAGES.h5 [STAGES.h5 ...] [--pressures P ...] [-o intensity.png] [--table out.csv]

STAGES is the HDF5 file of `grains consolidate` (one snapshot per stage, observables beside it), or
any H5MD file of 2D disks. For the loading stage at each of --pressures (default 0 0.01 0.178 1):
  - the density field chi (1 inside a disk, 0 outside) is sampled on a periodic grid of spacing
    a / --points-per-diameter (a: the largest diameter), at the grid points' centres;
  - I(k) = |chi^(k)|^2 / A, chi^(k) = sum over the grid of chi e^(-i k.r) dA (A: the cell's area), is
    averaged over directions in logarithmic shells of k;
  - the fractal blob form I(k) = I0 [1 + (k xi / 2 pi)^2]^(-d_F / 2) is fitted to log I for
    2 pi / L <= k <= --k-max (default 2 pi / a): flat below the crossover 2 pi / xi, slope -d_F above it.
    The paper fits the form of its "paper I", which its text does not give; this one has the paper's two
    features (plateau below k = 2 pi / xi, power law k^-d_F for a << 2 pi / k << xi), so d_F is
    comparable, while xi carries the form's own constant.
Beside them xi', the pores' mass-averaged radius of gyration (runner/pore_sizes.py), the paper's other blob size
(xi' ~ xi at P* = 0.01, below xi under higher pressures).
The paper's values (1400 disks, type 2): d_F ~ 1.52-1.55 with rolling resistance at P* = 0 and 0.01
(xi = 9.3 +- 0.4 a and 5.1 +- 0.2 a there), ~ 1.9 without; no fractal range left at P* = 1.
"""
import argparse
import csv
import math
import os
import pathlib
import sys
import warnings

import numpy as np
from scipy.optimize import OptimizeWarning, curve_fit

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent))
import dataset_checks  # noqa: E402
import run_files  # noqa: E402
import tool_exits  # noqa: E402
from dataset_checks import FramesError, increasing, numbers  # noqa: E402
from consolidation_fit import stage_table_of  # noqa: E402
from disk_grid import density_field  # noqa: E402
from pore_sizes import pore_sizes  # noqa: E402

# A grid finer than this resolves nothing the fit sees: at 16 points per diameter I(k) is within 5 % of a disk's
# closed form below k R = 2 and each doubling cuts that threefold (tests/python/test_density_correlations.py),
# while the grid's memory grows with the square (100,000 asked for 139 GiB).
MAX_POINTS_PER_DIAMETER = 128
# What the analysis of one state holds per grid point (chi, its transform, |k| and the pooled shells' work arrays):
# 42-50 bytes measured (2026-12), rounded up; the grids of one pressure's states together are kept below the budget.
BYTES_PER_GRID_POINT = 64
GRID_MEMORY = 4 * 2 ** 30


class FitRangeError(ValueError):
    """The fit's range, 2 pi / L to k_max, holds too few shells (the one error --k-max answers for)."""


def scattering_intensity(chi, h):
    """|chi^(k)|^2 / A on the grid of wave vectors, with their moduli; k = 0 is left out."""
    area_element = h[0] * h[1]
    area = chi.size * area_element
    amplitude = np.fft.fft2(chi.astype(float)) * area_element
    intensity = np.abs(amplitude) ** 2 / area
    kx = 2 * np.pi * np.fft.fftfreq(chi.shape[0], d=h[0])
    ky = 2 * np.pi * np.fft.fftfreq(chi.shape[1], d=h[1])
    k = np.hypot(kx[:, None], ky[None, :])
    keep = k > 0
    return k[keep], intensity[keep]


def shell_average(k, intensity, k_min, k_max, shells_per_decade=10):
    """Mean I in logarithmic shells of k between k_min and k_max, with the number of wave vectors in
    each; empty shells are dropped. Returns the shells' mean k, mean I and counts."""
    bounds = np.logspace(math.log10(k_min), math.log10(k_max),
                         max(int(round(shells_per_decade * math.log10(k_max / k_min))), 1) + 1)
    which = np.digitize(k, bounds) - 1
    inside = (which >= 0) & (which < len(bounds) - 1)
    counts = np.bincount(which[inside], minlength=len(bounds) - 1)
    k_sum = np.bincount(which[inside], weights=k[inside], minlength=len(bounds) - 1)
    i_sum = np.bincount(which[inside], weights=intensity[inside], minlength=len(bounds) - 1)
    full = counts > 0
    return k_sum[full] / counts[full], i_sum[full] / counts[full], counts[full]


def blob_form(k, log_i0, d_f, log_xi):
    """log I of the fractal blob form I0 [1 + (k xi / 2 pi)^2]^(-d_F / 2)."""
    return log_i0 - 0.5 * d_f * np.log1p((k * np.exp(log_xi) / (2 * np.pi)) ** 2)


def fit_blob(k, intensity, counts, k_min, k_max):
    """Fit the blob form to the shells' log I over k_min <= k <= k_max. A single wave vector's intensity
    scatters like an exponential variable (relative spread 1) and chi^(-k) repeats chi^(k), so a shell's
    mean of n wave vectors has a relative spread sqrt(2 / n): the fit's weights. Returns d_F, xi, I0 and
    the standard errors of d_F and xi from the fit's covariance. When the crossover 2 pi / xi does not
    lie below k_max / 2 (less than an octave of power law inside the range: a flat, homogeneous signal), or
    d_F's standard error exceeds half of it, or the fit does not converge, there is no fractal range: d_F and xi
    are NaN and I0 is the mean level."""
    sel = (k >= k_min * (1 - 1e-12)) & (k <= k_max * (1 + 1e-12)) & (intensity > 0)
    if sel.sum() < 4:
        raise FitRangeError(f"blob fit: {sel.sum()} shells with {k_min:.3g} <= k <= {k_max:.3g}; need at least 4")
    x, y, sigma = k[sel], np.log(intensity[sel]), np.sqrt(2.0 / counts[sel])
    start = (y[0], 1.5, math.log(2 * np.pi / math.sqrt(x[0] * x[-1])))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", OptimizeWarning)
        try:
            params, cov = curve_fit(blob_form, x, y, p0=start, sigma=sigma, absolute_sigma=False, maxfev=20000)
        except RuntimeError:   # no convergence in maxfev evaluations (a traceback before): no blob form to find
            params, cov = np.full(3, math.nan), np.full((3, 3), math.nan)
    errors = np.sqrt(np.diag(cov))
    xi = math.exp(params[2])
    # A d_F whose standard error passes half of it is the noise of too few wave vectors (16 disks gave
    # 0.26 +- 1.99 with xi a thousand cells long): no fractal range either.
    if not (2 * np.pi / xi < k_max / 2 and np.all(np.isfinite(errors)) and 0 < params[1] < 3 and errors[1] < 0.5 * params[1]):
        level = math.exp(np.average(y, weights=1 / sigma ** 2))
        return {"fractal_range": False, "d_F": math.nan, "d_F_error": math.nan, "xi": math.nan,
                "xi_error": math.nan, "I0": level}
    return {"fractal_range": True, "d_F": params[1], "d_F_error": errors[1], "xi": xi,
            "xi_error": xi * errors[2], "I0": math.exp(params[0])}


def wave_vectors(positions, radii, edges, points_per_diameter=8):
    """(k, I) of every wave vector of one 2D configuration, k = 0 left out; a is the largest diameter."""
    a = 2 * float(np.max(radii))
    chi, h = density_field(positions, radii, edges, a / points_per_diameter)
    return scattering_intensity(chi, h)


def analyse(configurations, points_per_diameter=8, k_max=None):
    """I(k) in shells, pooled over configurations (positions, radii, edges) of one state, and the blob
    fit over 2 pi / L <= k <= k_max (default 2 pi / a; L: the largest cell edge, a: the largest
    diameter). Lengths in the input's units. Returns the shells (k, I, counts), the fit, a, L."""
    ks, intensities = [], []
    for positions, radii, edges in configurations:
        k, intensity = wave_vectors(positions, radii, edges, points_per_diameter)
        ks.append(k)
        intensities.append(intensity)
    a = 2 * max(float(np.max(radii)) for _, radii, _ in configurations)
    length = max(float(np.max(edges)) for _, _, edges in configurations)
    k_max = 2 * np.pi / a if k_max is None else k_max
    k_top = min(2 * k_max, np.pi * points_per_diameter / a)   # shells to twice k_max, below the grid's Nyquist limit
    k_s, i_s, c_s = shell_average(np.concatenate(ks), np.concatenate(intensities), 2 * np.pi / length, k_top)
    fit = fit_blob(k_s, i_s, c_s, 2 * np.pi / length, k_max)
    return {"k": k_s, "I": i_s, "counts": c_s, "a": a, "L": length, "k_max": k_max, **fit}


def positive(path, name, values, what, second="particle"):
    """FramesError naming the first value that is not finite and > 0 (`what`: the quantity, plural; `second`: what
    the second index counts)."""
    if (bad := np.argwhere(~(np.isfinite(values) & (values > 0)))).size:
        at = tuple(int(i) for i in bad[0])
        raise FramesError(f"{path}: {name} holds {values[at]} (frame {at[0]}, {second} {at[1]}); {what} must be finite "
                          "and > 0")


def read_frames(path, dimensions=(2,), need="density correlations need 2D disks"):
    """Snapshots of an H5MD file: positions, radii and cell edges per frame, with each frame's reduced
    pressure and solid fraction where the file records them (else NaN). `dimensions`: those the caller
    takes (`need` says so in the error). The tools that read stages (density_correlations.py,
    force_distribution.py, a campaign's reports) read them here, so that each takes the same frame for a stage and
    refuses the same damage (FramesError): steps not strictly increasing, fewer frames than records, positions,
    radii or edges that are not finite (edges and radii also > 0), observables that are no numbers."""
    import h5py
    with h5py.File(path, "r") as f:
        group = f["particles/all"]
        positions = numbers(f, path, "particles/all/position/value") if "value" in group["position"] else None
        if positions is None or positions.ndim != 3 or positions.shape[2] not in dimensions:
            raise FramesError(f"{path}: particles/all/position has shape "
                              f"{None if positions is None else positions.shape}; {need}")
        radii = (numbers(f, path, "particles/all/radius/value", 2) if "value" in group["radius"]
                 else np.broadcast_to(group["radius"][()], positions.shape[:2]))
        edges = (numbers(f, path, "particles/all/box/edges/value", 2) if "value" in group["box/edges"]
                 else np.broadcast_to(group["box/edges"][()], (len(positions), positions.shape[2])))
        steps = numbers(f, path, "particles/all/position/step", 1)
        # A killed run can leave the frames' records (their steps) ahead of the frames themselves.
        for name, values in (("position/value", positions), ("radius/value", radii), ("box/edges/value", edges)):
            if len(values) != len(steps):
                raise FramesError(f"{path}: particles/all/{name} holds {len(values)} frame(s), particles/all/position/step "
                                  f"records {len(steps)}: the file is cut short (a run killed while writing it?); "
                                  "`grains resume` it, or analyse a complete file")
        increasing(path, "particles/all/position/step", steps)
        if edges.shape[1] != positions.shape[2]:
            raise FramesError(f"{path}: particles/all/position/value has {positions.shape[2]} columns and "
                              f"particles/all/box/edges/value {edges.shape[1]}: a {edges.shape[1]}D file's positions have "
                              f"{edges.shape[1]}")
        if (bad := np.argwhere(~np.isfinite(positions))).size:
            i, j, _ = (int(v) for v in bad[0])
            raise FramesError(f"{path}: particles/all/position/value holds {positions[tuple(bad[0])]} (frame {i}, particle "
                              f"{j}); positions must be finite")
        if radii.shape != positions.shape[:2]:
            raise FramesError(f"{path}: particles/all/radius/value has shape {radii.shape}, the positions "
                              f"{positions.shape[:2]} frames and particles")
        positive(path, "particles/all/radius/value", radii, "radii")
        positive(path, "particles/all/box/edges/value", edges, "cell edges", "axis")

        def observable(name):
            if f"observables/{name}/value" not in f:
                return np.full(len(steps), np.nan)
            obs_steps = numbers(f, path, f"observables/{name}/step", 1)
            values = numbers(f, path, f"observables/{name}/value", 1)
            dataset_checks.one_per_step(path, f"observables/{name}", obs_steps, "value", values)
            increasing(path, f"observables/{name}/step", obs_steps)
            lookup = dict(zip(obs_steps.tolist(), values.tolist()))
            return np.array([lookup.get(s, np.nan) for s in steps.tolist()], float)

        p_star, phi = observable("pressure_reduced"), observable("solid_fraction")
    return positions, radii, edges, stage_targets(path, p_star), phi


def stage_targets(path, measured):
    """The programme's target P* per frame, from the stage table written with the file (`grains consolidate`
    writes STEM.h5 and its table, frame 0 the initial state, frame s + 1 the end of stage s; see
    consolidation_fit.stage_table_of), so a stage that ended short of its target is still found by it; the
    measured P* where there is no table."""
    table = stage_table_of(path)
    if table is None:
        return measured
    with open(table, newline="") as f:
        rows = list(csv.DictReader(f))
    if len(rows) + 1 != len(measured):
        return measured
    return np.array([measured[0]] + [target_pressure(row) for row in rows])


def target_pressure(row):
    """A stage table row's target P* (so that a stage short of its target is found and drawn where the
    programme meant it); its measured P* where the table has no target (older tables); none (NaN) for the
    aggregation, which runs in a fixed cell: its measured P* is no stage of the loading branch (in a short run it
    comes above the first loading targets and would be taken as the branch's top)."""
    target = float(row.get("target_pressure") or "nan")
    if math.isfinite(target):
        return target
    return math.nan if row.get("phase") == "aggregation" else float(row["P_star"])


def loading_frame(p_star, target):
    """Index of the loading-branch frame (up to the largest P*) at the target reduced pressure: for
    target 0, the last frame under |P*| < 1e-3 before loading starts (the equilibrated P* = 0 state of a
    type-2 programme); otherwise the frame nearest in ln P*, within a factor 10^(1/16) (half a stage of
    the programme). None if there is none."""
    if not np.isfinite(p_star[1:]).any():   # no P* after the initial state: no loading branch (nanargmax would raise)
        return None
    top = 1 + int(np.nanargmax(p_star[1:]))   # frame 0 is the initial gas
    if target == 0:
        relaxed = [i for i in range(1, top + 1) if abs(p_star[i]) < 1e-3]
        return relaxed[-1] if relaxed else None
    candidates = [i for i in range(1, top + 1) if p_star[i] > 0]
    if not candidates:
        return None
    best = min(candidates, key=lambda i: abs(math.log(p_star[i] / target)))
    return best if abs(math.log(p_star[best] / target)) <= math.log(10) / 16 else None


def plot(results, out, title):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(figsize=(6.4, 4.8))
    colours = plt.cm.viridis(np.linspace(0, 0.85, len(results)))
    for (label, r), colour in zip(results, colours):
        a = r["a"]
        fit_k = r["k"][r["k"] <= r["k_max"] * (1 + 1e-12)]
        if r["fractal_range"]:
            label = f"{label}: d_F = {r['d_F']:.2f}, ξ = {r['xi'] / a:.1f} a"
            fitted = np.exp(blob_form(fit_k, math.log(r["I0"]), r["d_F"], math.log(r["xi"])))
            ax.axvline(2 * np.pi * a / r["xi"], color=colour, ls=":", lw=0.8)
        else:
            label = f"{label}: no fractal range"
            fitted = np.full(len(fit_k), r["I0"])
        ax.plot(r["k"] * a, r["I"] / a ** 2, "o", ms=3, color=colour, label=label)
        ax.plot(fit_k * a, fitted / a ** 2, color=colour, lw=1.2)
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("k a  (a: largest diameter)")
    ax.set_ylabel("I(k) / a²")
    ax.set_title(title, fontsize=9)
    ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(out, dpi=120)
    plt.close(fig)
    return fig


def default_outputs(first):
    """The table and the plot beside the first sample's file: <name>-intensity.csv and .png."""
    stem = pathlib.Path(first).with_suffix("")
    return stem.parent / f"{stem.name}-intensity.csv", stem.parent / f"{stem.name}-intensity.png"


def same_file(a, b):
    """Whether the names a and b (links followed) are one file that exists."""
    try:
        return os.path.samefile(a, b)
    except OSError:
        return False


def refuse_overwriting(ap, outputs, given, inputs):
    """ap.error for an output ({option: path}, a table and a plot) that is a folder or in a folder that is not there
    (a traceback came after the table was written), an input, its stage table or its XDMF file (--table cons.h5
    overwrote the input; a tool's documented --table its programme's table), or the other output. `given`: the
    options the user named (the others are defaults beside the first input, and the message says so)."""
    for option, path in outputs.items():
        default = "" if given[option] else f" (the default; give {option})"
        if kind := run_files.not_a_regular_file(path):
            ap.error(f"{option} '{path}' is {kind}: name a file to write{default}")
        if not path.resolve().parent.is_dir():
            ap.error(f"{option}: the folder '{path.parent}' of '{path}' does not exist")
        for source in inputs:
            for read, what in ((source, "an input"), (stage_table_of(source), f"the stage table of the input '{source}'"),
                               (source.with_suffix(".xdmf"), f"the XDMF file of the input '{source}'")):
                if read is not None and same_file(path, read):
                    ap.error(f"{option} '{path}' is {what}, which it would overwrite: name another file{default}")
    first, second = outputs.values()
    if same_file(first, second) or first.resolve() == second.resolve():
        ap.error(f"--table and -o/--out both name '{first}': the plot would overwrite the table")


def largest_grid(samples, pressures, points_per_diameter):
    """(grid points, P*) of the pressure whose states' density grids (density_field's) hold the most points in all."""
    largest = (0, math.nan)
    for target in pressures:
        points = 0
        for _, _, radii, edges, p_star, _ in samples:
            i = loading_frame(p_star, target)
            if i is not None:
                spacing = 2 * float(np.max(radii[i])) / points_per_diameter
                points += int(np.prod(np.maximum(np.ceil(np.asarray(edges[i], float) / spacing), 1)))
        if points > largest[0]:
            largest = (points, target)
    return largest


def largest_disk(samples, pressures, points_per_diameter):
    """(grid points, P*, path, radius, edges) of the largest square a disk is drawn in on the density grids (pore_sizes'
    at 16 points per diameter or more included): a disk wider than its cell is drawn over more points than the grid
    holds (radius 1e6 asked for 241 GiB, past largest_grid's guard)."""
    largest = (0, math.nan, None, math.nan, None)
    for target in pressures:
        for path, _, radii, edges, p_star, _ in samples:
            i = loading_frame(p_star, target)
            if i is None:
                continue
            r = float(np.max(radii[i]))
            cell = np.asarray(edges[i], float)
            h = cell / np.maximum(np.ceil(cell / (2 * r / max(points_per_diameter, 16))), 1)
            points = int(np.prod(np.ceil(2 * (r + h / 4) / h) + 2))   # density_field's square, with the pores' seal
            if points > largest[0]:
                largest = (points, target, path, r, cell)
    return largest


def main(argv=None):
    ap = argparse.ArgumentParser(description="Scattering intensity I(k), fractal dimension d_F and blob size xi of 2D disk packings, and their pores' radius of gyration xi' (physics.md section 9).")
    ap.add_argument("h5", nargs="+", help="stages files of `grains consolidate` (samples of one programme: their I(k) are pooled)")
    ap.add_argument("--pressures", type=float, nargs="+", default=[0.0, 0.01, 0.178, 1.0],
                    help="reduced pressures of the loading branch to analyse (default: 0 0.01 0.178 1, the paper's)")
    ap.add_argument("--points-per-diameter", type=int, default=8,
                    help=f"grid points per largest diameter a, 4 to {MAX_POINTS_PER_DIAMETER}, and no more than keep the "
                         f"grids of one pressure's states within {GRID_MEMORY // 2 ** 30} GiB (default 8)")
    ap.add_argument("--k-max", type=float, default=2 * math.pi, help="largest k of the fit, in 1/a (default 2 pi)")
    ap.add_argument("-o", "--out", help="plot file (PNG); default: beside the first input, <name>-intensity.png")
    ap.add_argument("--table", help="CSV of the fits (default: beside the first input, <name>-intensity.csv)")
    args = ap.parse_args(argv)
    ppd = args.points_per_diameter
    if not 4 <= ppd <= MAX_POINTS_PER_DIAMETER:
        ap.error(f"--points-per-diameter: {ppd}; need at least 4 grid points per diameter and at most "
                 f"{MAX_POINTS_PER_DIAMETER} (finer grids add nothing the fit sees, and their memory grows as the square)")
    if not 0 < args.k_max < math.inf:
        ap.error(f"--k-max: {args.k_max}; must be a finite number > 0")
    if any(not 0 <= p < math.inf for p in args.pressures):
        ap.error(f"--pressures: {args.pressures}; reduced pressures must be finite numbers >= 0")
    from plot import image_name_problem
    if args.out and (problem := image_name_problem("-o/--out", args.out)):
        ap.error(problem)
    names = {}   # path -> the name given
    for name in args.h5:
        path = pathlib.Path(name)
        if problem := run_files.not_a_run_file(path):
            ap.error(f"h5: '{path}' {problem}")
        if first := next((p for p in names if same_file(p, path)), None):   # pooled twice, it made "2 sample(s)"
            print(f"h5: '{name}' is the file '{names[first]}' again: counted once", file=sys.stderr)
        else:
            names[path] = name
    paths = list(names)
    # The outputs, named or beside the first input, before any work.
    table, out = default_outputs(paths[0])
    outputs = {"--table": pathlib.Path(args.table) if args.table else table,
               "-o/--out": pathlib.Path(args.out) if args.out else out}
    refuse_overwriting(ap, outputs, {"--table": args.table, "-o/--out": args.out}, paths)
    samples = []
    for path in paths:
        try:
            samples.append((path, *read_frames(path)))
        except FramesError as err:   # names the file itself
            ap.error(f"h5: {err}")
        except (OSError, KeyError, ValueError) as err:
            ap.error(f"h5: {path}: not a 2D H5MD stages file ({err})")
        if not np.isfinite(samples[-1][4][1:]).any():
            ap.error(f"h5: {path}: no stages in it (no reduced pressure P* after its first snapshot, from "
                     "observables/pressure_reduced or a stage table beside it): not an output of `grains consolidate`")
    points, target = largest_grid(samples, args.pressures, ppd)
    if points * BYTES_PER_GRID_POINT > GRID_MEMORY:
        fits = int(ppd * math.sqrt(GRID_MEMORY / (points * BYTES_PER_GRID_POINT)))   # points grow as ppd^2
        ap.error(f"--points-per-diameter: {ppd}; the density grids at P* = {target:g} would hold {points:.3g} points, "
                 f"about {points * BYTES_PER_GRID_POINT / 2 ** 30:.0f} GiB; at most about {fits} points per diameter "
                 f"keep them within {GRID_MEMORY // 2 ** 30} GiB")
    points, target, path, radius, cell = largest_disk(samples, args.pressures, ppd)
    if points * BYTES_PER_GRID_POINT > GRID_MEMORY:
        ap.error(f"h5: {path}: at P* = {target:g} a disk of radius {radius:g} in a cell of edges {cell.tolist()} would be "
                 f"drawn over {points:.3g} grid points, about {points * BYTES_PER_GRID_POINT / 2 ** 30:.0f} GiB, past the "
                 f"{GRID_MEMORY // 2 ** 30} GiB allowed; a packing's disks are smaller than its cell")
    try:
        rows = report(samples, args.pressures, ppd, args.k_max, outputs["-o/--out"], outputs["--table"])
    except FitRangeError as err:   # the fit's range, 2 pi / L to --k-max, holds too few shells
        ap.error(f"--k-max: {args.k_max}: {err} (the fit runs from 2 pi / L, L the cell's longest edge, to --k-max / a)")
    if not rows:
        ap.error(f"--pressures: none of {args.pressures} is a loading stage of the input")
    return 0


def report(samples, pressures, points_per_diameter=8, k_max=2 * math.pi, out=None, table=None):
    """Pooled fits of the samples (path, positions, radii, edges, P*, Phi: read_frames' arrays) at each
    loading-branch pressure: prints a line each, writes the table (CSV) and the plot of I(k) (default:
    beside the first sample, <name>-intensity.csv and .png) and returns the table's rows ([] and
    nothing written when no sample has any of the pressures). k_max in units of 1/a."""
    results, rows = [], []
    for target in pressures:
        states = []   # (configuration, Phi) of each sample at this stage
        for path, positions, radii, edges, p_star, phi in samples:
            i = loading_frame(p_star, target)
            if i is None:
                print(f"{path.name}: no loading stage at P* = {target:g}; left out", file=sys.stderr)
                continue
            states.append(((positions[i], radii[i], edges[i]), phi[i]))
        if not states:
            continue
        configurations = [c for c, _ in states]
        a = 2 * max(float(np.max(radii)) for _, radii, _ in configurations)
        r = analyse(configurations, points_per_diameter, k_max / a)
        # Phi in the label: the state drawn (a stage short of its target is drawn at the target's P*)
        results.append((f"P* = {target:g} (Φ {np.mean([p for _, p in states]):.3f})", r))
        # the samples' own fits, for the spread between samples beside the pooled fit's error
        single = [analyse([c], points_per_diameter, k_max / a)["d_F"] for c in configurations] if len(states) > 1 else []
        finite = [d for d in single if np.isfinite(d)]   # samples with no fractal range of their own are left out
        spread = float(np.std(finite, ddof=1)) if len(finite) > 1 else math.nan
        # xi', the pores' mass-averaged radius of gyration, pooled as I(k) is: over every enclosed pore of the samples
        # (on a grid of at least 16 points per diameter: the seal's share of the pores is a quarter cell, and at 8 the
        # interstices of a square lattice read 18 % small, at 16 10 %, at 64 4 %)
        pores = [pore_sizes(*c, max(points_per_diameter, 16)) for c in configurations]
        areas = np.concatenate([p["areas"] for p in pores])
        gyration = np.concatenate([p["radii_of_gyration"] for p in pores])
        xi_prime = float(np.sum(areas * gyration) / np.sum(areas)) if len(areas) else math.nan
        rows.append({"P_star": target, "samples": len(states), "phi_mean": float(np.mean([p for _, p in states])),
                     "fractal_range": r["fractal_range"], "d_F": r["d_F"], "d_F_error": r["d_F_error"],
                     "d_F_sample_sd": spread, "xi_over_a": r["xi"] / a, "xi_error_over_a": r["xi_error"] / a,
                     "xi_prime_over_a": xi_prime / a, "pores": len(areas),
                     "percolating_pore_share": float(np.mean([p["percolating_share"] for p in pores]))})
        pore_text = (f"  xi'/a {xi_prime / a:.2f} ({len(areas)} pores"
                     + (f"; {rows[-1]['percolating_pore_share']:.0%} of the free area percolates, left out"
                        if rows[-1]["percolating_pore_share"] > 0 else "") + ")")
        if r["fractal_range"]:
            print(f"P* {target:<6g} {len(states)} sample(s), Phi {rows[-1]['phi_mean']:.4f}:  d_F {r['d_F']:.3f} +- {r['d_F_error']:.3f}"
                  + (f" (sd of the samples' own fits {spread:.3f})" if math.isfinite(spread) else "")
                  + f"  xi/a {r['xi'] / a:.2f} +- {r['xi_error'] / a:.2f}" + pore_text)
        else:
            print(f"P* {target:<6g} {len(states)} sample(s), Phi {rows[-1]['phi_mean']:.4f}:  no fractal range (flat I(k))"
                  + pore_text)
    if not rows:
        return rows
    default_table, default_plot = default_outputs(samples[0][0])
    table = table or default_table
    with open(table, "w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)
    out = out or default_plot
    first = samples[0][0].name + (f" and {len(samples) - 1} more" if len(samples) > 1 else "")
    plot(results, out, f"Scattering intensity of {first}, pooled\nlines: blob fits; dotted: 2π / ξ")
    print(f"wrote {table} and {out}")
    return rows


if __name__ == "__main__":
    sys.exit(tool_exits.run_read_only(main, "density_correlations.py"))
