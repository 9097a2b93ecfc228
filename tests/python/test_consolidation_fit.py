"""The consolidation-curve fits (physics.md section 9) recover the parameters of synthetic curves
made from the formulas, and the command writes its plot and names bad input."""
import math
import os
import subprocess
import sys

import numpy as np
import pytest

from conftest import ROOT
from h5text import text

sys.path.insert(0, str(ROOT / "runner"))
import consolidation_fit as cf  # noqa: E402

# The paper's fit without rolling resistance (physics.md section 9 table).
P0, PHI0, LAM, PHI_MAX, ALPHA = 0.0237, 0.469, 0.349, 0.7808, 0.91


def programme():
    """The loading programme: P* x 10^(1/8) per stage from 0.01 to 13.33."""
    return 0.01 * 10 ** (np.arange(0, 26) / 8)


def synthetic_phi(p):
    """Regime I plateau below P0*, the regimes II-III form above."""
    inv = np.where(p < P0, 1 / PHI0, cf.inverse_phi_crossover(np.maximum(p, P0), 1 / PHI0, LAM, PHI_MAX, ALPHA, P0))
    return 1 / inv


def test_crossover_fit_recovers_the_parameters_and_p1():
    p = programme()
    fit = cf.fit_crossover(p, synthetic_phi(p), P0)
    assert fit["lambda"] == pytest.approx(LAM, rel=1e-6)
    assert fit["phi_max"] == pytest.approx(PHI_MAX, rel=1e-6)
    assert fit["alpha"] == pytest.approx(ALPHA, rel=1e-6)   # 1.3e-9 measured (lambda 4.4e-10, the others ~1e-11)
    assert fit["phi0"] == pytest.approx(PHI0, rel=1e-6)
    # ln(P1*/P0*) = (1/Phi0 - 1/Phimax) / lambda: the paper's P1* = 0.271 +- 0.033.
    assert fit["P1"] == pytest.approx(P0 * math.exp((1 / PHI0 - 1 / PHI_MAX) / LAM), rel=1e-5)
    assert abs(fit["P1"] - 0.271) < 0.033


def test_crossover_fit_finds_where_regime_two_starts():
    """P0* lies between the scan's grid points: the refinement finds it (the grid's best point alone is 3 %
    off in P0* and 2 % in lambda)."""
    p = programme()
    fit = cf.fit_crossover(p, synthetic_phi(p))
    assert fit["P0"] == pytest.approx(P0, rel=1e-5)
    assert fit["lambda"] == pytest.approx(LAM, rel=1e-5)
    assert fit["phi_max"] == pytest.approx(PHI_MAX, rel=1e-6)
    assert fit["alpha"] == pytest.approx(ALPHA, rel=1e-5)


def test_crossover_fit_with_noise_stays_within_its_error_bars():
    rng = np.random.default_rng(4)
    p = programme()
    phi = synthetic_phi(p) * (1 + 1e-3 * rng.standard_normal(p.size))
    fit = cf.fit_crossover(p, phi, P0)
    for name, true in (("lambda", LAM), ("phi_max", PHI_MAX), ("alpha", ALPHA)):
        assert 0 < fit[name + "_err"] < 0.2 * true
        assert abs(fit[name] - true) < 4 * fit[name + "_err"], name


def test_crossover_tends_to_phimax_with_the_power_law_tail():
    p = np.array([1e3, 1e4])
    inv = cf.inverse_phi_crossover(p, 1 / PHI0, LAM, PHI_MAX, ALPHA, P0)
    p1 = P0 * math.exp((1 / PHI0 - 1 / PHI_MAX) / LAM)
    tail = 1 / PHI_MAX + LAM / (2 * ALPHA) * (p1 / p) ** ALPHA
    assert inv == pytest.approx(tail, rel=1e-6)
    # and to the regime II line at small P*
    assert cf.inverse_phi_crossover(np.array([P0]), 1 / PHI0, LAM, PHI_MAX, ALPHA, P0)[0] == pytest.approx(1 / PHI0, abs=1e-4)


def test_crossover_far_below_p1_is_the_regime_two_line_without_a_warning():
    """With a steep crossover (alpha = 300, as an optimiser may try) (P1*/P*)^alpha overflows far below P1*;
    the limit is the regime II line, and no overflow warning reaches the campaign's output."""
    import warnings
    p = np.array([1e-3, 0.01, 0.02])
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        inv = cf.inverse_phi_crossover(p, 1 / PHI0, LAM, PHI_MAX, 300.0, P0)
    assert inv == pytest.approx(1 / PHI0 - LAM * np.log(p / P0), rel=1e-12)


def test_crossover_far_above_p1_is_phimax_without_a_warning():
    """Far above P1* with a steep crossover (P1*/P*)^alpha underflows to 0; the limit is 1/Phimax (it was
    inf, with a divide-by-zero warning in the campaign's output, where an optimiser's trial reached it)."""
    import warnings
    p = np.array([10.0, 1e3, 1e300])
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        inv = cf.inverse_phi_crossover(p, 1 / PHI0, LAM, PHI_MAX, 300.0, P0)
    assert inv == pytest.approx(1 / PHI_MAX, rel=1e-12)


def test_crossover_at_p1_against_its_closed_form():
    """physics.md section 9's form at P* = P1*, worked by hand: there (P1*/P*)^alpha = 1, so
    1/Phi = 1/Phi0 - lambda ln(P1*/P0*) - (lambda/alpha) ln(1 - 1/e) = 1/Phimax - (lambda/alpha) ln(1 - 1/e);
    with the paper's parameters P1* = 0.271832 and Phi = 0.686508."""
    p1 = P0 * math.exp((1 / PHI0 - 1 / PHI_MAX) / LAM)
    assert p1 == pytest.approx(0.271832, abs=1e-6)
    inv = cf.inverse_phi_crossover(np.array([p1]), 1 / PHI0, LAM, PHI_MAX, ALPHA, P0)[0]
    assert 1 / inv == pytest.approx(0.686508, abs=1e-6)


def test_regime_two_line_and_its_start():
    p = programme()
    phi = 1 / np.where(p < P0, 1 / PHI0, 1 / PHI0 - LAM * np.log(np.maximum(p, P0) / P0))
    fit = cf.fit_regime_two(p[p >= P0], phi[p >= P0], p_max=1.0)
    assert fit["lambda"] == pytest.approx(LAM, rel=1e-10)
    # P0* found as the kink between the regime I plateau and the line, then Phi0 is the plateau.
    fit = cf.fit_regime_two(p, phi, p_max=1.0)
    assert fit["P0"] == pytest.approx(P0, rel=0.02)
    assert fit["phi0"] == pytest.approx(PHI0, rel=1e-3)
    assert fit["lambda"] == pytest.approx(LAM, rel=0.01)


def test_regime_two_error_at_a_given_p0_is_the_straight_line_fits():
    """With P0* given only 1/Phi0 and lambda are fitted: lambda's standard error is ordinary least squares'
    with n - 2 degrees of freedom (it took n - 3, as when P0* is found too)."""
    rng = np.random.default_rng(3)
    p = P0 * 1.334 ** np.arange(6)
    inv_phi = 1 / PHI0 - LAM * np.log(p / P0) + rng.normal(0, 2e-3, p.size)
    fit = cf.fit_regime_two(p, 1 / inv_phi, p0=P0, p_max=1.0)
    _, cov = np.polyfit(np.log(p / P0), inv_phi, 1, cov="unscaled")
    residual = np.sum((np.polyval(np.polyfit(np.log(p / P0), inv_phi, 1), np.log(p / P0)) - inv_phi) ** 2)
    assert fit["lambda_err"] == pytest.approx(math.sqrt(cov[0, 0] * residual / (p.size - 2)), rel=1e-9)


def test_command_fits_a_table_and_writes_the_plot(tmp_path):
    p = programme()
    phi = synthetic_phi(p)
    table = tmp_path / "stages.csv"
    rows = ["P_star,phi,branch"] + [f"{a:.17g},{b:.17g},loading" for a, b in zip(p, phi)]
    rows += [f"{a:.17g},{phi[-1]:.17g},unloading" for a in p[::-4][1:]]   # irreversible: Phi stays near its top
    table.write_text("\n".join(rows) + "\n")
    out = tmp_path / "fit.png"
    r = subprocess.run([sys.executable, str(ROOT / "runner" / "consolidation_fit.py"), str(table), "-o", str(out),
                        "--p0", str(P0)], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    assert "lambda = 0.3490" in r.stdout and "Phimax = 0.7808" in r.stdout
    assert out.stat().st_size > 10000
    bad = tmp_path / "bad.csv"
    bad.write_text("pressure,phi\n1,0.5\n")
    r = subprocess.run([sys.executable, str(ROOT / "runner" / "consolidation_fit.py"), str(bad)],
                       capture_output=True, text=True)
    assert r.returncode == 2 and "P_star" in r.stderr
    for value in ("0", "-1"):   # a math domain error, naming nothing, before
        r = subprocess.run([sys.executable, str(ROOT / "runner" / "consolidation_fit.py"), str(bad), "--p0", value],
                           capture_output=True, text=True)
        assert r.returncode == 2 and f"--p0: {float(value)}; a reduced pressure P* > 0" in r.stderr, r.stderr


def test_reads_the_table_of_grains_consolidate(tmp_path):
    """Columns of `grains consolidate`: the aggregation, P* = 0 and unreached stages are left out, the
    prepared state (phase equilibrate) starts the loading branch."""
    p = programme()
    phi = synthetic_phi(p)
    rows = ["stage,phase,target_pressure,reached,steps,time,pressure_reduced,solid_fraction,coordination",
            "0,aggregation,nan,1,100,1,0,0.36,2.9", "1,equilibrate,0,1,100,2,1e-9,0.40,3.0"]
    rows.append(f"2,equilibrate,0.01,1,100,3,{p[0]:.17g},{phi[0]:.17g},3.0")
    rows += [f"{k + 3},loading,{a:.17g},1,100,4,{a:.17g},{b:.17g},3.0" for k, (a, b) in enumerate(zip(p[1:], phi[1:]))]
    rows.append("99,unloading,1,0,100,5,0.9,0.5,3.0")   # not reached: out
    rows.append(f"100,unloading,0.01,1,100,6,0.01,{phi[-1]:.17g},3.0")
    table = tmp_path / "consolidation-stages.csv"
    table.write_text("\n".join(rows) + "\n")
    got_p, got_phi, branch = cf.read_stages(table)
    assert list(branch).count("loading") == len(p) and list(branch).count("unloading") == 1
    assert got_p[0] == p[0] and got_phi[-1] == phi[-1]
    fit = cf.fit_crossover(got_p[branch == "loading"], got_phi[branch == "loading"], P0)
    assert fit["lambda"] == pytest.approx(LAM, rel=1e-6)
    # given the HDF5 file of the same run, the table beside it is read; without one the message says so
    h5 = table.with_suffix(".h5")
    h5.write_bytes(b"")   # only its name matters
    assert (cf.read_stages(h5)[0] == got_p).all()
    table.unlink()
    with pytest.raises(ValueError, match="stage table .CSV. that `grains consolidate` writes"):
        cf.read_stages(h5)


def test_reads_the_stage_table_the_hdf5_file_names(grains_bin, tmp_path):
    """`grains consolidate --out run/a.h5 --table tables/b.csv` records the table in the file (the grains group's
    stage_table, relative to the file's folder): given a.h5, the fit reads b.csv."""
    import h5py
    h5, table = tmp_path / "run" / "a.h5", tmp_path / "tables" / "b.csv"
    h5.parent.mkdir()
    table.parent.mkdir()
    r = subprocess.run([grains_bin, "consolidate", str(ROOT / "models" / "consolidation-type1.toml"), "--out", str(h5),
                        "--table", str(table), "--set", "particles.count=60", "--set", "programme.top_pressure=0.1",
                        "--set", "programme.stage_budget=20000"], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    with h5py.File(h5, "r") as f:
        assert (h5.parent / text(f["grains"].attrs["stage_table"])).resolve() == table.resolve()
    assert all((a == b).all() for a, b in zip(cf.read_stages(h5), cf.read_stages(table)))
    usage = subprocess.run([sys.executable, str(ROOT / "runner" / "consolidation_fit.py"), "--help"],
                           capture_output=True, text=True).stdout
    assert "stages/" not in usage and "the stage table it names" in " ".join(usage.split())


def test_plot_draws_each_fit_over_its_stages_with_its_parameters(tmp_path):
    """The regime II line was drawn to 10 P0* whatever stages it was fitted to (P* <= 0.1): past them it rose to
    Phi 0.9, above every stage; the legend gave no fitted value."""
    pytest.importorskip("matplotlib")
    p = programme()
    phi = synthetic_phi(p)
    branch = np.array(["loading"] * p.size)
    regime2 = cf.fit_regime_two(p, phi, p_max=0.1)
    crossover = cf.fit_crossover(p, phi)
    fig = cf.plot(p, phi, branch, regime2, crossover, tmp_path / "fit.png", "stages.csv")
    top = fig.axes[0]
    line = [l for l in top.lines if l.get_label().startswith("regime II line")]
    assert len(line) == 1 and line[0].get_xdata().max() <= p[p <= 0.1].max()
    assert line[0].get_xdata().min() >= regime2["P0"]
    labels = [l.get_label() for l in top.lines]
    assert f"regime II line: λ = {regime2['lambda']:.3f}, P0* = {regime2['P0']:.3g}" in labels
    assert any(label.startswith(f"regimes II-III fit: λ = {crossover['lambda']:.3f}, Φmax = {crossover['phi_max']:.4f}")
               for label in labels)
    assert top.get_title() == "stages.csv"


@pytest.mark.parametrize("suffix", [".csv", ".h5"])
@pytest.mark.parametrize("kind", ["folder", "FIFO (named pipe)"])
def test_a_table_that_is_not_a_regular_file_is_named_as_what_it_is(tmp_path, suffix, kind):
    """A FIFO given as the stage table, or as the HDF5 file whose table is read, held the fit without end (open and
    h5py wait for a writer); a folder was reported as a bare IsADirectoryError, or as an HDF5 file without a table."""
    table = tmp_path / f"stages{suffix}"
    table.mkdir() if kind == "folder" else os.mkfifo(table)
    r = subprocess.run([sys.executable, ROOT / "runner" / "consolidation_fit.py", table], capture_output=True,
                       text=True, timeout=60)
    assert r.returncode == 2 and r.stderr == (f"consolidation_fit: stage table '{table}' is a {kind}: name the stage "
                                              "table (CSV) or the HDF5 file grains consolidate wrote with it\n"), r.stderr


def test_a_plateau_joined_to_the_curve_has_no_step_where_p1_is_a_few_p0():
    """The plateau at 1/Phi0 meets the crossover form with a step of lambda ln(1 - exp(-(P1*/P0*)^alpha)) / alpha:
    nothing at the paper's P1* = 11 P0*, 0.04 in 1/Phi at 3 P0*. The joined form has none and recovers a curve made
    with it, P0* scanned; at the paper's parameters the two forms agree."""
    lam, phi0, phi_max, alpha, p0 = 0.6, 0.49, 0.78, 0.8, 0.03
    assert math.exp((1 / phi0 - 1 / phi_max) / lam) < 4   # P1* / P0*: 3.54
    p = programme()
    phi = 1 / cf.inverse_phi_crossover(np.maximum(p, p0), 1 / phi0, lam, phi_max, alpha, p0)
    joined = cf.fit_crossover(p, phi, joined=True)
    assert joined["lambda"] == pytest.approx(lam, rel=1e-4) and joined["P0"] == pytest.approx(p0, rel=1e-3)
    step = -lam * math.log(-math.expm1(-(joined["P1"] / p0) ** alpha)) / alpha
    assert step > 0.03
    paper = cf.fit_crossover(programme(), synthetic_phi(programme()), joined=True)
    assert paper["lambda"] == pytest.approx(LAM, rel=1e-3) and paper["P0"] == pytest.approx(P0, rel=1e-2)


def test_the_errors_of_a_scanned_fit_are_the_spread_of_its_estimates():
    """The scanned P0* is fitted too: its covariance with lambda belongs in the errors. Scaling a four-parameter
    covariance for the lost degree of freedom alone gives errors 0.53 (lambda) and 0.61 (P1*) times the scatter of
    60 noisy curves' estimates (0.54 and 0.64 over the 16 here); with the five-parameter Jacobian
    0.85 and 0.90 here, 0.7 and 0.8 over 60 (the plateau's kink, which no linearisation sees, keeps them below 1)."""
    rng = np.random.default_rng(7)
    p = programme()
    clean = synthetic_phi(p)
    estimates, errors = [], []
    for _ in range(16):
        phi = clean * (1 + 2e-3 * rng.standard_normal(p.size))
        line = cf.fit_regime_two(p, phi)
        fit = cf.fit_crossover(p, phi, guess=(1 / line["phi0"], line["lambda"], phi.max() * 1.01, 1.0))
        estimates.append([fit["lambda"], fit["P1"]])
        errors.append([fit["lambda_err"], fit["P1_err"]])
    ratio = np.median(errors, axis=0) / np.std(estimates, axis=0)
    assert ratio[0] > 0.7 and np.all(ratio > 0.6) and np.all(ratio < 1.5), ratio


def test_a_line_and_its_start_need_a_stage_left_over():
    """Three stages and a scanned P0*: three parameters from three points, which gave lambda +- 7e-8 (a review)."""
    p = programme()[:9]
    phi = 1 / (1 / PHI0 - LAM * np.log(p / 0.01))
    with pytest.raises(ValueError, match="need at least 4"):
        cf.fit_regime_two(p[:3], phi[:3])
    assert cf.fit_regime_two(p[:3], phi[:3], p0=0.01)["lambda"] == pytest.approx(LAM)   # P0* given: 3 suffice
    assert cf.fit_regime_two(p[:4], phi[:4])["lambda"] == pytest.approx(LAM, rel=1e-6)


@pytest.mark.parametrize("shape", ["falling", "flat"])
def test_stages_whose_phi_does_not_grow_hold_no_regime_two(tmp_path, shape):
    """A falling Phi gives lambda = -0.022 and a flat one lambda = 0: no regime II, not a fit with exit status 0."""
    p = programme()
    phi = synthetic_phi(p)[::-1] if shape == "falling" else np.full(p.size, 0.6)
    table = tmp_path / "t.csv"
    table.write_text("P_star,phi,branch\n" + "".join(f"{a},{b},loading\n" for a, b in zip(p, phi)))
    r = subprocess.run([sys.executable, str(ROOT / "runner" / "consolidation_fit.py"), str(table), "-o",
                        str(tmp_path / "t.png")], capture_output=True, text=True)
    assert r.returncode == 2 and "Phi does not grow with P*" in r.stderr and "no regime II" in r.stderr, r.stderr
    assert not (tmp_path / "t.png").exists()


def test_a_stage_given_twice_is_refused_naming_both_lines(tmp_path):
    """A duplicated row (the same P* and branch twice) fitted as two stages would move Phimax (0.8814 -> 0.8859); a
    loading and an unloading stage at one P* are two stages."""
    p = programme()
    phi = synthetic_phi(p)
    rows = ["P_star,phi,branch"] + [f"{a:.17g},{b:.17g},loading" for a, b in zip(p, phi)]
    rows += [f"{p[-3]:.17g},{phi[-1]:.17g},unloading"]
    table = tmp_path / "stages.csv"
    table.write_text("\n".join(rows + [rows[5]]) + "\n")
    r = subprocess.run([sys.executable, str(ROOT / "runner" / "consolidation_fit.py"), str(table), "-o",
                        str(tmp_path / "fit.png")], capture_output=True, text=True)
    assert r.returncode == 2 and "Traceback" not in r.stderr, r.stderr
    assert all(w in r.stderr for w in (str(table), "lines 6 and 29", f"P_star = {p[4]:.17g}", "loading")), r.stderr
    assert not (tmp_path / "fit.png").exists()
    table.write_text("\n".join(rows) + "\n")   # the same P* on both branches is no duplicate
    assert len(cf.read_stages(table)[0]) == len(p) + 1


def test_a_joined_fit_takes_its_errors_from_its_own_model():
    """The five-parameter covariance of a scanned P0* differentiates a joined fit's own model: the flat plateau's
    gives Phi0's error 4.6 times too small where P1* is a few P0*."""
    rng = np.random.default_rng(3)
    p = np.geomspace(1e-4, 10, 24)
    truth = (1 / 0.40, 0.12, 0.4223, 1.0, 3e-3)
    y = cf.plateau_then(p, truth[4], truth[0], lambda q: cf.inverse_phi_crossover(q, *truth[:4], truth[4]))
    phi = 1 / (y + rng.normal(0, 1e-3, len(p)))
    fit = cf.fit_crossover(p, phi, guess=(1 / 0.40, 0.12, truth[2] * 1.01, 1.0), joined=True)
    theta = np.array([1 / fit["phi0"], fit["lambda"], fit["phi_max"], fit["alpha"], math.log(fit["P0"])])

    def joined(t):
        c = math.exp(t[4])
        return cf.inverse_phi_crossover(np.maximum(p, c), *t[:4], c)

    jac = np.empty((len(p), 5))
    for k in range(5):
        h = 1e-6 * max(abs(theta[k]), 1.0)
        up, down = theta.copy(), theta.copy()
        up[k] += h
        down[k] -= h
        jac[:, k] = (joined(up) - joined(down)) / (2 * h)
    cov = np.linalg.pinv(jac.T @ jac) * float(np.sum((joined(theta) - 1 / phi) ** 2)) / (len(p) - 5)
    assert fit["phi0_err"] == pytest.approx(math.sqrt(cov[0, 0]) * fit["phi0"] ** 2, rel=1e-3)
    assert fit["lambda_err"] == pytest.approx(math.sqrt(cov[1, 1]), rel=1e-3)
