"""Normal-force distributions of a consolidation programme's stages (physics.md section 9; the consolidation paper,
section V C, Figs. 18 and 19), from the stage snapshots of `grains consolidate`:

    python runner/force_distribution.py STAGES.h5 [STAGES.h5 ...] [--pressures P ...] [--scaled P ...] [-o forces.png] [--table out.csv]

Each interaction's static normal force is found again from the snapshot's geometry and the stored scene's law
(physics.md section 6: K_N delta - F0 in contact, the elastic part capped at contact.overlap_limit times the smaller
radius; -F0 (1 - h / D0) across a gap h < D0; positive compressive), as the engine's contact network finds it (the
stage records' `force_histogram_*`, which a test compares with this). Two panels:
  - P(F_N / F0), the probability density, at --pressures of the loading branch (default 0.01 0.178 1 2.37, the
    paper's Fig. 18; F0 = 0, a cohesionless packing: F_N over its mean |F_N|);
  - the positive wing of P(F_N / (P* F0)) at --scaled (default 2.37 5.62 13.3, its Fig. 19), where forces grow in
    proportion to P* (the engine's histogram ends at 9 F0: at P* = 13.3 over half the interactions lie beyond).
Samples of one programme are pooled. The table has one row per pressure, panel and bin.
"""
import argparse
import csv
import math
import pathlib
import sys
import tomllib

import numpy as np
from scipy.spatial import cKDTree

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent))
import run_files  # noqa: E402
import tool_exits  # noqa: E402
from density_correlations import FramesError, loading_frame, read_frames, refuse_overwriting  # noqa: E402


def law_of(path, largest_diameter):
    """(K_N, F0, D0, f_max) of the adhesive law in the run's stored scene (parameters/scene.toml); D0 defaults, as in the
    engine, to 1e-3 of the size distribution's largest diameter, or of the largest given one (`largest_diameter`)."""
    import h5py
    with h5py.File(path, "r") as f:
        text = f["parameters/scene.toml"][()]
    scene = tomllib.loads(text.decode() if isinstance(text, bytes) else str(text))
    adhesion = scene.get("adhesion", {})
    if not adhesion.get("enabled", False):
        raise ValueError("its scene has no adhesive law (adhesion.enabled = false): the force distribution is the "
                         "consolidation law's")
    particles = scene.get("particles", {})
    a = particles.get("diameter_max", particles.get("diameter", largest_diameter))
    force = float(adhesion.get("force", 1.0))
    return (float(adhesion.get("stiffness", 1e5)), force, float(adhesion.get("range", 1e-3 * a)),
            float(scene.get("contact", {}).get("overlap_limit", 0.1)))


def normal_forces(positions, radii, edges, law):
    """The static normal force of every interacting pair (contacts; with F0 > 0 also gaps h < D0) of a periodic
    configuration, by the minimum image."""
    k_n, f0, d0, f_max = law
    edges = np.asarray(edges, float)
    wrapped = np.mod(positions, edges)
    wrapped[wrapped >= edges] = 0.0   # (mod can round up to the edge itself)
    reach = 2 * float(np.max(radii)) + (d0 if f0 > 0 else 0.0)
    pairs = cKDTree(wrapped, boxsize=edges).query_pairs(reach, output_type="ndarray")
    if len(pairs) == 0:
        return np.zeros(0)
    i, j = pairs[:, 0], pairs[:, 1]
    r = wrapped[j] - wrapped[i]
    r -= edges * np.round(r / edges)
    gap = np.linalg.norm(r, axis=1) - radii[i] - radii[j]
    elastic = k_n * np.minimum(-gap, f_max * np.minimum(radii[i], radii[j]))
    force = np.where(gap < 0, elastic - f0, -f0 * (1 - gap / d0) if f0 > 0 else 0.0)
    interacting = (gap < 0) | ((gap < d0) & (f0 > 0))
    return force[interacting]


def histogram(forces, scale, lower, width, bins, fold_below=True):
    """Fractions of `forces / scale` in `bins` bins of `width` from `lower` (the first also takes what lies below, the
    last everything from its lower edge on): the engine's force_histogram_* with lower -1, width 0.5, 21 bins. Without
    fold_below what lies below is left out (a wing), the fractions still of all forces."""
    position = np.floor((forces / scale - lower) / width)
    if not fold_below:
        position = position[position >= 0]
    which = np.clip(position, 0, bins - 1).astype(int)
    return np.bincount(which, minlength=bins) / max(len(forces), 1)


def main(argv=None):
    ap = argparse.ArgumentParser(description="Normal-force distributions of consolidation stages (the paper's Figs. 18 and 19).")
    ap.add_argument("h5", nargs="+", help="stages files of `grains consolidate` (samples of one programme: pooled)")
    ap.add_argument("--pressures", type=float, nargs="+", default=[0.01, 0.178, 1.0, 2.37],
                    help="loading-branch P* of the P(F_N / F0) panel (default 0.01 0.178 1 2.37, the paper's Fig. 18)")
    ap.add_argument("--scaled", type=float, nargs="+", default=[2.37, 5.62, 13.3],
                    help="loading-branch P* of the P(F_N / P* F0) panel (default 2.37 5.62 13.3, its Fig. 19)")
    ap.add_argument("-o", "--out", help="plot file (PNG); default: beside the first input, <name>-forces.png")
    ap.add_argument("--table", help="CSV of the distributions (default: beside the first input, <name>-forces.csv)")
    args = ap.parse_args(argv)
    for option, values in (("--pressures", args.pressures), ("--scaled", args.scaled)):
        if any(not 0 < p < math.inf for p in values):
            ap.error(f"{option}: {values}; reduced pressures must be finite numbers > 0")
    from plot import image_name_problem
    if args.out and (problem := image_name_problem("-o/--out", args.out)):
        ap.error(problem)
    paths = [pathlib.Path(p) for p in args.h5]
    for path in paths:
        if problem := run_files.not_a_run_file(path):
            ap.error(f"h5: '{path}' {problem}")
    stem = paths[0].with_suffix("")
    table = pathlib.Path(args.table) if args.table else stem.parent / f"{stem.name}-forces.csv"
    out = pathlib.Path(args.out) if args.out else stem.parent / f"{stem.name}-forces.png"
    refuse_overwriting(ap, {"--table": table, "-o/--out": out}, {"--table": args.table, "-o/--out": args.out}, paths)
    try:
        rows = report(paths, args.pressures, args.scaled, out, table)
    except UnreadableInput as err:
        ap.error(f"h5: {err}" if isinstance(err.__cause__, FramesError)
                 else f"h5: not a stages file of the consolidation law ({err})")
    except OSError as err:
        ap.error(f"cannot write the table '{table}' or the plot '{out}' ({err})")
    if not rows:
        ap.error(f"--pressures, --scaled: none of {args.pressures + args.scaled} is a loading stage of the input")
    return 0


class UnreadableInput(ValueError):
    """An input that is no stages file of the consolidation law (named in the message)."""


def report(paths, pressures, scaled, out, table):
    """The pooled distributions of the stages files `paths` at the loading-branch P* `pressures` (over F0) and `scaled`
    (over P* F0): prints a line each, writes the table (CSV) and the plot, and returns the table's rows ([] and nothing
    written when no input has any of the pressures). An input that is no stages file of the consolidation law raises
    UnreadableInput naming it; a table or plot that cannot be written, OSError."""
    samples = []
    for path in paths:
        try:
            frames = read_frames(path, (2, 3), "need 2D disks or 3D spheres")
            samples.append((path, frames, law_of(path, 2 * float(np.max(frames[1])))))
        except FramesError as err:   # its message names the file and what is wrong in it
            raise UnreadableInput(str(err)) from err
        except (OSError, KeyError, ValueError, tomllib.TOMLDecodeError) as err:
            raise UnreadableInput(f"{path}: {err}") from err
    if len({law[1] > 0 for *_, law in samples}) > 1:
        raise UnreadableInput("the inputs mix cohesive (F0 > 0) and cohesionless (F0 = 0) samples: pool one programme's")
    cohesive = samples[0][2][1] > 0
    rows = []
    panels = {"F0": [], "P*F0": []}
    names = {"F0": "F0", "P*F0": "P*F0"} if cohesive else {"F0": "mean|F_N|", "P*F0": "mean|F_N|"}   # the scales used
    for kind, targets in (("F0", pressures), ("P*F0", scaled)):
        for target in targets:
            forces, phis = [], []
            for path, (positions, radii, edges, p_star, phi), law in samples:
                i = loading_frame(p_star, target)
                if i is None:
                    continue
                f = normal_forces(positions[i], radii[i], edges[i], law)
                # F0 = 0 (cohesionless): over the mean |F_N|, which grows with P itself, in both panels
                scale = law[1] * (target if kind == "P*F0" else 1.0) if law[1] > 0 or len(f) == 0 else np.mean(np.abs(f))
                forces.append(f / scale)
                phis.append(phi[i])
            if not forces:
                print(f"P* = {target:g}: no loading stage there in any input; left out", file=sys.stderr)
                continue
            pooled = np.concatenate(forces)
            if len(pooled) == 0:
                print(f"P* = {target:g}: no interacting pair in its states (a gas); left out", file=sys.stderr)
                continue
            lower, width, bins = (-1.0, 0.25, 40) if kind == "F0" else (0.0, 0.1, 40)
            fractions = histogram(pooled, 1.0, lower, width, bins, fold_below=kind == "F0")   # P* F0: the compressive wing
            panels[kind].append((target, np.mean(phis), lower, width, fractions, len(pooled)))
            for b, fraction in enumerate(fractions):
                rows.append({"panel": f"F_N / {names[kind]}", "P_star": target, "samples": len(forces), "interactions": len(pooled),
                             "bin_low": lower + b * width, "bin_high": lower + (b + 1) * width if b < bins - 1 else math.inf,
                             "density": fraction / width})
            print(f"P* {target:<6g} F_N / {names[kind]}: {len(forces)} sample(s), {len(pooled)} interactions, mean "
                  f"{np.mean(pooled):.3f}, tensile {np.mean(pooled < 0):.1%}, in the last bin (open) {fractions[-1]:.1%}")
    if not rows:
        return rows
    with open(table, "w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)
    plot(panels, out, pathlib.Path(paths[0]).name + (f" and {len(paths) - 1} more" if len(paths) > 1 else ""), names)
    print(f"wrote {table} and {out}")
    return rows


def plot(panels, out, title, names):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, axes = plt.subplots(1, 2, figsize=(10, 4.2))
    for ax, kind in zip(axes, ("F0", "P*F0")):
        for (target, phi, lower, width, fractions, n), colour in zip(
                panels[kind], plt.cm.viridis(np.linspace(0, 0.85, max(len(panels[kind]), 1)))):
            edges = lower + width * np.arange(len(fractions) + 1)   # the last bin is open: drawn one width wide
            ax.stairs(fractions / width, edges, color=colour, label=f"P* = {target:g} (Φ {phi:.3f}, {n})")
        ax.set_xlabel(f"F_N / {names[kind]}")
        ax.set_ylabel("probability density")
        if kind == "P*F0":
            ax.set_yscale("log")
        ax.legend(fontsize=7)
    axes[0].set_title("normal forces (the paper's Fig. 18)", fontsize=9)
    axes[1].set_title("rescaled by P*, compressive wing (its Fig. 19)", fontsize=9)
    fig.suptitle(f"{title}; the last bin holds everything beyond it", fontsize=9)
    fig.tight_layout()
    fig.savefig(out, dpi=120)
    plt.close(fig)


if __name__ == "__main__":
    sys.exit(tool_exits.run_read_only(main, "force_distribution.py"))
