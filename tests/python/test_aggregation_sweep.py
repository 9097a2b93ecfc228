"""The aggregation sweep (runner/aggregation_sweep.py): its conversion of (zeta, k*) into the scene's
restitution and contact duration, its reading of the virial ratio, its verdicts, and a small sweep run
end to end through grains."""
import csv
import math
import os
import re
import subprocess
import sys

import numpy as np
import pytest

from conftest import ROOT

sys.path.insert(0, str(ROOT / "runner"))
import aggregation_sweep as sweep  # noqa: E402
import scene_check  # noqa: E402


def test_damping_ratio_and_restitution_are_inverse():
    for zeta in (0.0, 0.002, 0.1, 0.5, 0.9):
        assert sweep.damping_ratio(sweep.restitution(zeta)) == pytest.approx(zeta, abs=1e-12)
    assert sweep.restitution(0.0) == 1.0


def test_contact_duration_gives_the_requested_stiffness():
    """k_n = m* (pi^2 + ln^2 e) / t_c^2 (physics.md section 2) equals k* k_g; the scene as written is
    e = 0.5, t_c = 0.02 with m* = 1/2 and k_g = G m^2 / (4 R^3) = 2."""
    m_star, k_g = 0.5, 2.0
    for zeta, k_star in ((0.0, 10.0), (0.3, 6.5e3), (0.9, 1e6)):
        t_c = sweep.contact_duration(zeta, k_star, m_star, k_g)
        k_n = m_star * (math.pi ** 2 + math.log(sweep.restitution(zeta)) ** 2) / t_c ** 2
        assert k_n == pytest.approx(k_star * k_g, rel=1e-12)
    scene = {"particles": {"diameter": 1.0, "mass": 1.0}, "gravity": {"G": 1.0},
             "contact": {"restitution": 0.5, "duration": 0.02}}
    assert sweep.grain(scene) == (0.5, 2.0)
    zeta, k_star = sweep.scene_point(scene, 0.5, 2.0)
    assert zeta == pytest.approx(sweep.damping_ratio(0.5)) and k_star == pytest.approx(0.5 * (math.pi ** 2 + math.log(0.5) ** 2) / 4e-4 / 2)
    with pytest.raises(ValueError, match="one grain size"):
        sweep.grain({"particles": {"size_distribution": "uniform"}, "gravity": {}})


def test_points_past_the_damped_packing_rule_run_at_its_steps_per_contact(grains_bin):
    """The rule (engine/core/dashpot_stability.hpp) asks for 92 steps per contact at zeta = 0.9 and 44 at 0.7,
    at any k*; weaker dampings stay at the scene's 30. The raised runs carry n_c in their names."""
    m_star, k_g = 0.5, 2.0
    for zeta, needed in ((0.9, 92), (0.7, 44), (0.5, None), (0.0, None)):
        for k_star in (10.0, 1e6):
            assert sweep.stable_steps_per_contact(grains_bin, zeta, k_star, m_star, k_g, []) == needed
    assert sweep.stable_steps_per_contact(grains_bin, 0.9, 100.0, m_star, k_g, ["time.steps_per_contact=100"]) is None
    assert sweep.run_name(0.9, 6468.79, 1, {"time.steps_per_contact": 92}) == "z0p9-k6469-n92-s1"
    assert sweep.run_name(0.9, 6468.79, 1) == sweep.run_name(0.9, 6468.79, 1, {}) == "z0p9-k6469-s1"
    own = {"output.observables_every": 8, "analysis.every": 4}
    assert sweep.run_name(0.1, 10, 2, own) == "z0p1-k10-a4o8-s2"
    points = [{"zeta": 0.9, "steps_per_contact": 92}, {"zeta": 0.5, "steps_per_contact": 30}]
    assert sweep.raised_points(points, 30)[-1].endswith("zeta 0.9 at 92.") and sweep.raised_points(points[1:], 30) == []


def test_an_override_of_a_sweep_default_replaces_it_and_each_key_is_given_once(grains_bin):
    """The sweep set output.snapshots_every = 0 before the user's overrides, so a --set of it gave the key twice:
    the last one won silently then, and grains now refuses a key given twice with two values."""
    m_star, k_g = 0.5, 2.0
    own = {"time.steps_per_contact": 92}
    for overrides, snapshots in (([], 0), (["output.snapshots_every=7"], 7)):
        settings = sweep.run_settings(0.9, 10.0, 1, m_star, k_g, 1, overrides + ["time.steps_per_contact=40"], own)
        keys = [s.split("=", 1)[0] for s in settings]
        assert len(keys) == len(set(keys)), settings
        scene = scene_check.resolve(grains_bin, sweep.SCENE, settings)   # grains takes them as they are
        assert scene["output"]["snapshots_every"] == snapshots and scene["time"]["steps_per_contact"] == 92


def test_virial_peaks():
    t = np.linspace(0, 3, 301)
    collapse = np.exp(-((t - 0.6) / 0.15) ** 2)
    q1, t1, q2 = sweep.virial_peaks(t, 0.5 * collapse + 1e-6)
    assert q1 == pytest.approx(0.5, rel=1e-3) and t1 == pytest.approx(0.6, abs=0.01) and q2 == 0.0
    rebound = 0.5 * collapse + 0.05 * np.exp(-((t - 1.8) / 0.3) ** 2) + 1e-4
    assert sweep.virial_peaks(t, rebound)[2] == pytest.approx(0.05, rel=0.01)
    # A rise in a frozen aggregate's noise, below 1 % of the first peak, is no peak.
    assert sweep.virial_peaks(t, 0.5 * collapse + 1e-5 * (1 + np.sin(20 * t) ** 2))[2] == 0.0


def test_virial_peaks_first_is_the_collapse_peak_not_a_higher_later_one():
    """The collapse peak comes first even when a later peak (a re-virialisation, or a run heating up) stands
    higher; noise on the rise and a small early bump are no first peak."""
    t = np.linspace(0, 3, 301)
    q = 0.40 * np.exp(-((t - 0.6) / 0.15) ** 2) + 0.05 + 0.50 * np.exp(-((t - 2.0) / 0.3) ** 2)
    q1, t1, q2 = sweep.virial_peaks(t, q)
    assert q1 == pytest.approx(0.45, rel=1e-3) and t1 == pytest.approx(0.6, abs=0.01)
    assert q2 == pytest.approx(0.55, rel=1e-3)
    # A run that heats up: Q climbs past its collapse peak to the end.
    heating = 0.4 * np.exp(-((t - 0.6) / 0.15) ** 2) + 0.1 + 0.7 * np.clip(t - 1.0, 0, None)
    q1, t1, q2 = sweep.virial_peaks(t, heating)
    assert q1 == pytest.approx(0.5, rel=0.01) and t1 == pytest.approx(0.6, abs=0.02) and q2 == pytest.approx(heating[-1])
    # Noise of +-5 % throughout is passed over, and so is an early bump (a few collisions) from a cold start
    # that stays below 10 % of the highest Q.
    rng = np.random.default_rng(1)
    noisy = q * (1 + 0.05 * rng.uniform(-1, 1, t.size))
    q1, t1, _ = sweep.virial_peaks(t, noisy)
    assert q1 == pytest.approx(0.45, rel=0.06) and t1 == pytest.approx(0.6, abs=0.05)
    cold = 0.45 * np.exp(-((t - 0.6) / 0.15) ** 2) + 0.04 * np.exp(-((t - 0.1) / 0.03) ** 2)
    assert sweep.virial_peaks(t, cold)[:2] == pytest.approx((0.45, 0.6), rel=1e-3)
    # No fall after any maximum (a monotone rise): the highest value.
    assert sweep.virial_peaks(t, t)[:2] == (3.0, 3.0)


def test_medians_over_seeds_treat_a_missing_aggregation_as_never():
    base = {"cluster_index": 0.1, "largest_cluster_fraction": 0.9, "fractal_dimension": 2.9, "q_first_peak": 0.5,
            "q_first_peak_time": 0.6, "q_second_peak": 0.0, "t": [0], "q": [0], "warnings": []}
    runs = [dict(base, t_agg_over_t_ff=v) for v in (1.0, math.nan, 2.0)]
    assert sweep.median_point(runs)["t_agg_over_t_ff"] == 2.0
    runs = [dict(base, t_agg_over_t_ff=v) for v in (1.0, math.nan, math.nan)]
    assert math.isnan(sweep.median_point(runs)["t_agg_over_t_ff"])
    assert sweep.warned_points([dict(sweep.median_point(runs), zeta=0.1, k_star=100)]) == []


def test_points_whose_runs_were_warned_about_are_named():
    base = {"cluster_index": 0.1, "largest_cluster_fraction": 0.9, "fractal_dimension": 2.9, "q_first_peak": 0.5,
            "q_first_peak_time": 0.6, "q_second_peak": 0.0, "t": [0], "q": [0], "t_agg_over_t_ff": 1.0}
    step = "time.dt = 0.002 exceeds 0.001, the largest step at which grains ... settle"
    runs = [dict(base, warnings=[step]), dict(base, warnings=[]), dict(base, warnings=[step])]
    point = dict(sweep.median_point(runs), zeta=0.9, k_star=6469)
    assert point["warned_runs"] == 2 and point["warnings"] == [step]
    lines = sweep.warned_points([point, dict(sweep.median_point([dict(base, warnings=[])]), zeta=0.1, k_star=6469)])
    assert len(lines) == 3 and "zeta 0.9, k* 6.47e+03: 2 of 3 run(s); " + step in lines[-1]


def point(zeta, k_star, index, t_agg, second=0.0):
    return {"zeta": zeta, "k_star": k_star, "cluster_index": index, "t_agg_over_t_ff": t_agg,
            "q_first_peak": 0.5, "q_second_peak": second}


def test_findings_follow_the_measured_trends():
    damping = [point(0.0, 100, 0.9, math.nan, 0.1), point(0.1, 100, 0.4, 2.0, 0.1), point(0.3, 100, 0.05, 1.2, 0.1),
               point(0.5, 100, 0.01, 1.0)]
    stiffness = [point(0.1, 10, 0.8, 1.5), point(0.1, 100, 0.01, 0.9), point(0.1, 1e4, 0.6, 2.5)]
    lines = sweep.findings(damping, stiffness, 100, 0.1)
    assert all(line.endswith("| yes |") for line in lines[2:]), lines
    flat = [point(0.1, 10, 0.02, 1.0), point(0.1, 100, 0.01, 0.9), point(0.1, 1e4, 0.05, 2.5)]
    lines = sweep.findings(damping, flat, 100, 0.1)
    assert [line.rsplit("|", 2)[-2].strip() for line in lines[5:7]] == ["no", "no"]


def test_a_trend_over_two_points_is_not_decided_and_a_curve_that_stays_high_does_not_cross():
    """Two damping points give the rank correlation NaN, which must not read as "no", nor give the text "crosses 0.5
    between zeta none"."""
    lines = sweep.findings([point(0.1, 100, 0.9, 2.0), point(0.5, 100, 0.8, 1.0)], [], 100, 0.1)
    assert lines[2].endswith(f"| {sweep.TOO_FEW} |"), lines[2]
    assert "does not cross 0.5" in lines[3] and "none" not in lines[3]


def test_a_trend_over_one_point_is_not_decided():
    """One damping point decides neither the logistic fall (it gave "no") nor Q's peaks (it gave "yes")."""
    lines = sweep.findings([point(0.1, 100, 0.9, 2.0)], [point(0.1, 1e4, 0.6, 2.5)], 100, 0.1)
    assert lines[3].endswith("| not decided: needs 3 points or more |"), lines[3]
    assert lines[4].endswith("| not decided: needs 2 points or more |"), lines[4]
    assert lines[6].endswith("| not decided: needs 2 points or more |"), lines[6]


def test_findings_that_turn_on_runs_that_heated_up_are_not_decided():
    energy = "energy check: at t = 6.6 (1.77 t_ff, step 400) the total energy E = K + W + elastic = -38040 is 234762 above ..."
    base = {"cluster_index": 0.7, "largest_cluster_fraction": 0.3, "fractal_dimension": math.nan, "q_first_peak": 1.4,
            "q_first_peak_time": 2.9, "q_second_peak": 0.0, "t": [0], "q": [0], "t_agg_over_t_ff": 0.8}
    step = "time.dt = 0.0167 exceeds T_orb / 20 = 0.00248 ..."
    soft = sweep.median_point([dict(base, warnings=[step, energy]), dict(base, warnings=[step]), dict(base, warnings=[])])
    assert (soft["warned_runs"], soft["heated_runs"]) == (2, 1)
    damping = [point(0.0, 100, 0.9, math.nan, 0.1), point(0.1, 100, 0.4, 2.0, 0.1), point(0.3, 100, 0.05, 1.2, 0.1),
               point(0.5, 100, 0.01, 1.0)]
    stiffness = [dict(point(0.1, 10, 0.8, 1.5), heated_runs=1), point(0.1, 100, 0.01, 0.9), point(0.1, 1e4, 0.6, 2.5)]
    lines = sweep.findings(damping, stiffness, 100, 0.1)
    assert all(line.endswith("| yes |") for line in lines[2:5]), lines
    assert "0.800‡ (k* 10)" in lines[5] and lines[5].endswith("| not decided: rests on runs that heated up (‡) |")
    assert lines[6].endswith("| yes |")   # the stiff end did not heat up
    assert "1.50‡ (k* 10)" in lines[7] and "not decided" in lines[7]
    grid = [dict(p, zeta=z) for z in (0.0, 0.1) for p in stiffness]
    assert "not decided" in sweep.stiffness_shapes(grid, [0.0, 0.1], [10, 100, 1e4])
    grid = [dict(p, heated_runs=0) for p in grid]
    assert sweep.stiffness_shapes(grid, [0.0, 0.1], [10, 100, 1e4]).endswith("| yes |")


def test_a_small_sweep_runs_end_to_end_and_names_bad_input(grains_bin, tmp_path):
    small = ["--set", "particles.count=40", "--set", "time.duration=1.5", "--set", "analysis.every=20",
             "--set", "output.observables_every=50"]
    cmd = [sys.executable, str(ROOT / "runner/aggregation_sweep.py"), "--grains", grains_bin, "--out", str(tmp_path),
           "--damping", "0.1", "0.5", "--stiffness", "100", "1000", "--fixed-damping", "0.9", "--jobs", "2", *small]
    run = subprocess.run(cmd, capture_output=True, text=True)
    assert run.returncode == 0, run.stdout + run.stderr
    rows = list(csv.DictReader((tmp_path / "sweep.csv").open()))
    scene_k = float(rows[0]["k_star"])   # the damping sweep runs at the scene's k*
    assert [(r["sweep"], float(r["zeta"]), float(r["k_star"]), int(r["steps_per_contact"])) for r in rows] == [
        ("damping", 0.1, scene_k, 30), ("damping", 0.5, scene_k, 30), ("stiffness", 0.9, 100.0, 92),
        ("stiffness", 0.9, 1000.0, 92)]
    # k* = 100 at zeta = 0.9: 92 steps per contact of t_c = 0.360 (dt 3.92e-3, 5.9 times the scene's 6.67e-4),
    # so the analysis every 20 / 5.9 = 3 steps and the records every 50 / 5.9 = 9: as often in time as the scene's.
    assert (tmp_path / "z0p9-k100-n92a3o9-s1.h5").is_file() and not (tmp_path / "z0p9-k100-s1.h5").exists()
    assert [int(r["analysis_every"]) for r in rows] == [20, 20, 3, 20]   # k* = 1000: dt 1.8 times the scene's
    # The raised steps per contact keep k* = 100, zeta = 0.9 inside the damped-packing rule; its one warning is the
    # gravity step rule's: contacts this soft (capped force 10 against the 40 grains' pull 40) do not keep grains
    # apart, so the orbit is checked at the softened centre, and dt = 3.92e-3 is past T_orb / 20 = 2.48e-3.
    summary = (tmp_path / "summary.md").read_text()
    assert int(rows[0]["warned_runs"]) == 0 and int(rows[2]["warned_runs"]) == 1
    assert "zeta 0.9, k* 100: 1 of 1 run(s); time.dt = 0.00391702 exceeds T_orb / 20" in summary
    assert "damped contacts" not in summary
    assert "zeta 0.9 at 92" in summary
    for name in ("summary.md", "damping.png", "stiffness.png"):
        assert (tmp_path / name).stat().st_size > 100
    again = subprocess.run(cmd + ["--report"], capture_output=True, text=True)   # nothing rerun (the same --set)
    assert again.returncode == 0 and "finished" not in again.stdout
    # The values in another order, or given twice, are the same sweep: its verdicts read it from the weakest damping
    # ("--damping 0.2 0.1 0.01" must not reverse two verdicts).
    reordered = [a if a not in ("0.1", "0.5") else {"0.1": "0.5", "0.5": "0.1"}[a] for a in cmd] + ["--damping", "0.5", "0.1", "0.5"]
    report = subprocess.run(reordered + ["--report"], capture_output=True, text=True)
    assert report.returncode == 0, report.stderr
    assert "given more than once" in report.stdout
    assert (tmp_path / "summary.md").read_text() == summary
    # A report summarises what is complete, and says what is not (it refused to, naming three runs).
    (tmp_path / "z0p9-k100-n92a3o9-s1.h5").rename(tmp_path / "elsewhere.h5")
    partial = subprocess.run(cmd + ["--report"], capture_output=True, text=True)
    assert partial.returncode == 0, partial.stderr
    assert "1 of 2 run(s) are not complete" in partial.stdout and "z0p9-k100-n92a3o9-s1.h5" in partial.stdout
    rows = list(csv.DictReader((tmp_path / "sweep.csv").open()))
    assert [(r["sweep"], float(r["k_star"])) for r in rows][2:] == [("stiffness", 1000.0)]
    for args, message in ((["--damping", "1.0"], "--damping: 1.0"), (["--stiffness", "0"], "k* must be positive"),
                          (["--fixed-damping", "soft"], "--fixed-damping: 'soft'")):
        bad = subprocess.run([sys.executable, str(ROOT / "runner/aggregation_sweep.py"), "--grains", grains_bin,
                              "--out", str(tmp_path / "bad"), *args], capture_output=True, text=True)
        assert bad.returncode == 2 and message in bad.stderr, bad.stderr


def test_a_point_grains_refuses_stops_the_sweep_before_any_run(grains_bin, tmp_path):
    """Every point is resolved by grains first: a stiffness the scene refuses (k* = 1e-300: a contact so soft the
    run's free-fall times round to no step) stops the sweep before any run, not in its turn after the damping sweep
    has run."""
    out = tmp_path / "sweep"
    cmd = [sys.executable, str(ROOT / "runner/aggregation_sweep.py"), "--grains", grains_bin, "--out", str(out),
           "--damping", "0.1", "--stiffness", "100", "1e-300", "--set", "particles.count=40"]
    bad = subprocess.run(cmd, capture_output=True, text=True)
    assert bad.returncode == 2, bad.stdout + bad.stderr
    assert "grains refuses 1 of the sweep's points (nothing was run)" in bad.stderr
    assert "zeta 0.1, k* 1e-300:" in bad.stderr and "time.free_fall_times" in bad.stderr
    assert "damping sweep" not in bad.stdout and not out.exists()   # no run, and no empty folder left behind


def test_a_stiffness_option_without_values_runs_the_damping_sweep_alone(grains_bin, tmp_path):
    """`--stiffness` with no value leaves the stiffness sweep out (by default it runs after the damping one, six more
    runs: a user asking for two dampings would get eight). The help lists the defaults."""
    small = ["--set", "particles.count=30", "--set", "time.duration=0.5", "--set", "analysis.every=20",
             "--set", "output.observables_every=50"]
    tool = [sys.executable, str(ROOT / "runner/aggregation_sweep.py")]
    run = subprocess.run([*tool, "--grains", grains_bin, "--out", str(tmp_path), "--damping", "0.3", "0.5",
                          "--stiffness", "--jobs", "1", "--threads", "1", *small], capture_output=True, text=True)
    assert run.returncode == 0, run.stdout + run.stderr
    rows = list(csv.DictReader((tmp_path / "sweep.csv").open()))
    assert [(r["sweep"], float(r["zeta"])) for r in rows] == [("damping", 0.3), ("damping", 0.5)]
    assert len(list(tmp_path.glob("*.h5"))) == 2 and "stiffness sweep" not in run.stdout
    assert (tmp_path / "damping.png").is_file() and not (tmp_path / "stiffness.png").exists()
    assert "vs k*" not in (tmp_path / "summary.md").read_text()
    usage = subprocess.run([*tool, "--help"], capture_output=True, text=True).stdout
    assert " ".join(f"{k:g}" for k in sweep.STIFFNESS) in " ".join(usage.split())
    assert " ".join(map(str, sweep.DAMPING)) in " ".join(usage.split())


def test_a_map_or_a_fixed_damping_without_stiffnesses_is_refused(grains_bin, tmp_path):
    """`--stiffness` with no value leaves out the stiffness sweep, and with it every k* of the map: `--map` then ran
    the damping sweep, wrote no map and ended with status 0, and `--fixed-damping` was silently unused. Refused before
    any run, naming the option."""
    tool = [sys.executable, str(ROOT / "runner/aggregation_sweep.py"), "--grains", grains_bin, "--damping", "0.3",
            "--jobs", "1", "--threads", "1", "--set", "particles.count=30", "--set", "time.duration=0.5"]   # small, if run
    for option, named in ((["--map"], "--map"), (["--fixed-damping", "0.5"], "--fixed-damping 0.5")):
        out = tmp_path / option[0].strip("-")
        bad = subprocess.run([*tool, "--out", str(out), "--stiffness", *option], capture_output=True, text=True)
        assert bad.returncode == 2, bad.stdout + bad.stderr
        assert f"{named} " in bad.stderr and "--stiffness was given no value" in bad.stderr, bad.stderr
        assert not out.exists()   # refused before any run


def test_a_stiffness_that_names_its_runs_as_the_scene_k_star_does_is_that_point(grains_bin, tmp_path):
    """The scene's k* (6468.79) and --stiffness 6469 both name their runs k6469: the second is that point, not a run
    with other settings that stops the sweep."""
    small = ["--set", "particles.count=30", "--set", "time.duration=0.5", "--set", "analysis.every=20",
             "--set", "output.observables_every=50"]
    run = subprocess.run([sys.executable, str(ROOT / "runner/aggregation_sweep.py"), "--grains", grains_bin, "--out",
                          str(tmp_path), "--damping", "0.9", "--stiffness", "6469", "--fixed-damping", "0.9", "--jobs", "1",
                          "--threads", "1", *small], capture_output=True, text=True)
    assert run.returncode == 0, run.stdout + run.stderr
    assert "k* = 6469 names its runs as k* = 6468.79" in run.stdout
    rows = list(csv.DictReader((tmp_path / "sweep.csv").open()))
    assert len({r["k_star"] for r in rows}) == 1 and len(list(tmp_path.glob("*.h5"))) == 1


def test_runs_are_reused_only_with_the_settings_asked_for_now(grains_bin, tmp_path):
    """k* is converted with the grain's mass, size and G as the overrides set them (particles.mass = 2 halves
    the scene's k*, and every run's own k* is checked against the request). A complete run is taken as it is
    only if it ran the scene that would run now (its HDF5 file's parameters/scene.toml; the thread count
    aside): with another --set the sweep, and its --report, refuse in one message naming the setting."""
    small = ["--set", "particles.count=40", "--set", "time.duration=1.5", "--set", "analysis.every=20",
             "--set", "output.observables_every=50", "--set", "particles.mass=2"]
    cmd = [sys.executable, str(ROOT / "runner/aggregation_sweep.py"), "--grains", grains_bin, "--out", str(tmp_path),
           "--damping", "0.1", "--stiffness", "1000", "--fixed-damping", "0.1", "--jobs", "1", "--threads", "1", *small]
    run = subprocess.run(cmd, capture_output=True, text=True)
    assert run.returncode == 0, run.stdout + run.stderr
    table = (tmp_path / "sweep.csv").read_text()
    rows = list(csv.DictReader(table.splitlines()))
    # m = 2, R = 1/2, G = 1: m* = m / 2 = 1 and k_g = G m^2 / (4 R^3) = 8; the scene's e = 0.5, t_c = 0.02
    scene_k = sweep.scene_point({"contact": {"restitution": 0.5, "duration": 0.02}}, 1.0, 8.0)[1]
    assert float(rows[0]["k_star"]) == pytest.approx(scene_k, rel=1e-12) and scene_k == pytest.approx(3234.39, rel=1e-6)
    again = subprocess.run(cmd + ["--jobs", "2", "--threads", "2"], capture_output=True, text=True)
    assert again.returncode == 0 and "finished" not in again.stdout, again.stderr
    fewer = ["particles.count=30" if a == "particles.count=40" else a for a in cmd]   # a key given twice is refused
    for other in ([], ["--report"]):
        bad = subprocess.run(fewer + other, capture_output=True, text=True)
        assert bad.returncode == 2 and "Traceback" not in bad.stderr, bad.stderr
        assert "particles.count = 40 there, 30 now" in bad.stderr and "give another --out" in bad.stderr
    assert (tmp_path / "sweep.csv").read_text() == table


def test_a_folder_or_fifo_at_a_run_name_is_refused_not_deleted(grains_bin, tmp_path):
    """A run's file that is not complete was deleted before the run (now it is run again over: --overwrite): a FIFO
    at its name was deleted silently, and a folder ended the sweep in a traceback. The sweep refuses before any run, naming each path
    and what it holds; a sweep that meets one later (run_point) ends with the same message."""
    os.mkfifo(tmp_path / "z0p3-k6469-s1.h5")
    (tmp_path / "z0p5-k6469-s1.h5").mkdir()
    small = ["--set", "particles.count=30", "--set", "time.duration=0.5", "--set", "analysis.every=20",
             "--set", "output.observables_every=50"]
    cmd = [sys.executable, str(ROOT / "runner/aggregation_sweep.py"), "--grains", grains_bin, "--out", str(tmp_path),
           "--damping", "0.3", "0.5", "--stiffness", "--jobs", "1", "--threads", "1", *small]
    for report in ([], ["--report"]):
        bad = subprocess.run(cmd + report, capture_output=True, text=True, timeout=60)
        assert bad.returncode == 2 and "Traceback" not in bad.stderr, bad.stderr
        assert f"{tmp_path / 'z0p3-k6469-s1.h5'} is a FIFO (named pipe), not a run's HDF5 file: move it" in bad.stderr
        assert f"{tmp_path / 'z0p5-k6469-s1.h5'} is a folder, not a run's HDF5 file" in bad.stderr, bad.stderr
    assert (tmp_path / "z0p3-k6469-s1.h5").is_fifo() and (tmp_path / "z0p5-k6469-s1.h5").is_dir()
    assert sorted(f.name for f in tmp_path.iterdir()) == ["z0p3-k6469-s1.h5", "z0p5-k6469-s1.h5"]   # nothing ran
    for zeta, kind in ((0.3, "a FIFO (named pipe)"), (0.5, "a folder")):   # no grains to run: it must not get there
        with pytest.raises(sweep.child_runs.RunFailed, match=re.escape(f"{sweep.run_name(zeta, 6469, 1)}.h5 is {kind}, ")):
            sweep.run_point(tmp_path / "no-grains", zeta, 6469.0, 1, 0.5, 1.0, 1, [], tmp_path)
    assert (tmp_path / "z0p3-k6469-s1.h5").is_fifo() and (tmp_path / "z0p5-k6469-s1.h5").is_dir()


def test_a_run_left_interrupted_is_run_again_over_its_file(grains_bin, tmp_path):
    """The sweep runs an interrupted point again from its start. Its file holds a checkpoint, which grains refuses
    to write over unless told so: the sweep says so (--overwrite), and the point ends complete."""
    from interrupt import interrupted
    h5 = tmp_path / "z0p3-k6469-s1.h5"
    code, _, err = interrupted([grains_bin, "run", ROOT / "models/gas.toml", "--set", "time.steps=700000",
                                "--set", "run.threads=1", "--out", h5, "--quiet"], h5, 0.3)
    assert code == 130, err
    plain = subprocess.run([grains_bin, "run", str(ROOT / "models/gas.toml"), "--out", str(h5), "--quiet"],
                           capture_output=True, text=True)
    assert plain.returncode == 1 and "holds a run interrupted at step" in plain.stderr, plain.stderr
    small = ["--set", "particles.count=30", "--set", "time.duration=0.5", "--set", "analysis.every=20",
             "--set", "output.observables_every=50"]
    cmd = [sys.executable, str(ROOT / "runner/aggregation_sweep.py"), "--grains", grains_bin, "--out", str(tmp_path),
           "--damping", "0.3", "--stiffness", "--jobs", "1", "--threads", "1", *small]
    r = subprocess.run(cmd, capture_output=True, text=True, timeout=300)
    assert r.returncode == 0 and "finished zeta 0.3" in r.stdout, r.stdout + r.stderr
    ran = sweep.run_files.stored(h5)   # the sweep's point, not the gas left there
    assert sweep.run_files.ended(h5) and ran["scene"]["name"] == "aggregation" and ran["particles"]["count"] == 30


def test_rank_correlation_gives_ties_their_mean_rank():
    """Tied values (a level t_agg at several k*) took arbitrary distinct ranks: scipy's spearmanr is the reference."""
    from scipy.stats import spearmanr
    x, y = [1, 2, 3, 4, 5, 6], [0.9, 0.9, 0.9, 1.2, 1.1, 1.5]
    assert sweep.spearman(x, y) == pytest.approx(spearmanr(x, y)[0], rel=1e-12)
    assert math.isnan(sweep.spearman(x, [1.0] * 6)) and math.isnan(sweep.spearman([1, 2], [3, 4]))


def test_an_intermediate_k_star_over_two_points_is_not_decided_and_nothing_reads_nan():
    """A review's run of two k* and one damping: "no" for an intermediate minimum that two points cannot show,
    "rank correlation with zeta +nan over 1 points" and "largest rise between neighbours -0.225"."""
    damping = [point(0.1, 100, 0.9, 2.0), point(0.5, 100, 0.2, 1.0)]
    lines = sweep.findings(damping[:1], [point(0.1, 10, 0.8, 1.5), point(0.1, 100, 0.01, 0.9)], 100, 0.1)
    text = "\n".join(lines)
    assert "nan" not in text and "+nan" not in text, text
    intermediate = [line.rsplit("|", 2)[-2].strip() for line in lines[2:] if "intermediate" in line.split("|")[1]]
    assert intermediate == ["not decided: an intermediate k* needs 3 points or more"] * 2, lines
    assert "no rise between neighbours" in "\n".join(sweep.findings(damping, [], 100, 0.1))


def sweep_point(zeta, k_star, t_agg, cluster_index, fractal_dimension, heated_runs=0):
    return {"zeta": zeta, "k_star": k_star, "t_agg_over_t_ff": t_agg, "cluster_index": cluster_index,
            "fractal_dimension": fractal_dimension, "heated_runs": heated_runs, "t": np.linspace(0, 3, 4),
            "q": np.array([0, 0.4, 0.01, 1e-4])}


def test_damping_plot_marks_the_points_that_never_aggregated(tmp_path):
    """The weak dampings, whose clouds never aggregate, have no t_agg (NaN): the line left them out without a word,
    and its panel's axis started at the first damping that aggregated."""
    pytest.importorskip("matplotlib")
    points = [sweep_point(z, 6469, t, c, 3.0) for z, t, c in ((0, math.nan, 0.94), (0.01, math.nan, 0.56),
                                                              (0.05, 1.5, 0.01), (0.5, 0.9, 0.001))]
    fig = sweep.plot_sweep(points, "zeta", "damping", tmp_path / "damping.png")
    t_agg = fig.axes[1]
    never = [line for line in t_agg.lines if line.get_label().startswith("never aggregated")]
    assert len(never) == 1 and list(never[0].get_xdata()) == [0, 0.01]
    assert t_agg.get_xlim() == fig.axes[0].get_xlim()   # the same range as the N_c / N panel, zeta = 0 in it


def test_map_writes_a_fractal_dimension_beyond_its_colour_scale(tmp_path):
    """D_f of a cluster sunk into the softened core came out 0.35 (docs/aggregation-sweep, zeta 0.02, k* 100): the map's
    colour scale, clipped at 1, drew it as D_f = 1."""
    pytest.importorskip("matplotlib")
    points = [sweep_point(z, k, 1.0, 0.001, d, heated) for z, k, d, heated in
              ((0.02, 100, 0.35, 0), (0.02, 1000, 2.81, 0), (0.1, 100, 2.08, 1), (0.1, 1000, 0.62, 1))]
    fig = sweep.plot_map(points, [0.02, 0.1], [100, 1000], tmp_path / "map.png")
    texts = sorted((t.get_text(), t.get_position()) for t in fig.axes[0].texts)
    assert texts == [("0.35", (0, 0.22)), ("0.62", (1, 1.22)), ("‡", (0, 1)), ("‡", (1, 1 - 0.22))]
    assert fig.axes[0].images[0].colorbar.extend == "both"


def test_map_leaves_a_cell_without_a_fractal_dimension_blank(tmp_path):
    """A point whose runs formed no cluster has no D_f (NaN, "blank: none" on the colour bar): the map wrote "nan" in
    it, white on the white cell, and drew its dagger below the centre as if beside a number (docs/aggregation-sweep,
    k* 10 at zeta 0.01 to 0.1)."""
    pytest.importorskip("matplotlib")
    points = [sweep_point(z, k, 1.0, 0.001, d, heated) for z, k, d, heated in
              ((0.02, 100, math.nan, 1), (0.02, 1000, math.nan, 0), (0.1, 100, 0.35, 1), (0.1, 1000, 2.9, 0))]
    fig = sweep.plot_map(points, [0.02, 0.1], [100, 1000], tmp_path / "map.png")
    texts = sorted((t.get_text(), t.get_position()) for t in fig.axes[0].texts)
    assert texts == [("0.35", (0, 1.22)), ("‡", (0, 0)), ("‡", (0, 1 - 0.22))]
