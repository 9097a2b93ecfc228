"""The loading curve by system size (runner/loading_by_size.py): each folder's samples are averaged and fitted as the
campaign fits its mean curve, unfinished samples are left out, and bad arguments are refused by name."""
import subprocess
import sys

import numpy as np
import pytest

from conftest import ROOT
from test_consolidation_campaign import synthetic_curve, write_table

sys.path.insert(0, str(ROOT / "runner"))
import consolidation_campaign as campaign  # noqa: E402
import loading_by_size  # noqa: E402


def write_samples(folder, scene, lams, partial_lam=None):
    """One table per lambda of a synthetic crossover curve (and, if given, an unfinished one far off them)."""
    folder.mkdir()
    for seed, lam in enumerate(lams, start=1):
        p, phi = synthetic_curve(lam=lam)
        write_table(folder / f"{scene}-seed{seed}.csv", [("loading", "loading", x, y, 1, 3.1) for x, y in zip(p, phi)])
    if partial_lam is not None:
        p, phi = synthetic_curve(lam=partial_lam)
        write_table(folder / f"{scene}-seed{len(lams) + 1}.partial.csv",
                    [("loading", "loading", x, y, 1, 3.1) for x, y in zip(p[:12], phi[:12])])


def fitted_lambda(line):
    return float(line.split(" | ")[3].split(" ±")[0])


def test_each_size_gets_the_fit_of_its_mean_curve_and_unfinished_samples_are_left_out(tmp_path):
    write_samples(tmp_path / "small", "consolidation", [0.3, 0.3, 0.3], partial_lam=0.9)
    write_samples(tmp_path / "large", "consolidation", [0.2])
    figure = tmp_path / "by-size.png"
    out = subprocess.run([sys.executable, str(ROOT / "runner" / "loading_by_size.py"), "--scene", "consolidation",
                          "--campaign", f"1400={tmp_path / 'small'}", "--campaign", f"5600={tmp_path / 'large'}",
                          "--resamples", "3", "--out", str(figure)], capture_output=True, text=True, check=True).stdout
    rows = [l for l in out.splitlines() if l.startswith("| consolidation |")]
    assert [r.split(" | ")[1:3] for r in rows] == [["1400", "3"], ["5600", "1"]]
    assert abs(fitted_lambda(rows[0]) - 0.3) < 1e-3 and abs(fitted_lambda(rows[1]) - 0.2) < 1e-3
    # the regime II line alone, to P* = 0.1: flatter than the crossover's lambda, as the curve already bends there
    line = float(rows[0].split(" | ")[8].split(" ±")[0])
    assert 0.2 < line < 0.3, rows[0]
    # three identical samples: their resampled spread is zero; one sample has none
    assert "; ± 0.000" in rows[0] and "; ±" not in rows[1].split(" | ")[3]
    # the paper's P1* as its Table III states it, its own curve's regime II line and one-stage rises
    assert rows[0].endswith("0.349 ± 0.019, 0.7808, 0.271 ± 0.033; line 0.328 (0.336, 0.303); rises 0.0231, 0.028, 0% |")
    assert figure.stat().st_size > 10_000


def test_a_label_given_twice_pools_the_seeds_chosen_from_its_folders(tmp_path):
    # the paper's mix of sizes: some seeds of one campaign and some of another, averaged as one curve
    write_samples(tmp_path / "small", "consolidation", [0.3, 0.3, 0.9])
    write_samples(tmp_path / "large", "consolidation", [0.9, 0.3])
    out = subprocess.run([sys.executable, str(ROOT / "runner" / "loading_by_size.py"), "--scene", "consolidation",
                          "--campaign", f"mix={tmp_path / 'small'}:1-2", "--campaign", f"mix={tmp_path / 'large'}:2",
                          "--campaign", f"all={tmp_path / 'small'}", "--campaign", f"all={tmp_path / 'small'}/:2-3",
                          "--resamples", "0", "--out", str(tmp_path / "m.png")],
                         capture_output=True, text=True, check=True).stdout
    rows = [l for l in out.splitlines() if l.startswith("| consolidation |")]
    # "all" names seeds 2 and 3 of its folder twice (the second time as another spelling of the folder): counted once
    assert [r.split(" | ")[1:3] for r in rows] == [["mix", "3"], ["all", "3"]]
    assert abs(fitted_lambda(rows[0]) - 0.3) < 1e-3   # the λ = 0.9 samples left out
    assert fitted_lambda(rows[1]) > 0.35   # and counted where every seed is taken


def test_the_stage_rises_tell_a_staircase_from_a_smooth_climb(tmp_path):
    p, phi = campaign.paper_curve("consolidation")
    stairs = phi[np.arange(len(phi)) // 4 * 4]   # each value held four stages: three flat ones, then a jump
    shifted = phi[np.clip((np.arange(len(phi)) + 2) // 4 * 4 - 2, 0, None)]   # the same, its jumps two stages later
    for name, curves in (("smooth", [phi]), ("stairs", [stairs]), ("two", [stairs, shifted])):
        (tmp_path / name).mkdir()
        for seed, curve in enumerate(curves, start=1):
            write_table(tmp_path / name / f"consolidation-seed{seed}.csv",
                        [("loading", "loading", x, y, 1, 3.1) for x, y in zip(p, curve)])
    out = subprocess.run([sys.executable, str(ROOT / "runner" / "loading_by_size.py"), "--scene", "consolidation",
                          "--campaign", f"smooth={tmp_path / 'smooth'}", "--campaign", f"stairs={tmp_path / 'stairs'}",
                          "--campaign", f"two={tmp_path / 'two'}",
                          "--resamples", "0", "--out", str(tmp_path / "s.png")], capture_output=True, text=True, check=True).stdout
    rows = {r.split(" | ")[1]: r.split(" | ")[9].split("; mean curve ") for r in out.splitlines() if r.startswith("| consolidation |")}
    # the paper's own curve climbs as the paper's does; its stairs from P0* = 0.0237 (the fourth stage) to P* = 1 (the
    # seventeenth): 13 rises, 4 of them the jumps at stages 5, 9, 13 and 17, each the sum of four of the curve's rises
    assert rows["smooth"] == ["0.0231, 0.028, 0%"] * 2
    median, largest, flat = rows["stairs"][0].split(", ")
    assert float(median) == 0 and flat == "69%"   # 9 of 13
    assert rows["stairs"][1] == rows["stairs"][0]   # one sample is its own mean curve
    jumps = [phi[k + 4] - phi[k] for k in (0, 4, 8, 12)]
    assert float(largest) == pytest.approx(max(jumps), abs=6e-4) and float(largest) > 3.5 * 0.028
    # two staircases whose jumps fall on other stages: their mean climbs every second stage, with smaller jumps
    samples, mean = ([float(v.rstrip("%")) for v in cell.split(", ")] for cell in rows["two"])
    assert mean[2] < samples[2] - 20 and mean[1] < samples[1]


@pytest.mark.parametrize("given, said", [("1400", "expected LABEL=FOLDER"), ("1400=/nonexistent/folder", "is not a folder"),
                                         ("1400=/nonexistent/folder:4-8", "is not a folder"), (".=.:8-4", "run backwards")])
def test_a_campaign_argument_that_is_not_a_label_and_folder_is_refused(given, said):
    run = subprocess.run([sys.executable, str(ROOT / "runner" / "loading_by_size.py"), "--campaign", given],
                         capture_output=True, text=True)
    assert run.returncode == 2 and said in run.stderr and "Traceback" not in run.stderr


@pytest.mark.parametrize("out, said", [("missing/x.png", "does not exist"), ("x.h5", "supported image format")])
def test_a_figure_name_that_cannot_be_written_is_refused_before_the_fits(tmp_path, out, said):
    write_samples(tmp_path / "c", "consolidation", [0.3])
    run = subprocess.run([sys.executable, str(ROOT / "runner" / "loading_by_size.py"), "--campaign", f"x={tmp_path / 'c'}",
                          "--out", str(tmp_path / out)], capture_output=True, text=True)
    assert run.returncode == 2 and said in run.stderr and "Traceback" not in run.stderr and "| consolidation |" not in run.stdout


def test_folders_without_a_finished_table_are_an_error(tmp_path):
    (tmp_path / "empty").mkdir()
    run = subprocess.run([sys.executable, str(ROOT / "runner" / "loading_by_size.py"), "--campaign", f"x={tmp_path / 'empty'}"],
                         capture_output=True, text=True)
    assert run.returncode == 2 and "no finished stage table" in run.stderr


def test_the_fit_at_the_papers_start_shows_how_far_lambda_rides_on_where_the_plateau_ends(tmp_path):
    # two curves of the same lambda, one leaving its plateau at the paper's P0* = 0.0237, one at 0.0422: the free fit
    # finds lambda in both; held at the paper's P0*, the second reads a shallower climb from an earlier start
    for name, p0 in (("paper-start", 0.0237), ("late-start", 0.0422)):
        folder = tmp_path / name
        folder.mkdir()
        p, phi = synthetic_curve(lam=0.3, p0=p0)
        write_table(folder / "consolidation-seed1.csv", [("loading", "loading", x, y, 1, 3.1) for x, y in zip(p, phi)])
    out = subprocess.run([sys.executable, str(ROOT / "runner" / "loading_by_size.py"), "--scene", "consolidation",
                          "--campaign", f"a={tmp_path / 'paper-start'}", "--campaign", f"b={tmp_path / 'late-start'}",
                          "--resamples", "0", "--out", str(tmp_path / "f.png")], capture_output=True, text=True, check=True).stdout
    rows = {r.split(" | ")[1]: r.split(" | ") for r in out.splitlines() if r.startswith("| consolidation |")}
    held = {k: float(v[10].split(" ±")[0]) for k, v in rows.items()}
    assert abs(fitted_lambda(" | ".join(rows["a"])) - 0.3) < 1e-3 and abs(fitted_lambda(" | ".join(rows["b"])) - 0.3) < 1e-3
    assert abs(held["a"] - 0.3) < 1e-3 and held["b"] < 0.27
    # the line's other ends, ours and the paper's curve's: numbers (its curve bends, so the longer line is flatter)
    ends = [float(x) for x in rows["a"][10].split("; ")[2].split(", ")]
    assert len(ends) == 2 and ends[1] < ends[0]
    assert "line 0.328 (0.336, 0.303); rises" in rows["a"][11]
