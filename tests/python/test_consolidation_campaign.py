"""The campaign's reading of stage tables and its verdicts against the paper (runner/consolidation_campaign.py)."""
import csv
import math
import os
import pathlib
import re
import subprocess
import sys
import time

import h5py
import numpy as np
import pytest

from conftest import ROOT
from h5text import text
from interrupt import interrupted

sys.path.insert(0, str(ROOT / "runner"))
import consolidation_campaign as campaign  # noqa: E402
import child_runs  # noqa: E402
import run_files  # noqa: E402
import run_reuse  # noqa: E402


def write_table(path, rows):
    fields = ["stage", "phase", "branch", "P_star", "phi", "reached", "coordination"]
    with path.open("w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=fields)
        w.writeheader()
        for k, (phase, branch, p, phi, reached, z) in enumerate(rows):
            w.writerow(dict(zip(fields, (k, phase, branch, p, phi, reached, z))))


def synthetic_curve(lam=0.3, phi0=0.5, p0=0.03, phi_max=0.78, alpha=1.0):
    from consolidation_fit import inverse_phi_crossover
    p = 0.01 * 10 ** (np.arange(0, 25) / 8)
    inv = np.where(p < p0, 1 / phi0, inverse_phi_crossover(np.maximum(p, p0), 1 / phi0, lam, phi_max, alpha, p0))
    return p, 1 / inv


def test_first_loading_stage_is_reported_even_when_not_in_equilibrium(tmp_path):
    p, phi = synthetic_curve()
    rows = [("aggregation", "preparation", 0.0, 0.36, 1, 3.1), ("equilibrate", "preparation", 0.0, 0.35, 0, 3.1),
            ("equilibrate", "loading", p[0], 0.61, 0, 3.2)]   # P* = 0.01 missed equilibrium
    rows += [("loading", "loading", x, y, 1, 3.3) for x, y in zip(p[1:], phi[1:])]
    rows[10] = ("loading", "loading", p[8], 0.70, 0, 3.3)   # and a regime II stage far off its curve
    write_table(tmp_path / "t.csv", rows)
    s = campaign.summarise(tmp_path / "t.csv")
    # The P* = 0.01 row, not the next reached one, and flagged as missed; the aggregation is not counted.
    assert s["phi_0.01"] == 0.61 and s["z_0.01"] == 3.2 and not s["first_reached"]
    assert s["unreached"] == 3
    # The fits use the reached loading stages only and recover the synthetic curve's parameters (with the
    # missed rows lambda would be 0.68).
    assert abs(s["lambda"] - 0.3) < 1e-5 and abs(s["phi_max"] - 0.78) < 1e-6
    # No HDF5 file beside the table: no fractal dimension, and the summary says so.
    assert math.isnan(s["d_F_0"]) and math.isnan(s["d_F_0.01"])
    assert any("| d_F_0 | no sample |" in l for l in campaign.table_lines("consolidation", [s]))


def test_verdicts_use_twice_the_paper_bar(tmp_path):
    value, bar = campaign.PAPER["consolidation"]["phi_0.01"]
    base = {"z_0.01": 3.1, "lambda": math.nan, "phi_max": math.nan, "first_reached": True, "unreached": 0,
            "p": np.array([]), "phi": np.array([]), "all_p": np.array([]), "all_reached": np.array([], bool)}
    inside = [dict(base, **{"phi_0.01": value + 1.9 * bar}), dict(base, **{"phi_0.01": value + 1.9 * bar})]
    outside = [dict(base, **{"phi_0.01": value + 2.1 * bar}), dict(base, **{"phi_0.01": value + 2.1 * bar})]
    line = next(l for l in campaign.table_lines("consolidation", inside) if "| phi_0.01 |" in l)
    assert line.endswith("| yes |")
    line = next(l for l in campaign.table_lines("consolidation", outside) if "| phi_0.01 |" in l)
    assert line.endswith("| NO |")
    # A quantity no sample could fit is said so, not averaged as NaN.
    assert any("| lambda | no sample |" in l for l in campaign.table_lines("consolidation", inside))


def test_the_mean_curve_over_the_samples_is_fitted_as_the_paper_fits_its_averaged_data(tmp_path):
    """Three samples scattered about one curve (a step up in one, down in another, as collapses make them):
    the mean at each target P* is the curve, whose fit gives its lambda; a stage in equilibrium in fewer
    than half of the samples is left out, and so is each sample's stage that missed equilibrium."""
    p, phi = synthetic_curve(lam=0.3)
    offsets = (np.where(p > 0.1, 0.02, 0.0), np.where(p > 0.1, -0.02, 0.0), np.zeros_like(p))
    results = []
    for k, off in enumerate(offsets):
        rows = [("loading", "loading", x, y + d, 1, 3.1) for x, y, d in zip(p, phi, off)]
        if k < 2:   # the last stage is in equilibrium in the third sample only
            rows[-1] = rows[-1][:4] + (0, 3.1)
        if k == 0:   # and the first sample missed a stage, far off the curve
            rows[5] = ("loading", "loading", p[5], 0.70, 0, 3.1)
        write_table(tmp_path / f"s{k}.csv", rows)
        results.append(campaign.summarise(tmp_path / f"s{k}.csv"))
    mean_p, mean_phi, counts = campaign.mean_curve(results)
    assert len(mean_p) == len(p) - 1 and counts[5] == 2 and max(counts) == 3
    assert np.allclose(mean_phi, phi[:-1], atol=1e-12) and np.allclose(mean_p, p[:-1])
    lines = campaign.mean_curve_lines("consolidation-rr", results)
    fitted = float(lines[0].split("| lambda of the mean curve | ")[1].split(" ±")[0])
    assert abs(fitted - 0.3) < 1e-4 and "24 stages (" in lines[0] and "2–3 samples each" in lines[0]   # printed to 4 decimals
    assert lines[0].endswith("| NO |") and lines[1].endswith("| yes |")   # 0.3 against 0.194 ± 0.004; 0.78
    assert "regime II line alone" in lines[2]


def test_the_regime_two_line_alone_is_fitted_to_the_mean_curve(tmp_path):
    """A plateau at Phi0 to P0* = 0.03, then 1/Phi = 1/Phi0 - lambda ln(P*/P0*): the line's lambda is the curve's,
    whatever the crossover form makes of the stages above P* = 0.1 (here a sudden rise to 0.78 that no line has)."""
    p = 0.01 * 10 ** (np.arange(0, 25) / 8)
    inv = 1 / 0.5 - 0.35 * np.log(np.maximum(p, 0.03) / 0.03)
    phi = np.where(p <= 0.1 * (1 + 1e-12), 1 / inv, 0.78)
    results = []
    for k in range(3):
        write_table(tmp_path / f"s{k}.csv", [("loading", "loading", x, y, 1, 3.1) for x, y in zip(p, phi)])
        results.append(campaign.summarise(tmp_path / f"s{k}.csv"))
    line = campaign.mean_curve_lines("consolidation", results)[-1]
    assert "regime II line alone" in line and line.endswith("| yes |"), line   # 0.35 against 0.3275 ± 0.019
    assert "0.3275 ± 0.019 (the paper's fitted curve's line)" in line, line
    assert abs(float(line.split(" | ")[2].split(" ±")[0]) - 0.35) < 1e-4 and "P0* 0.03" in line, line


def test_report_reads_unfinished_samples_and_skips_those_still_aggregating(tmp_path):
    p, phi = synthetic_curve()
    write_table(tmp_path / "consolidation-seed1.partial.csv",
                [("aggregation", "preparation", 0.0, 0.36, 1, 3.1), ("equilibrate", "loading", p[0], 0.48, 1, 3.1)])
    write_table(tmp_path / "consolidation-seed2.partial.csv", [("aggregation", "preparation", 0.0, 0.36, 0, 3.0)])
    path, partial = campaign.existing_table(tmp_path, "consolidation", 1)
    assert partial and path.name == "consolidation-seed1.partial.csv"
    assert campaign.existing_table(tmp_path, "consolidation", 3) == (None, False)
    assert campaign.summarise(tmp_path / "consolidation-seed2.partial.csv") is None
    first = campaign.summarise(path)
    assert first["phi_0.01"] == 0.48 and first["first_reached"]
    first["partial"] = True
    assert any("| samples whose programme had not finished | 1 of 1 |" in l
               for l in campaign.table_lines("consolidation", [first]))


def test_fractal_dimensions_come_from_the_snapshots_beside_the_table(tmp_path):
    """d_F at P* = 0 and 0.01 are the density-correlation fits of the stages file's frames at those
    targets (an unfinished sample's table, SCENE-seedN.partial.csv, pairs with SCENE-seedN.h5)."""
    from test_density_correlations import write_stages
    import density_correlations as dc
    rng = np.random.default_rng(6)
    edge = np.array([150.0, 150.0])

    def random_walks():   # 8 chains of 300 touching unit disks at random angles: a finite d_F
        angles = rng.uniform(0, 2 * math.pi, (8, 300))
        steps = np.stack([np.cos(angles), np.sin(angles)], axis=2)
        return (rng.uniform(0, 150.0, (8, 1, 2)) + np.cumsum(steps, axis=1)).reshape(-1, 2)

    chains = [random_walks() for _ in range(4)]
    frames = [(c, np.full(len(c), 0.5), edge, p) for c, p in zip(chains, (0.02, 1e-4, 2e-8, 0.0101))]
    write_stages(tmp_path / "consolidation-seed1.h5", frames)
    found = campaign.fractal_dimensions(tmp_path / "consolidation-seed1.partial.csv")
    for key, frame in (("d_F_0", 2), ("d_F_0.01", 3)):
        expected = dc.analyse([frames[frame][:3]])["d_F"]
        assert np.isfinite(expected) and found[key] == expected


def test_plot_puts_a_stage_at_its_target_pressure():
    """A stage that ended short of its target (P* = 0.0162 measured for 0.01) is drawn at 0.01; the
    aggregation (no target) and tables without the column use the measured P*."""
    assert campaign.target_pressure({"target_pressure": "0.01", "P_star": "0.0162"}) == 0.01
    assert campaign.target_pressure({"target_pressure": "nan", "P_star": "0.0011"}) == 0.0011
    assert campaign.target_pressure({"P_star": "0.02"}) == 0.02


def test_report_with_no_table_is_an_error(tmp_path):
    r = subprocess.run([sys.executable, str(ROOT / "runner" / "consolidation_campaign.py"), "--report", "--out",
                        str(tmp_path)], capture_output=True, text=True)
    assert r.returncode == 2 and "--report: no stage table" in r.stderr
    assert not (tmp_path / "summary.md").exists()


def test_an_interrupted_sample_continues_from_its_last_finished_stage(grains_bin, tmp_path):
    """A sample left with its partial table and output (killed during its last stage) is resumed with
    `grains resume`, not run again, and ends with the table of an unbroken run."""
    import h5py
    scene = ROOT / "models/consolidation-type1.toml"
    small = ["particles.count=100", "programme.top_pressure=0.1", "programme.stage_budget=20000"]
    whole = campaign.consolidate(grains_bin, scene, small, tmp_path / "whole", "whole")
    # The finished sample's file names its final table (it named the partial one, renamed at the end), so the
    # tools reading the file find it.
    from consolidation_fit import read_stages, recorded_table
    assert recorded_table(whole.with_suffix(".h5")) == whole
    assert read_stages(whole.with_suffix(".h5"))[1].tolist() == read_stages(whole)[1].tolist()
    # A finished sample whose table was not renamed (the tool stopped just then) is not run again.
    log = whole.with_suffix(".log").read_text()
    whole.rename(whole.with_suffix(".partial.csv"))
    assert campaign.consolidate(grains_bin, scene, small, tmp_path / "whole", "whole") == whole
    assert whole.exists() and whole.with_suffix(".log").read_text() == log
    stem = tmp_path / "sample"
    cmd = [grains_bin, "consolidate", str(scene), "--table", str(stem) + ".partial.csv", "--out", str(stem) + ".h5"]
    assert subprocess.run(cmd + [a for o in small for a in ("--set", o)], capture_output=True).returncode == 0
    rows = stem.with_suffix(".partial.csv").read_text().splitlines()
    stem.with_suffix(".partial.csv").write_text("\n".join(rows[:-1]) + "\n")
    with h5py.File(stem.with_suffix(".h5"), "r+") as f:
        del f["grains"].attrs["status"]
    # Resumed in a copy of its folder: the table it goes on writing is the copy's.
    import shutil
    copy = tmp_path / "copy"
    copy.mkdir()
    for suffix in (".partial.csv", ".h5"):
        shutil.copy(stem.with_suffix(suffix), copy / ("sample" + suffix))
    table = campaign.consolidate(grains_bin, scene, small, copy / "sample", "sample")
    assert table == copy / "sample.csv" and not (copy / "sample.partial.csv").exists()
    assert recorded_table(copy / "sample.h5") == table
    assert table.read_text() == whole.read_text()
    assert "resuming" in (copy / "sample.log").read_text()
    assert stem.with_suffix(".partial.csv").read_text().count("\n") == len(rows) - 1   # the original untouched
    # With other settings than those it was started with, the sample runs again rather than resuming.
    other = small[:-1] + ["programme.stage_budget=10000"]
    table = campaign.consolidate(grains_bin, scene, other, stem, "sample")
    assert "resuming" not in stem.with_suffix(".log").read_text() and table.read_text() != whole.read_text()
    # A finished sample is not taken as one run with other settings, nor run again over: refused, naming them.
    with pytest.raises(run_reuse.Stale, match="programme.stage_budget = 20000 there, 10000 now"):
        campaign.consolidate(grains_bin, scene, other, tmp_path / "whole", "whole")
    assert campaign.consolidate(grains_bin, scene, small + ["run.threads=2"], tmp_path / "whole", "whole") == whole


def test_threads_per_sample_follow_the_engines_automatic_choice_within_the_cores(grains_bin):
    # The engine's rule, as its scene reference states it, is the one the campaign copies.
    reference = subprocess.run([str(grains_bin), "scene-reference"], capture_output=True, text=True, check=True).stdout
    assert f"at most one thread per {campaign.PARTICLES_PER_THREAD} particles" in reference
    # 1400 disks: one thread even when one sample has both cores (two threads lose there: README).
    assert campaign.default_threads(1400, jobs=1, cores=2) == 1
    assert campaign.default_threads(1400, jobs=2, cores=2) == 1
    # Larger samples take more threads, never more than their share of the cores, and always one.
    assert campaign.default_threads(5600, jobs=1, cores=2) == 2
    assert campaign.default_threads(5600, jobs=2, cores=2) == 1
    assert campaign.default_threads(40000, jobs=2, cores=8) == 4
    assert campaign.default_threads(40000, jobs=16, cores=8) == 1


def test_the_summary_says_which_samples_and_overrides_it_measured():
    """A summary read later must say what protocol produced it: the seeds, the disks and the --set overrides."""
    import argparse
    args = argparse.Namespace(first_seed=4, samples=3, count=1400, set=["programme.first_compression_time=100"])
    line = campaign.provenance(args, ["consolidation", "consolidation-rr"])
    assert line.startswith("consolidation, consolidation-rr: seeds 4–6, 1400 disks;")
    assert "`--set programme.first_compression_time=100`" in line
    assert campaign.provenance(argparse.Namespace(first_seed=1, samples=1, count=300, set=[]), ["type1"]).startswith(
        "type1: seeds 1–1, 300 disks; scene overrides: none.")


def test_a_campaign_stopped_by_ctrl_c_resumes_and_refuses_samples_of_other_settings(grains_bin, tmp_path):
    """Ctrl-C (to the campaign and its runs) ends it with status 130 and says that the same command resumes,
    which it does. A finished sample is taken only with the settings it ran (its HDF5 file's scene): with another
    --count or --set the campaign, and its --report, refuse in one message naming the setting, rather than
    summarise the old sample under the new settings; another thread count changes nothing."""
    script = ROOT / "runner" / "consolidation_campaign.py"
    cmd = [sys.executable, script, "--samples", "1", "--count", "80", "--scene", "consolidation", "--jobs", "1",
           "--threads", "1", "--grains", grains_bin, "--out", tmp_path, "--set", "programme.stage_budget=50000",
           "--set", "programme.aggregation_budget=300000", "--set", "programme.top_pressure=0.1"]
    code, out, err = interrupted(cmd, tmp_path / "consolidation-seed1.h5", after=0.5, group=True)
    assert code == 130 and "interrupted; run the same command again to resume" in err and "Traceback" not in err, err
    assert (tmp_path / "consolidation-seed1.partial.csv").exists() and not (tmp_path / "consolidation-seed1.csv").exists()
    again = subprocess.run([str(c) for c in cmd], capture_output=True, text=True)
    assert again.returncode == 0 and "finished consolidation seed 1 (resumed)" in again.stdout, again.stderr
    summary = (tmp_path / "summary.md").read_text()
    assert summary.startswith("consolidation: seeds 1–1, 80 disks;")
    assert f"wrote {tmp_path / 'first-compression.png'}" in again.stdout   # from the resumed sample's trace
    for other, named in ((["--count", "60"], "particles.count = 80 there, 60 now"),
                         (["--count", "60", "--report"], "particles.count = 80 there, 60 now"),
                         (["--set", "programme.check_every=1234", "--report"], ", 1234 now")):
        r = subprocess.run([str(c) for c in cmd + other], capture_output=True, text=True)
        assert r.returncode == 2 and "Traceback" not in r.stderr, r.stderr
        assert "consolidation-seed1.csv: " in r.stderr and named in r.stderr and "give another --out" in r.stderr
    assert (tmp_path / "summary.md").read_text() == summary
    r = subprocess.run([str(c) for c in cmd + ["--threads", "2", "--jobs", "2", "--report"]], capture_output=True, text=True)
    assert r.returncode == 0 and (tmp_path / "summary.md").read_text() == summary, r.stderr


def grains_processes_writing_in(folder):
    """The processes whose command line names a file in `folder` (grains runs a tool started there)."""
    found = []
    for entry in pathlib.Path("/proc").iterdir():
        try:
            words = (entry / "cmdline").read_bytes().split(b"\0")
        except OSError:
            continue
        if any(w.startswith(str(folder).encode()) for w in words) and words[0].endswith(b"grains"):
            found.append(entry.name)
    return found


@pytest.mark.parametrize("tool", ["consolidation_campaign.py", "aggregation_sweep.py"])
def test_sigterm_to_a_tool_alone_stops_its_runs_as_ctrl_c_does(grains_bin, tmp_path, tool):
    """`kill PID` of the tool (not of its process group) must not end it silently with its grains runs going on
    alone: they get SIGTERM, stop with a checkpoint, and the tool says how to resume."""
    if tool == "consolidation_campaign.py":
        args = ["--samples", "1", "--count", "80", "--scene", "consolidation", "--jobs", "1", "--threads", "1",
                "--set", "programme.stage_budget=50000", "--set", "programme.aggregation_budget=300000"]
    else:
        args = ["--damping", "0.02", "--stiffness", "1000", "--set", "particles.count=2000"]
    tool_run = subprocess.Popen([sys.executable, str(ROOT / "runner" / tool), *args, "--grains", str(grains_bin),
                                 "--out", str(tmp_path)], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    deadline = time.monotonic() + 60
    while not list(tmp_path.glob("*.h5")) and time.monotonic() < deadline and tool_run.poll() is None:
        time.sleep(0.05)
    time.sleep(0.5)
    assert tool_run.poll() is None and grains_processes_writing_in(tmp_path), tool_run.communicate()
    tool_run.terminate()
    _, err = tool_run.communicate(timeout=60)
    assert tool_run.returncode == 130 and "interrupted; run the same command again" in err and "Traceback" not in err, err
    assert not grains_processes_writing_in(tmp_path)
    with h5py.File(next(tmp_path.glob("*.h5"))) as f:
        assert text(f["grains"].attrs["status"]).startswith("interrupted")


def test_initial_states_refuse_runs_of_other_settings(grains_bin, tmp_path):
    """runner/initial_states.py shares the campaign's check of a finished run's scene."""
    cmd = [sys.executable, str(ROOT / "runner" / "initial_states.py"), "--samples", "1", "--count", "60", "--state",
           "type1", "--jobs", "1", "--grains", grains_bin, "--out", str(tmp_path), "--set", "programme.stage_budget=20000"]
    assert subprocess.run(cmd, capture_output=True).returncode == 0
    summary = (tmp_path / "summary.md").read_text()
    for other in (["--count", "50"], ["--count", "50", "--report"]):
        r = subprocess.run(cmd + other, capture_output=True, text=True)
        assert r.returncode == 2 and "type1-seed1.csv: particles.count = 60 there, 50 now" in r.stderr, r.stderr
    assert (tmp_path / "summary.md").read_text() == summary
    # --report over two seeds, one of them never run: the one there is summarised, the other named (it was refused).
    r = subprocess.run([str(c) for c in cmd + ["--samples", "2", "--report"]], capture_output=True, text=True)
    assert r.returncode == 0 and "type1 seed 2: no table in" in r.stdout, r.stdout + r.stderr
    assert "| type1 |" in (tmp_path / "summary.md").read_text() and "(1) |" in (tmp_path / "summary.md").read_text()


@pytest.mark.parametrize("tool, key", [("consolidation_campaign.py", "particles.seed"), ("consolidation_campaign.py", "particles.count"),
                                       ("initial_states.py", "programme.load"), ("aggregation_sweep.py", "contact.restitution")])
def test_a_set_of_a_key_the_tool_sets_per_run_is_refused(grains_bin, tmp_path, tool, key):
    """The tools' own per-run settings came first and a --set of the same key silently won: every sample of a
    campaign ran the one seed, and its summary gave a spread of 0 as if they were independent."""
    r = subprocess.run([sys.executable, str(ROOT / "runner" / tool), "--set", f"{key}=7", "--grains", str(grains_bin),
                        "--out", str(tmp_path / "out")], capture_output=True, text=True)
    assert r.returncode == 2, r.stderr
    assert f"--set {key}=7: {key} is set by this tool for each run" in r.stderr
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize("tool", ["consolidation_campaign.py", "initial_states.py", "aggregation_sweep.py"])
def test_a_set_the_engine_refuses_leaves_no_out_folder(grains_bin, tmp_path, tool):
    """The campaign tools made --out before the engine had checked the scenes with their overrides."""
    r = subprocess.run([sys.executable, str(ROOT / "runner" / tool), "--set", "bogus.key=1", "--grains", str(grains_bin),
                        "--out", str(tmp_path / "out")], capture_output=True, text=True)
    assert r.returncode == 2 and "unknown key 'bogus.key'" in r.stderr, r.stderr
    assert not (tmp_path / "out").exists()


def test_a_sample_that_fails_ends_the_campaign_with_one_line_naming_its_log(grains_bin, tmp_path):
    """A run that grains ends with an error (8 disks pass the scene checks but cannot be prepared) ends the campaign
    with one line naming its log, not a Python traceback."""
    r = subprocess.run([sys.executable, str(ROOT / "runner/consolidation_campaign.py"), "--samples", "1", "--count", "8",
                        "--scene", "consolidation", "--set", "programme.stage_budget=5000", "--set",
                        "programme.aggregation_budget=20000", "--grains", str(grains_bin), "--out", str(tmp_path)],
                       capture_output=True, text=True)
    assert r.returncode == 1 and "Traceback" not in r.stderr, r.stderr
    assert f"consolidation seed 1: grains consolidate exited with 1; see {tmp_path}/consolidation-seed1.log" in r.stderr


def test_the_spread_over_resampled_samples_shows_what_the_mean_curves_fit_error_leaves_out(tmp_path):
    """Samples on two different curves (lambda 0.2 and 0.4): their mean curve is smooth, so the fit's own error
    is small, but which samples a campaign happens to draw moves the fitted lambda by far more, and the
    resampled spread shows it. Identical samples have no spread."""
    def results_of(lams):
        out = []
        for k, lam in enumerate(lams):
            p, phi = synthetic_curve(lam=lam)
            write_table(tmp_path / f"r{k}.csv", [("loading", "loading", x, y, 1, 3.1) for x, y in zip(p, phi)])
            out.append(campaign.summarise(tmp_path / f"r{k}.csv"))
        return out
    mixed = results_of([0.2, 0.4, 0.2, 0.4])
    fit = campaign.fit_loading(*campaign.mean_curve(mixed)[:2])
    spread, converged = campaign.resampled_spread(mixed, 6)
    assert converged >= 5 and spread["lambda"] > 3 * fit["lambda_err"] and spread["lambda"] > 0.02
    line = campaign.mean_curve_lines("consolidation-rr", mixed, 6)[0]
    assert f"± {spread['lambda']:.4f} (samples, {converged} resamples)" in line
    same, _ = campaign.resampled_spread(results_of([0.3, 0.3]), 2)
    assert same["lambda"] == 0.0


def test_a_sample_whose_fit_has_no_plateau_below_phimax_is_left_out_of_the_mean():
    """Seed 11 without rolling resistance (the ten-sample campaign in docs/): the crossover form reaches its stages
    only with Phi0 above Phimax (Phi0 = 4e14 at a bound of 1/Phi0 >= 0, P1* below P0*), and its lambda of 3.5 +- 51
    would enter the per-sample mean. Such a fit is refused: the sample gives no lambda."""
    table = ROOT / "docs" / "campaign-1400-10-samples-14e3020" / "consolidation-seed11.csv"
    s = campaign.summarise(table)
    assert math.isnan(s["lambda"]) and math.isnan(s["phi_max"])
    neighbour = campaign.summarise(table.with_name("consolidation-seed10.csv"))
    assert 1.5 < neighbour["lambda"] < 2.5   # a steep but proper fit stays (1.93)


def campaign_sample(p, phi, reached):
    reached = np.asarray(reached, bool)
    return {"all_p": p, "all_phi": phi, "all_reached": reached, "p": p[reached], "phi": phi[reached]}


def test_plot_draws_the_papers_fitted_curve_and_no_mean_where_there_is_none(tmp_path):
    """The plot marked the paper at P* = 0.01 only: where our curves part from its (the no-rolling samples' loading
    rises too fast) took the tables to see. A campaign with no stage in equilibrium listed a mean curve it did not
    draw."""
    pytest.importorskip("matplotlib")
    p, phi = synthetic_curve()
    fig = campaign.plot({"consolidation": [campaign_sample(p, phi, p > 0.02), campaign_sample(p, phi - 0.01, p > 0.02)],
                         "consolidation-rr": [campaign_sample(p, phi, p < 0), campaign_sample(p, phi, p < 0)]},
                        tmp_path / "campaign.png")
    lines = {line.get_label(): line for line in fig.axes[0].lines}
    paper = lines["paper consolidation: its fit, λ = 0.349, Φmax = 0.7808"]
    x, y = paper.get_xdata(), paper.get_ydata()
    assert y[0] == pytest.approx(0.469) and x[0] == pytest.approx(0.01)   # the plateau Phi0 below P0*
    # at the paper's P1* = 0.2718 its form gives Phi = 0.686508 (tests/python/test_consolidation_fit.py); the
    # 200-point curve, read between its points, within 1e-3 of it
    assert np.interp(math.log(0.271832), np.log(x), y) == pytest.approx(0.686508, abs=1e-3)
    assert "paper consolidation-rr: its fit, λ = 0.194, Φmax = 0.7745" in lines
    assert "consolidation: mean over the samples" in lines
    assert "consolidation-rr: mean over the samples" not in lines   # no stage of it in equilibrium


def test_report_beside_a_running_campaign_reads_the_sample_it_is_writing(grains_bin, tmp_path):
    """--report while the campaign still runs: HDF5 locks the file a grains run writes, and the check of the
    sample's settings (its file's scene) took the locked file for one that holds no scene, so the report refused
    the running sample as "run with other settings". The scene, written when the file is made, is now read without
    the lock, and the report summarises the samples as they stand."""
    args = ["--samples", "1", "--count", "80", "--scene", "consolidation", "--jobs", "1", "--threads", "1",
            "--set", "programme.stage_budget=50000000", "--set", "programme.aggregation_budget=300000",
            "--grains", str(grains_bin), "--out", str(tmp_path)]
    script = str(ROOT / "runner" / "consolidation_campaign.py")
    tool_run = subprocess.Popen([sys.executable, script, *args], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        h5 = tmp_path / "consolidation-seed1.h5"
        deadline = time.monotonic() + 60
        while not h5.exists() and time.monotonic() < deadline and tool_run.poll() is None:
            time.sleep(0.05)
        assert tool_run.poll() is None and grains_processes_writing_in(tmp_path), tool_run.communicate()
        with pytest.raises(OSError):   # the run holds HDF5's lock
            h5py.File(h5, "r").close()
        assert run_files.stored(h5)["particles"]["count"] == 80
        report = subprocess.run([sys.executable, script, *args, "--report"], capture_output=True, text=True)
        assert report.returncode == 0 and "other settings" not in report.stderr, report.stderr
        assert "consolidation: seeds 1–1, 80 disks;" in (tmp_path / "summary.md").read_text()
        assert tool_run.poll() is None   # the campaign still runs
    finally:
        tool_run.terminate()
        tool_run.communicate(timeout=60)


def test_a_fifo_at_a_runs_path_is_taken_as_not_ended_without_waiting(tmp_path):
    """run_files.ended opened whatever the path held with h5py, which waits on a FIFO until something writes into it."""
    fifo = tmp_path / "run.h5"
    os.mkfifo(fifo)
    code = f"import sys; sys.path.insert(0, {str(ROOT / 'runner')!r}); import run_files; print(run_files.ended({str(fifo)!r}))"
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=30)
    assert (r.returncode, r.stdout) == (0, "False\n"), r.stderr


def test_reading_or_comparing_a_fifo_at_a_runs_path_neither_waits_nor_calls_it_missing(tmp_path):
    """run_files.read_unlocked opened a FIFO with h5py, which waits until something writes into it;
    run_reuse.difference then said a FIFO at a sample's path was "missing"."""
    fifo = tmp_path / "run.h5"
    os.mkfifo(fifo)
    code = (f"import sys; sys.path.insert(0, {str(ROOT / 'runner')!r}); import run_files, run_reuse\n"
            f"try:\n    run_files.read_unlocked({str(fifo)!r}, lambda f: 1)\n"
            f"except OSError as e:\n    print(e)\n"
            f"print(run_reuse.difference({{}}, {str(fifo)!r}))")
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=30)
    assert (r.returncode, r.stdout) == (0, f"'{fifo}' is a FIFO (named pipe), not an HDF5 file grains wrote\n"
                                           f"{fifo} is a FIFO (named pipe), not an HDF5 file grains wrote\n"), r.stderr


def test_a_folder_or_fifo_at_a_samples_name_is_refused_not_deleted(tmp_path):
    """An unfinished sample's file was deleted before its programme ran again (now it is run again over:
    --overwrite): a FIFO at its name was deleted silently, and a folder ended the campaign in a traceback. Refused, naming the path and what
    it holds, before anything runs (no grains is needed to get there)."""
    os.mkfifo(tmp_path / "consolidation-seed4.h5")
    (tmp_path / "consolidation-seed5.h5").mkdir()
    for seed, kind in ((4, "a FIFO (named pipe)"), (5, "a folder")):
        stem = tmp_path / f"consolidation-seed{seed}"
        with pytest.raises(child_runs.RunFailed, match=re.escape(f"seed{seed}.h5 is {kind}, not a sample's HDF5 file")):
            campaign.consolidate(tmp_path / "no-grains", ROOT / "models/consolidation.toml", [], stem, f"seed {seed}")
    assert (tmp_path / "consolidation-seed4.h5").is_fifo() and (tmp_path / "consolidation-seed5.h5").is_dir()


def test_a_folder_at_a_later_samples_name_is_refused_before_any_sample_runs(grains_bin, tmp_path):
    """The campaign refused a folder or FIFO at a sample's name only when it reached that sample, with the samples
    before it run (or under way beside it) and the campaign then ended there. Now every name is checked first."""
    (tmp_path / "consolidation-seed5.h5").mkdir()
    r = subprocess.run([sys.executable, str(ROOT / "runner/consolidation_campaign.py"), "--samples", "2", "--first-seed", "4",
                        "--count", "8", "--scene", "consolidation", "--jobs", "1", "--grains", str(grains_bin),
                        "--out", str(tmp_path)], capture_output=True, text=True, timeout=120)
    assert r.returncode == 2, r.stderr
    assert f"{tmp_path / 'consolidation-seed5.h5'} is a folder, not a sample's HDF5 file" in r.stderr, r.stderr
    assert not list(tmp_path.glob("consolidation-seed4*")), "seed 4 ran before the folder at seed 5's name was refused"


def test_a_folder_at_a_samples_name_is_refused_before_initial_states_runs_but_not_in_its_report(grains_bin, tmp_path):
    """runner/initial_states.py shares the check made before any run; its --report, which runs and writes nothing,
    was refused by it (the tool checks its samples with the campaign's run-time arguments in both modes)."""
    (tmp_path / "type1-seed2.h5").mkdir()
    cmd = [sys.executable, str(ROOT / "runner/initial_states.py"), "--samples", "2", "--count", "60", "--state", "type1",
           "--jobs", "1", "--grains", str(grains_bin), "--out", str(tmp_path)]
    r = subprocess.run(cmd, capture_output=True, text=True, timeout=120)
    assert r.returncode == 2 and f"{tmp_path / 'type1-seed2.h5'} is a folder, not a sample's HDF5 file" in r.stderr, r.stderr
    assert not list(tmp_path.glob("type1-seed1*")), "seed 1 ran before the folder at seed 2's name was refused"
    # An archived table of seed 1 (no HDF5 file beside it): the report summarises it and names seed 2 as missing.
    with (tmp_path / "type1-seed1.csv").open("w") as f:
        f.write("phi,coordination,reached,steps\n0.72,3.9,1,1000\n")
    r = subprocess.run(cmd + ["--report"], capture_output=True, text=True, timeout=120)
    assert r.returncode == 0 and "type1 seed 2: no table in" in r.stdout, r.stdout + r.stderr
    assert "| type1 | 0.7200 (1) |" in (tmp_path / "summary.md").read_text()


def test_a_programme_that_ends_without_its_stage_table_is_named_not_a_traceback(tmp_path):
    """A --grains that exits 0 without writing the table is named, not a FileNotFoundError; and the console says when
    a sample starts."""
    r = subprocess.run([sys.executable, str(ROOT / "runner/consolidation_campaign.py"), "--grains", "/bin/true", "--out",
                        str(tmp_path / "c"), "--samples", "1", "--scene", "consolidation"], capture_output=True, text=True,
                       timeout=120)
    assert r.returncode == 1 and "Traceback" not in r.stderr, r.stderr
    assert "consolidation-seed1: the programme ended without its stage table" in r.stderr, r.stderr
    assert "started consolidation seed 1 (log:" in r.stdout, r.stdout
