"""The loading curve of type-2 samples against the system size (not part of the test suite; reads finished campaigns).

    python runner/loading_by_size.py --campaign 1400=FOLDER --campaign 5600=FOLDER ... [--out loading-by-size.png]
                                     [--resamples 40]

Each --campaign names a folder of `consolidation_campaign.py` stage tables (SCENE-seedN.csv; unfinished
SCENE-seedN.partial.csv are left out, since their curves stop part way) and the label it is shown under, the
number of disks as a rule; FOLDER:SEEDS (4-8, or 4,6,9) takes those seeds only, and a label given more than once
pools its folders' samples, so that the paper's own mix of sizes (its Table II: five samples of 1400 disks, three
of 5600, one of 10,976) can be averaged as one curve. Per scene and label it averages the samples' loading branches and fits the mean, as
the campaign does (the paper's method: its Fig. 11 and Table III), and prints a table of lambda, Phimax, P0*,
Phi at P0* and P1* with the fit's standard errors and, from three samples on, the spread over --resamples resamplings of
the samples, lambda of the regime II line alone (P* <= 0.1) beside the same line of the paper's own curve, and how
the samples climb: their one-stage rises of Phi from the paper's P0* to P* = 1 (median, largest, and the share of
flat stages, below 0.005), and those of their mean curve, beside the paper's curve's over the same stages, which
rises at every one; and how firmly the fits hold: the crossover with P0* held at the paper's, the crossover with its plateau joined to the curve
(no step at P0*; see consolidation_fit.fit_crossover), and the regime II line to P* <= 0.075 and 0.178. The
figure draws the mean curves, their fits and the paper's fit, one panel per scene. The paper
gives one lambda per law for its samples of all sizes together, so this shows whether our excess is a small
system's.
"""
import argparse
import pathlib
import re
import sys

import numpy as np

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent))
import consolidation_campaign as campaign  # noqa: E402
import tool_exits  # noqa: E402
from consolidation_fit import TableError, crossover_curve, fit_crossover, fit_regime_two, guess_from_line  # noqa: E402


SEEDS = re.compile(r"\d+(-\d+)?(,\d+(-\d+)?)*")


class Seeds(tuple):
    """Seeds given as ranges (4-8, or 4,6,9, or both: 4-6,9), tested by membership: a set of every seed of
    1-999999999999 took minutes to build."""
    def __contains__(self, seed):
        return any(seed in r for r in tuple.__iter__(self))


def parse_seeds(text):
    """4-8 or 4,6,9 (or both: 4-6,9) as Seeds; None where a range runs backwards."""
    ranges = []
    for part in text.split(","):
        first, _, last = part.partition("-")
        if last and int(last) < int(first):
            return None
        ranges.append(range(int(first), int(last or first) + 1))
    return Seeds(ranges)


def parse_campaign(text):
    """LABEL=FOLDER or LABEL=FOLDER:SEEDS, the folder existing: (label, folder, Seeds or None for all)."""
    label, sep, folder = text.partition("=")
    if not sep or not label or not folder:
        raise argparse.ArgumentTypeError(f"--campaign {text!r}: expected LABEL=FOLDER or LABEL=FOLDER:SEEDS, e.g. "
                                         "1400=campaign or 1400=campaign:4-8")
    seeds = None
    head, colon, tail = folder.rpartition(":")
    if colon and SEEDS.fullmatch(tail) and not pathlib.Path(folder).is_dir():
        folder, seeds = head, parse_seeds(tail)
        if seeds is None:
            raise argparse.ArgumentTypeError(f"--campaign {text!r}: seeds {tail!r} run backwards: expected FIRST-LAST "
                                             "with FIRST <= LAST, e.g. 4-8")
    path = pathlib.Path(folder)
    if not path.is_dir():
        raise argparse.ArgumentTypeError(f"--campaign {text!r}: {folder} is not a folder")
    return label, path, seeds


def finished_tables(folder, scene, seeds=None):
    """The scene's finished tables in the folder, in seed order (only `seeds`, if given)."""
    named = ((re.fullmatch(rf"{re.escape(scene)}-seed(\d+)\.csv", t.name), t) for t in folder.iterdir())
    return [t for _, t in sorted((int(m[1]), t) for m, t in named if m and (seeds is None or int(m[1]) in seeds))]


def summaries(tables):
    """The summaries of the tables with a loading branch, each table once (a label's folders and seeds may overlap:
    a sample counted twice would count twice in the mean and in the samples' spread)."""
    unique = {t.resolve(): t for t in tables}
    found = [campaign.summarise(t) for t in unique.values()]
    return [s for s in found if s is not None]


FLAT = 0.005   # a stage that raised Phi by less than this is a stair's tread: the sample held its plateau


def rising_stages(scene, p):
    """Which of the target pressures p lie from the paper's P0* to P* = 1, where its curve rises at every stage."""
    return (p >= campaign.PAPER_FIT[scene][0] * (1 - 1e-6)) & (p <= 1 + 1e-6)


def rises(scene, p, phi):
    """A curve's one-stage rises of Phi over those stages."""
    return np.diff(phi[rising_stages(scene, p)])


def stage_rises(scene, results):
    """The one-stage rises of Phi of every sample over those stages, pooled (all the sample's stages, in equilibrium
    or not: its collapses are as much its own as its plateaus). A staircase shows as flat stages and a few large
    rises."""
    return np.concatenate([rises(scene, r["all_p"], r["all_phi"]) for r in results])


def paper_rises(scene):
    """The paper's curve's rises over the same stages. Its curve is a fit to its samples' mean, so it is smoother
    than any one sample need be."""
    return rises(scene, *campaign.paper_curve(scene))


def mean_curve_rises(scene, found):
    """The one-stage rises of the samples' mean curve (the one fitted) over the same stages: smoother than a single
    sample's, as the paper's curve is a fit to its samples' mean."""
    return rises(scene, found["p"], found["phi"])


def rises_text(values):
    return f"{np.median(values):.4f}, {values.max():.3f}, {np.mean(values < FLAT):.0%}" if len(values) else "none"


# Other ends of the regime II line than the fits' 0.1: the paper's regime II ends "near P* = 0.1-0.3", and where our
# curves bend soon after 0.1 the line's slope depends on its end more than its error says.
LINE_ENDS = (0.075, 0.178)


def lines_to(p, phi):
    """lambda of the regime II line ending at each of LINE_ENDS (None where too few stages)."""
    found = []
    for end in LINE_ENDS:
        try:
            found.append(fit_regime_two(p, phi, p_max=end)["lambda"])
        except ValueError:
            found.append(None)
    return found


def line_ends_text(found):
    """lines_to's slopes as a table cell ("–" where a line had too few stages)."""
    return ", ".join("–" if v is None else f"{v:.3f}" for v in found)


def fit_at_paper_start(scene, p, phi):
    """The crossover fit with P0* held at the paper's: where our mean curve's plateau ends elsewhere, or where the
    scan puts the model's step at P0* on a stage (fit_crossover), lambda and P1* move with P0*. None where it does
    not converge."""
    p0 = campaign.PAPER_FIT[scene][0]
    try:
        line = fit_regime_two(p, phi, p0=p0)
        return fit_crossover(p, phi, p0=p0, guess=guess_from_line(line, phi))
    except (ValueError, RuntimeError):
        return None


def fit_joined(p, phi, fit):
    """The crossover with its plateau joined to the curve at P0* (fit_crossover's joined), started from `fit`; the
    fit, or the reason there is none ("degenerate": Phi0 above Phimax, no regime II line at all)."""
    try:
        return fit_crossover(p, phi, guess=(1 / fit["phi0"], fit["lambda"], fit["phi_max"], fit["alpha"]), joined=True)
    except RuntimeError as error:
        return "degenerate" if "degenerate" in str(error) else "no fit"


def fit_of_mean(scene, results, resamples):
    """The fit to the samples' mean loading curve and the spread of its values over resampled samples
    ({} below three samples, where a resample says little), or None where the mean curve cannot be fitted; with the
    fits' sensitivity: the crossover at the paper's P0* and joined to its plateau, the regime II line to other ends."""
    p, phi, counts = campaign.mean_curve(results)
    try:
        fit = campaign.fit_loading(p, phi)
    except (ValueError, RuntimeError):
        return None
    spread = (campaign.resampled_spread(results, resamples, label=scene)[0] if len(results) >= 3 and resamples else {})
    try:   # the regime II line alone: the slope, without how soon the curve bends to Phimax
        line = fit_regime_two(p, phi)
    except ValueError:
        line = None
    return {"fit": fit, "spread": spread, "line": line, "p": p, "phi": phi, "counts": counts,
            "at_paper_start": fit_at_paper_start(scene, p, phi), "joined": fit_joined(p, phi, fit),
            "line_ends": lines_to(p, phi)}


def sensitivity_text(found):
    at = found["at_paper_start"]
    fixed = f"{at['lambda']:.3f} ± {at['lambda_err']:.3f}, {at['P1']:.3g}" if at else "no fit"
    j = found["joined"]
    joined = j if isinstance(j, str) else f"{j['lambda']:.3f} ± {j['lambda_err']:.3f}, {j['P0']:.3g}"
    return f"{fixed}; {joined}; {line_ends_text(found['line_ends'])}"


def table_lines(rows):
    """rows: (scene, label, samples, fit_of_mean result or None, the samples' stage rises)."""
    ends = ", ".join(f"{e:g}" for e in LINE_ENDS)
    lines = ["| scene | size | samples | λ (fit; samples) | Φmax | P0* | Φ0 | P1* | λ of the regime II line alone (P* ≤ 0.1) "
             f"| one-stage rises of Φ, paper's P0* to P* = 1: median, largest, flat (< {FLAT}), of the samples; of their mean curve "
             f"| at the paper's P0*: λ, P1*; joined to the plateau: λ, P0*; the line to P* ≤ {ends} "
             "| paper λ, Φmax, P1*; its curve's line (to 0.1; to " + ends + "); its rises |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for scene, label, n, found, rises in rows:
        lam, phi_max, p1 = campaign.PAPER[scene]["lambda"], campaign.PAPER[scene]["phi_max"], campaign.PAPER_P1[scene]
        paper_ends = line_ends_text(lines_to(*campaign.paper_curve(scene)))
        paper = (f"{lam[0]} ± {lam[1]}, {phi_max[0]}, {p1[0]:.3f} ± {p1[1]:.3f}; line {campaign.paper_line(scene):.3f} "
                 f"({paper_ends}); rises {rises_text(paper_rises(scene))}")
        if found is None:
            lines.append(f"| {scene} | {label} | {n} | no fit | | | | | | {rises_text(rises)} | | {paper} |")
            continue
        f, s = found["fit"], found["spread"]
        spread = lambda key: f"; ± {s[key]:.3f}" if key in s else ""
        line = found["line"]
        line = f"{line['lambda']:.3f} ± {line['lambda_err']:.3f}" if line else "no fit"
        lines.append(f"| {scene} | {label} | {n} | {f['lambda']:.3f} ± {f['lambda_err']:.3f}{spread('lambda')} | "
                     f"{f['phi_max']:.4f} ± {f['phi_max_err']:.4f}{spread('phi_max')} | {f['P0']:.3g} | {f['phi0']:.4f} | "
                     f"{f['P1']:.3g} | {line} | {rises_text(rises)}; mean curve {rises_text(mean_curve_rises(scene, found))} | "
                     f"{sensitivity_text(found)} | {paper} |")
    return lines


def plot(rows, path):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    scenes = list(dict.fromkeys(r[0] for r in rows))
    fig, axes = plt.subplots(1, len(scenes), figsize=(6.5 * len(scenes), 4.5), squeeze=False)
    for ax, scene in zip(axes[0], scenes):
        ours = [r for r in rows if r[0] == scene]
        colours = plt.cm.viridis(np.linspace(0, 0.85, len(ours)))
        for (_, label, n, found, _), colour in zip(ours, colours):
            if found is None:
                continue
            f = found["fit"]
            name = f"{label} disks" if label.isdigit() else label
            ax.plot(found["p"], found["phi"], "o", color=colour, ms=4, label=f"{name}, mean of {n}")
            grid = np.geomspace(found["p"].min(), found["p"].max(), 200)
            inv = crossover_curve(grid, (1 / f["phi0"], f["lambda"], f["phi_max"], f["alpha"]), f["P0"])
            ax.plot(grid, 1 / inv, "-", color=colour, lw=1.2, label=f"  its fit: λ = {f['lambda']:.3g}, Φmax = {f['phi_max']:.4g}")
        p0, phi0, lam, phi_max, alpha = campaign.PAPER_FIT[scene]
        grid = np.geomspace(0.01, 13.33, 200)   # the paper's programme
        inv = crossover_curve(grid, (1 / phi0, lam, phi_max, alpha), p0)
        ax.plot(grid, 1 / inv, "k:", lw=1.5, label=f"paper's fit: λ = {lam:.3g}, Φmax = {phi_max:.4g}")
        ax.set_xscale("log")
        ax.set_xlabel("P* = a P / F0")
        ax.set_ylabel("solid fraction Φ (mean over the samples in equilibrium)")
        ax.set_title(f"{scene}: loading branch by system size")
        ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--campaign", action="append", type=parse_campaign, required=True, metavar="LABEL=FOLDER[:SEEDS]",
                    help="a folder of campaign stage tables and its label, e.g. 1400=campaign, or some of its seeds, "
                         "e.g. 1400=campaign:4-8 (repeatable; a label given again pools the folders' samples)")
    ap.add_argument("--scene", action="append", choices=list(campaign.PAPER), help="scene to read (default both)")
    ap.add_argument("--resamples", type=int, default=40,
                    help="resamplings of the samples for the spread of the fitted values, from three samples on (default 40)")
    ap.add_argument("--out", default="loading-by-size.png", help="the figure (default loading-by-size.png)")
    args = ap.parse_args(argv)
    if args.resamples < 0:
        ap.error(f"--resamples {args.resamples}: must be 0 or more")
    from plot import image_name_problem
    problem = image_name_problem("--out", args.out)
    if problem:   # said before the fits, not after
        ap.error(problem)
    labels = list(dict.fromkeys(label for label, _, _ in args.campaign))
    rows = []
    for scene in args.scene or list(campaign.PAPER):
        for label in labels:
            try:
                results = summaries([t for l, folder, seeds in args.campaign if l == label
                                     for t in finished_tables(folder, scene, seeds)])
            except TableError as error:   # one line naming the table, the line and the value
                ap.exit(2, f"{ap.prog}: error: {error}\n")
            if results:
                print(f"{scene}, {label}: {len(results)} finished sample(s); fitting the mean loading curve",
                      file=sys.stderr, flush=True)
                rows.append((scene, label, len(results), fit_of_mean(scene, results, args.resamples),
                             stage_rises(scene, results)))
    if not rows:
        ap.error("no finished stage table (SCENE-seedN.csv) of the scenes in the folders given")
    print("\n".join(table_lines(rows)))
    plot(rows, args.out)
    print(f"figure: {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(tool_exits.run_read_only(main, "loading_by_size.py"))
