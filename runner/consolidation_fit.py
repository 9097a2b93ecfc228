"""Consolidation-curve fits of physics.md section 9 and the plot of Phi and 1/Phi against P*.

    python runner/consolidation_fit.py STAGES.csv [-o fit.png] [--p0 P0] [--regime2-max P]

STAGES is the table of equilibrated stages of a compression programme: the CSV that `grains
consolidate` writes (columns pressure_reduced, solid_fraction, phase, reached), or any CSV with a
header naming at least `P_star` and `phi` (an optional `branch` column with `loading` / `unloading`
keeps the fit on the loading branch), or the HDF5 file of `grains consolidate`, whose stage table
(the CSV it names, written with --table; for a file naming none, the CSV of the same name beside it) is then read. Stages that did not reach equilibrium are left out.

Two fits, both on the loading branch:
  regime II (a straight line in ln P*):   1/Phi = 1/Phi0 - lambda ln(P*/P0*)
  regimes II-III (the crossover form):     1/Phi = 1/Phi0 - lambda ln{(P*/P0*) [1 - exp(-(P1*/P*)^alpha)]^(1/alpha)}
      with ln(P1*/P0*) = (1/Phi0 - 1/Phimax) / lambda, so 1/Phi -> 1/Phimax + lambda/(2 alpha) (P1*/P*)^alpha.
Below P0*, where regime II starts, Phi stays on the plateau Phi0 of regime I. Unless --p0 gives it,
each fit finds P0* as the kink between plateau and curve (the best of a fine scan, refined between its
neighbours). The regime II
line is fitted to the stages with P* <= --regime2-max (default: 0.1; the paper's regime II ends near
P* = 0.1-0.3), the regimes II-III form to every loading stage.
"""
import argparse
import csv
import itertools
import math
import pathlib
import sys
from typing import Callable, NamedTuple

import numpy as np
from scipy.optimize import curve_fit, minimize_scalar

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent))
import run_files  # noqa: E402
import tool_exits  # noqa: E402


def inverse_phi_regime_two(p, inv_phi0, lam, p0):
    return inv_phi0 - lam * np.log(p / p0)


def inverse_phi_crossover(p, inv_phi0, lam, phi_max, alpha, p0):
    """1/Phi of the regimes II-III form; P1* follows from the other parameters."""
    log_p1_over_p0 = (inv_phi0 - 1.0 / phi_max) / lam
    # x = (P1*/P*)^alpha; far below P1* (or at a trial alpha the optimiser tries) it overflows to inf, where
    # 1 - exp(-x) = 1 is the right limit; far above P1* it underflows to 0, where ln(1 - exp(-x)) = ln x
    # (taken from ln x itself: the curve's limit 1/Phimax, where ln 0 gave inf and a warning).
    log_x = alpha * (log_p1_over_p0 + math.log(p0) - np.log(p))
    with np.errstate(over="ignore", divide="ignore"):
        x = np.exp(log_x)
        # -expm1(-x) = 1 - exp(-x), accurate for small x
        log_one_minus = np.where(log_x < -700, log_x, np.log(-np.expm1(-x)))
    # ln{(P/P0) [1 - exp(-x)]^(1/alpha)}
    return inv_phi0 - lam * (np.log(p / p0) + log_one_minus / alpha)


def plateau_then(p, p0, inv_phi0, rest):
    """Regime I (1/Phi = 1/Phi0, flat) below P0*, `rest` (a function of P*) from P0* on."""
    return np.where(p < p0, inv_phi0, rest(np.maximum(p, p0)))


def crossover_curve(p, params, p0, joined=False):
    """1/Phi of the fitted form at P* = p: (1/Phi0, lambda, Phimax, alpha) = params from P0* on, below it the flat
    plateau 1/Phi0, or with `joined` the curve's own value at P0* (fit_crossover's joined)."""
    if joined:
        return inverse_phi_crossover(np.maximum(p, p0), *params, p0)
    return plateau_then(p, p0, params[0], lambda q: inverse_phi_crossover(q, *params, p0))


def best_kink(residual, candidates):
    """P0* minimising residual(P0*): the best of the scanned candidates, refined (Brent's method in ln P0*)
    between its neighbours, since the optimum lies between grid points (the best point of an 80-point grid
    put lambda 2.4 % off the best fit on a campaign's mean curve)."""
    values = [residual(c) for c in candidates]
    i = int(np.nanargmin(values))
    lo, hi = candidates[max(i - 1, 0)], candidates[min(i + 1, len(candidates) - 1)]
    if hi <= lo:
        return candidates[i]
    refined = minimize_scalar(lambda u: residual(math.exp(u)), bounds=(math.log(lo), math.log(hi)), method="bounded",
                              options={"xatol": 1e-6})
    return math.exp(refined.x) if refined.fun < values[i] else candidates[i]


def fit_regime_two(p, phi, p0=None, p_max=0.1):
    """Regime II line through the stages with P* <= p_max. With P0* given, the line is fitted to
    [P0*, p_max]; without, P0* is found too, as the kink between the plateau 1/Phi = 1/Phi0 below it and
    the line above it (the best of a fine scan of P0*; given P0* the fit is linear least squares)."""
    p, phi = np.asarray(p, float), np.asarray(phi, float)
    keep = p <= p_max * (1 + 1e-12)
    if p0 is not None:
        keep &= p >= p0 * (1 - 1e-12)
    if keep.sum() < 3:
        raise ValueError(f"regime II fit: {keep.sum()} stages with P* <= {p_max:g} (and >= P0*); need at least 3")
    x, y = np.log(p[keep]), 1.0 / phi[keep]

    def line_fit(p0_try):   # y = 1/Phi0 - lambda max(0, ln(P/P0)): linear in (1/Phi0, lambda)
        a = np.column_stack([np.ones_like(x), -np.maximum(0.0, x - math.log(p0_try))])
        coef, *_ = np.linalg.lstsq(a, y, rcond=None)
        return coef, float(np.sum((a @ coef - y) ** 2)), a

    scanned = p0 is None
    if len(y) < (4 if scanned else 3):   # a fit with nothing left over has no error to give (it gave 7e-8)
        raise ValueError(f"regime II fit: {len(y)} stages with P* <= {p_max:g}; need at least "
                         f"{'4 (the line and its start P0* fitted)' if scanned else '3'}")
    if scanned:
        p0 = best_kink(lambda c: line_fit(c)[1], np.geomspace(p[keep].min(), p[keep].max(), 400)[:-2])
    (inv_phi0, lam), residual, a = line_fit(p0)
    if scanned:   # the scanned P0* is a fitted parameter too: its column dy/d(ln P0*) = lambda on the line, else 0
        a = np.column_stack([a, lam * (x > math.log(p0))])
    cov = np.linalg.pinv(a.T @ a) * residual / (len(y) - a.shape[1])
    return {"P0": float(p0), "phi0": 1.0 / inv_phi0, "lambda": lam, "lambda_err": math.sqrt(max(cov[1, 1], 0.0)),
            "stages": int(keep.sum()), "P_last": float(p[keep].max())}


def guess_from_line(line, phi):
    """fit_crossover's start from a regime II line: its Phi0 and lambda (at least 1e-3, inside the fit's bounds: a flat
    line's lambda stopped the fit with scipy's "outside of provided bounds"), Phimax just above the largest Phi."""
    return 1 / line["phi0"], max(line["lambda"], 1e-3), float(np.max(phi)) * 1.01, 1.0


def fit_crossover(p, phi, p0=None, guess=None, joined=False):
    """The regimes II-III form (with the flat regime I below P0*). P0* is held fixed when given, else
    found by a scan like fit_regime_two. Returns a dict with Phi0, lambda, Phimax, alpha, the derived
    P1* and their standard errors (the fit's, with P0* counted among the fitted parameters when scanned).
    A fit whose Phi0 is not below its Phimax (so P1* not above P0*) describes no plateau, line and crossover:
    it raises RuntimeError (degenerate).

    The plateau is 1/Phi0, the regime II line's start; the crossover term already lowers the curve at P0* by
    lambda ln(1 - exp(-(P1*/P0*)^alpha)) / alpha, negligible where P1* >> P0* (the paper's 11x: 1e-4) but not
    where P1* is a few P0* (0.04 in 1/Phi at 3x), where the model steps at P0* and a scanned P0* can put that step
    between two stages. joined=True holds the plateau at the curve's own value at P0* instead (no step)."""
    p, phi = np.asarray(p, float), np.asarray(phi, float)
    if len(p) < 6:
        raise ValueError(f"regimes II-III fit: {len(p)} stages; need at least 6")
    y = 1.0 / phi
    if guess is None:
        guess = (y.max(), 0.3, float(phi.max()) * 1.01, 1.0)
    bounds = ([1.0, 1e-6, 1e-3, 0.05], [np.inf, 10.0, 1.0, 10.0])   # 1/Phi0 >= 1: a solid fraction is at most 1

    def fit_at(p0_try, start):
        model = lambda pp, a, b, c, d: crossover_curve(pp, (a, b, c, d), p0_try, joined)
        params, cov = curve_fit(model, p, y, p0=start, bounds=bounds, maxfev=20000)
        return params, cov, float(np.sum((model(p, *params) - y) ** 2))

    scanned = p0 is None
    if scanned:
        def residual(c):
            try:
                return fit_at(c, guess)[2]
            except RuntimeError:   # no convergence at this P0*
                return math.inf
        p0 = best_kink(residual, np.geomspace(p.min(), p.max() / 10, 80))
    try:
        params, cov, ssr = fit_at(p0, guess)
    except RuntimeError:
        if scanned:   # the best P0* did not converge: none did
            raise RuntimeError("regimes II-III fit did not converge for any P0*") from None
        raise
    if scanned:
        # The scanned P0* is a fitted parameter too: the covariance of all five from the model's Jacobian. Scaling
        # curve_fit's four-parameter covariance for the lost degree of freedom alone leaves out how P0* trades with
        # lambda: 60 noisy curves of the paper's form scatter lambda 1.9 times, P1* 1.6 times the errors it gives.
        cov = _covariance_with_p0(params, p0, p, ssr, joined)
    inv_phi0, lam, phi_max, alpha = params
    finite = np.all(np.isfinite(cov))
    err = np.sqrt(np.clip(np.diag(cov), 0, None)) if finite else np.full(len(cov), np.nan)
    p1 = p0 * math.exp((inv_phi0 - 1.0 / phi_max) / lam)
    if not 1.0 / inv_phi0 < phi_max:
        raise RuntimeError(f"regimes II-III fit degenerate (Phi0 {1 / inv_phi0:.4g}, Phimax {phi_max:.4g}, "
                           f"P0* {p0:.4g}, P1* {p1:.4g}): no plateau, line and crossover in these stages")
    # P1* error by linear propagation through ln P1* = ln P0* + (1/Phi0 - 1/Phimax) / lambda (and ln P0* itself
    # when it was fitted: the fifth entry).
    grad = np.array([1.0 / lam, -(inv_phi0 - 1.0 / phi_max) / lam**2, 1.0 / (lam * phi_max**2), 0.0, 1.0][:len(cov)]) * p1
    p1_err = float(math.sqrt(max(grad @ cov @ grad, 0.0))) if finite else float("nan")
    return {"P0": float(p0), "phi0": 1.0 / inv_phi0, "phi0_err": err[0] / inv_phi0**2, "lambda": lam,
            "lambda_err": err[1], "phi_max": phi_max, "phi_max_err": err[2], "alpha": alpha, "alpha_err": err[3],
            "P1": p1, "P1_err": p1_err, "stages": int(np.sum(p >= p0))}


def _covariance_with_p0(params, p0, p, ssr, joined):
    """Covariance of (1/Phi0, lambda, Phimax, alpha, ln P0*) at the fit: (J^T J)^-1 SSR / (n - 5), J the derivatives
    by central differences of the model fitted (flat plateau, or joined: fit_crossover's), ln P0* moving the plateau's
    end and the curve's origin together."""
    def model(theta):
        return crossover_curve(p, theta[:4], math.exp(theta[4]), joined)
    theta = np.append(np.asarray(params, float), math.log(p0))
    jac = np.empty((len(p), len(theta)))
    for k in range(len(theta)):
        h = 1e-6 * max(abs(theta[k]), 1.0)
        up, down = theta.copy(), theta.copy()
        up[k] += h
        down[k] -= h
        jac[:, k] = (model(up) - model(down)) / (2 * h)
    return np.linalg.pinv(jac.T @ jac) * ssr / (len(p) - len(theta))


class TableError(ValueError):
    """A stage table that is none to read: its message names the file and, for a bad value, the line, column and value
    and what the column holds. The tools say it in one line and exit with status 2."""


class Values(NamedTuple):
    """What a stage table's column holds: `parse` turns a value's text into a value (a ValueError: the text is not
    `kind`), which `within`, when given, must accept (`allowed` says what it accepts)."""
    kind: str = "a number"
    parse: Callable = float
    within: Callable = None
    allowed: str = ""


def _flag(text):   # exactly 0 or 1: the tools compare the text with "1" and "0"
    if text not in ("0", "1"):
        raise ValueError(text)
    return int(text)


NUMBER = Values()   # nan and inf too: grains writes nan where a stage has no value (the aggregation's target)
SOLID_FRACTION = Values(within=lambda v: 0 < v <= 1, allowed="a solid fraction is in (0, 1]")
# Only for the stages a fit takes: grains writes a negative P* for its preparation and for a stage short of its target.
REDUCED_PRESSURE = Values(within=lambda v: math.isfinite(v) and v >= 0,
                          allowed="the reduced pressure P* of a stage in equilibrium is finite and at least 0")
STEPS = Values("a whole number", int, lambda v: v >= 0, "a count of steps is at least 0")
FLAG = Values("0 or 1", _flag)   # reached: 1 where the stage ended in equilibrium
TEXT = Values("text", str)   # any value, but there: a row cut short has none
# A stage's branch: grains' branch column (preparation, loading, unloading) or, in tables without it, its phase column
# (aggregation, equilibrate, loading, unloading). A table by hand with another word (Loading, load) had its stages
# left out of the fit without a word.
BRANCHES = ("loading", "unloading", "preparation", "aggregation", "equilibrate")
BRANCH = Values("text", str, lambda v: v in BRANCHES, "a branch is loading or unloading (grains' tables also have "
                "preparation, aggregation and equilibrate, which the fit leaves out or takes as loading)")


class StageTable:
    """A CSV stage table, read once it is known to be one (else TableError): `header`, the column names; `rows`, one
    dict per stage, column -> text (None where the row ends short of the header); `lines`, the file's line of each.
    Lines starting with # are left out. `empty`: a file with no stage (nothing at all, or a header only) is taken as
    a table without rows; else it is refused."""

    def __init__(self, path, empty=False):
        self.path = pathlib.Path(path)
        if kind := run_files.not_a_regular_file(self.path):   # open would wait on a FIFO until something writes into it
            raise TableError(f"stage table '{self.path}' is {kind}, not a CSV file")
        self.header, self.rows, self.lines = [], [], []
        try:
            with open(self.path, newline="") as f:
                reader = csv.reader(f)
                for record in reader:
                    if not record or record[0].startswith("#"):
                        continue
                    if not self.header:
                        self.header = record
                        continue
                    self.rows.append(dict(itertools.zip_longest(self.header, record[:len(self.header)])))
                    self.lines.append(reader.line_num)
        except FileNotFoundError:
            raise TableError(f"stage table '{self.path}' does not exist") from None
        except UnicodeDecodeError:   # an HDF5 file, an image: open() reads text
            raise TableError(f"stage table '{self.path}' is not a text (CSV) file") from None
        except csv.Error as error:   # a NUL byte, a field past csv's size limit
            raise TableError(f"stage table '{self.path}' line {reader.line_num}: {error}") from None
        except OSError as error:
            raise TableError(f"stage table '{self.path}' cannot be read ({error.strerror})") from None
        if not self.rows and not empty:
            raise TableError(f"stage table '{self.path}' " + ("has a header and no stage" if self.header
                                                               else "is empty: no header naming its columns, no stage"))

    def columns(self, *wanted):
        """The header's name of each wanted column: a name, or a tuple of the names it goes by (the first the header
        has is taken). TableError when the header lacks any, naming what it needs and what it has."""
        wanted = [(w,) if isinstance(w, str) else w for w in wanted]
        found = [next((n for n in names if n in self.header), None) for names in wanted]
        if None in found:
            need = [names[0] + "".join(f" (or {n})" for n in names[1:]) for names in wanted]
            need = need[0] if len(need) == 1 else ", ".join(need[:-1]) + " and " + need[-1]
            raise TableError(f"stage table '{self.path}' needs a header with columns {need}; it has "
                             f"{', '.join(self.header) or 'none'}")
        return found

    def check(self, values, rows=None):
        """TableError at the first of `rows` (indices, in the file's order; default all) with a value that is not as
        `values` (column -> Values) says."""
        for i in range(len(self.rows)) if rows is None else rows:
            row = self.rows[i]
            for column, kind in values.items():
                text, where = row[column], f"stage table '{self.path}' line {self.lines[i]}: column '{column}'"
                if text is None:
                    fields = sum(v is not None for v in row.values())
                    raise TableError(f"{where} is missing: the row has {fields} of the header's {len(self.header)} "
                                     "fields")
                try:
                    value = kind.parse(text)
                except ValueError:
                    raise TableError(f"{where} = '{text}' is not {kind.kind}") from None
                if kind.within and not kind.within(value):
                    raise TableError(f"{where} = '{text}' is out of range: {kind.allowed}")


# Column names accepted for each quantity: this tool's own, and those of `grains consolidate`'s table.
COLUMNS = {"P_star": ("P_star", "pressure_reduced"), "phi": ("phi", "solid_fraction"), "branch": ("branch", "phase")}


def recorded_table(h5):
    """The stage table a `grains consolidate` HDF5 file names (its grains group's stage_table attribute, a path
    relative to the file's folder), or None when the file is unreadable, not a regular file or names none."""
    import h5py
    if run_files.not_a_regular_file(h5):   # h5py would wait on a FIFO until something writes into it
        return None
    try:
        with h5py.File(h5, "r") as f:
            name = f["grains"].attrs.get("stage_table") if "grains" in f else None
    except OSError:
        return None
    if name is None:
        return None
    return h5.parent / (name.decode() if isinstance(name, bytes) else str(name))


def names_stages(path):
    """Whether the CSV file at `path` is the stage table of `grains consolidate`: its header (the first line not
    starting with #) has the columns stage and P*. A CSV beside a run that is something else (the table of
    density_correlations.py --table STEM.csv, whose rows are pressures) is not taken for the run's table."""
    try:
        with open(path, newline="") as f:
            header = next((r for r in csv.reader(f) if r and not r[0].startswith("#")), [])
    except (OSError, UnicodeDecodeError, csv.Error):
        return False
    return "stage" in header and any(name in header for name in COLUMNS["P_star"])


def stage_table_of(h5):
    """The stage table written with a `grains consolidate` HDF5 file: the one the file names if it is there, else
    STEM.csv beside it, else STEM.partial.csv (a campaign's sample still running, or stopped), each only if it is
    a stage table (names_stages); None if none is."""
    h5 = pathlib.Path(h5)
    recorded = recorded_table(h5)
    if recorded is not None and recorded.is_file():
        return recorded
    for table in (h5.with_suffix(".csv"), h5.with_suffix(".partial.csv")):
        if table.is_file() and names_stages(table):   # is_file: a FIFO would hang the read
            return table
    return None


def read_stages(path):
    """(P*, Phi, branch) arrays from a CSV stage table (given, or the one a `grains consolidate` HDF5 file names,
    else the one beside it). Rows of `grains consolidate` that did not reach equilibrium (reached = 0), the aggregation stage
    and the relaxation at target P* = 0 are left out (and counted on stderr); its `equilibrate` stage at
    the start pressure is the first loading point. TableError names the line, column and value of a value that is
    no number, a solid fraction outside (0, 1], a P* of a stage the fit takes that is negative or not finite, or a
    stage the fit takes given twice (the same P* and branch)."""
    path = pathlib.Path(path)
    if not path.exists():
        raise FileNotFoundError(f"stage table '{path}' does not exist")
    if kind := run_files.not_a_regular_file(path):   # a FIFO: open and h5py would wait for a writer
        raise TableError(f"stage table '{path}' is {kind}: name the stage table (CSV) or the HDF5 file grains "
                         "consolidate wrote with it")
    if path.suffix in (".h5", ".hdf5"):   # the stage table grains consolidate wrote with it
        table = stage_table_of(path)
        if table is None:
            raise TableError(f"'{path}' is named as an HDF5 file: the fit reads the stage table (CSV) that `grains consolidate` "
                             f"writes with it (--table), and there is none at '{recorded_table(path) or path.with_suffix('.csv')}'")
        print(f"reading the stage table {table}", file=sys.stderr)
        path = table
    table = StageTable(path)
    pick = dict(zip(("P_star", "phi"), table.columns(COLUMNS["P_star"], COLUMNS["phi"])))
    pick["branch"] = next((c for c in COLUMNS["branch"] if c in table.header), None)
    rows = table.rows
    table.check({pick["P_star"]: NUMBER, pick["phi"]: SOLID_FRACTION,
                 **{c: kind for c, kind in ((pick["branch"], BRANCH), ("target_pressure", NUMBER), ("reached", FLAG))
                    if c in table.header}})
    p = np.array([float(r[pick["P_star"]]) for r in rows])
    phi = np.array([float(r[pick["phi"]]) for r in rows])
    branch = np.array([r[pick["branch"]] for r in rows]) if pick["branch"] else None
    reached = np.array([r.get("reached", "1") != "0" for r in rows])
    # grains consolidate: the aggregation stage (no target) and the relaxation at P* = 0 are preparation
    prepared = np.array([float(r.get("target_pressure", "1")) > 0 for r in rows])
    if branch is None:   # loading = the stages up to the largest pressure
        top = int(np.argmax(p))
        branch = np.array(["loading"] * (top + 1) + ["unloading"] * (len(p) - top - 1))
    branch = np.where(branch == "equilibrate", "loading", branch)
    taken = reached & prepared & np.isin(branch, ["loading", "unloading"])
    table.check({pick["P_star"]: REDUCED_PRESSURE}, np.flatnonzero(taken))   # P* = 0 (a relaxation) is left out below
    keep = taken & (p > 0)
    # a stage given twice (a row pasted again, two tables joined) was fitted as two and moved Phimax
    first = {}
    for i in np.flatnonzero(keep):
        key = (p[i], branch[i])
        if key in first:
            raise TableError(f"stage table '{path}' lines {table.lines[first[key]]} and {table.lines[i]}: the same stage "
                             f"twice ({pick['P_star']} = {rows[i][pick['P_star']]}, branch {branch[i]}); give each stage once")
        first[key] = i
    if (~keep).any():
        print(f"{int((~reached).sum())} stage(s) without equilibrium and {int((~keep & reached).sum())} preparation "
              f"stage(s) left out", file=sys.stderr)
    return p[keep], phi[keep], branch[keep]


def plot(p, phi, branch, regime2, crossover, out, title=""):
    """Phi and 1/Phi against P* with both fits, their parameters in the legend; returns the figure."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, (top, bottom) = plt.subplots(2, 1, figsize=(6.4, 7.2), sharex=True)
    loading = branch == "loading"
    curve = np.geomspace(min(p.min(), regime2["P0"]), p.max(), 300)
    for ax, f in ((top, lambda v: v), (bottom, lambda v: 1.0 / v)):
        ax.plot(p[loading], f(phi[loading]), "o", mfc="none", label="loading")
        if (~loading).any():
            ax.plot(p[~loading], f(phi[~loading]), "s", mfc="none", label="unloading")
        if crossover:
            c = crossover
            inv = crossover_curve(curve, (1 / c["phi0"], c["lambda"], c["phi_max"], c["alpha"]), c["P0"])
            ax.plot(curve, f(1.0 / inv), "-",
                    label=f"regimes II-III fit: λ = {c['lambda']:.3f}, Φmax = {c['phi_max']:.4f}, P1* = {c['P1']:.3g}")
        # the line over the stages it was fitted to: drawn to 10 P0* it ran past them, to Phi 0.9 above the data
        line = curve[(curve >= regime2["P0"]) & (curve <= regime2["P_last"])]
        ax.plot(line, f(1.0 / inverse_phi_regime_two(line, 1 / regime2["phi0"], regime2["lambda"], regime2["P0"])),
                "--", label=f"regime II line: λ = {regime2['lambda']:.3f}, P0* = {regime2['P0']:.3g}")
        ax.set_xscale("log")
    top.set_ylabel("solid fraction Φ")
    bottom.set_ylabel("1 / Φ")
    bottom.set_xlabel("reduced pressure P*")
    top.legend(fontsize=8)
    top.set_title(title, fontsize=10)
    fig.tight_layout()
    fig.savefig(out, dpi=120)
    plt.close(fig)
    return fig


def main(argv=None):
    ap = argparse.ArgumentParser(description="Fit the consolidation curve Phi(P*) (physics.md section 9).")
    ap.add_argument("table", help="stage table: CSV with P_star, phi (and optionally branch), or the HDF5 file of grains consolidate "
                                      "(the stage table it names is read)")
    ap.add_argument("-o", "--out", help="plot file (PNG); default: beside the table")
    ap.add_argument("--p0", type=float, help="P0*, start of regime II (default: the line meets the initial plateau)")
    ap.add_argument("--regime2-max", type=float, default=0.1, help="largest P* of the regime II line fit (default 0.1)")
    args = ap.parse_args(argv)
    for option, value in (("--p0", args.p0), ("--regime2-max", args.regime2_max)):
        if value is not None and not value > 0:
            ap.error(f"{option}: {value}; a reduced pressure P* > 0")
    from plot import image_name_problem
    if args.out and (problem := image_name_problem("--out", args.out)):
        print(f"consolidation_fit: {problem}", file=sys.stderr)
        return 2
    try:
        p, phi, branch = read_stages(args.table)
        loading = branch == "loading"
        regime2 = fit_regime_two(p[loading], phi[loading], args.p0, args.regime2_max)
        if not regime2["lambda"] > max(2 * regime2["lambda_err"], 1e-6):   # falling or flat Phi: lambda <= 0
            raise ValueError(f"regime II fit: lambda = {regime2['lambda']:.4g} +- {regime2['lambda_err']:.2g}: Phi does "
                             f"not grow with P* in the loading stages up to P* = {args.regime2_max:g}, so they hold no "
                             "regime II to fit")
        try:
            crossover = fit_crossover(p[loading], phi[loading], args.p0, guess=guess_from_line(regime2, phi[loading]))
        except (ValueError, RuntimeError) as e:
            print(f"regimes II-III fit not done: {e}", file=sys.stderr)
            crossover = None
    except (OSError, ValueError) as e:
        print(f"consolidation_fit: {e}", file=sys.stderr)
        return 2
    print(f"regime II ({regime2['stages']} stages): P0* = {regime2['P0']:.4g}, Phi0 = {regime2['phi0']:.4f}, "
          f"lambda = {regime2['lambda']:.4f} +- {regime2['lambda_err']:.2g}")
    if crossover:
        c = crossover
        print(f"regimes II-III ({c['stages']} stages from P0* = {c['P0']:.4g}): Phi0 = {c['phi0']:.4f} +- {c['phi0_err']:.2g}, "
              f"lambda = {c['lambda']:.4f} +- {c['lambda_err']:.2g}, Phimax = {c['phi_max']:.4f} +- {c['phi_max_err']:.2g}, "
              f"alpha = {c['alpha']:.3f} +- {c['alpha_err']:.2g}, P1* = {c['P1']:.4g} +- {c['P1_err']:.2g}")
    out = args.out or str(pathlib.Path(args.table).with_suffix("")) + "-fit.png"
    plot(p, phi, branch, regime2, crossover, out, f"Consolidation curve of {pathlib.Path(args.table).name}")
    print(f"plot: {out}")
    return 0


if __name__ == "__main__":
    sys.exit(tool_exits.run_read_only(main, "consolidation_fit.py"))
