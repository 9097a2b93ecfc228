"""Bad stage tables given to the tools that read them (runner/consolidation_fit.py, consolidation_campaign.py --report,
initial_states.py --report, loading_by_size.py): one line naming the file, the line, the column, the value and what
the column holds, and exit status 2: not a traceback (TypeError, KeyError, IndexError, IsADirectoryError), a fit
of a negative solid fraction, or a wait without end on a FIFO at a table's name."""
import os
import subprocess
import sys

import pytest

from conftest import ROOT

sys.path.insert(0, str(ROOT / "runner"))
import consolidation_fit as cf  # noqa: E402

RUNNER = ROOT / "runner"
# Six loading stages: enough for both fits, so a table read without complaint is fitted (exit status 0).
GOOD = ["0.01,0.50", "0.02,0.52", "0.05,0.56", "0.1,0.60", "0.3,0.68", "1,0.74"]


def refused(r, *said):
    """The command ended with status 2, its last line on stderr saying all of `said` (notes may come before it)."""
    assert r.returncode == 2, (r.returncode, r.stdout, r.stderr)
    assert "Traceback" not in r.stderr and r.stderr.endswith("\n"), r.stderr
    error = r.stderr.splitlines()[-1]
    for words in said:
        assert words in error, r.stderr


@pytest.mark.parametrize("text, said", [
    ("P_star,phi\n0.01,0.50\n0.02\n" + "\n".join(GOOD[2:]) + "\n",
     "line 3: column 'phi' is missing: the row has 1 of the header's 2 fields"),
    ("P_star,phi\n0.01,0.50\nfoo,bar\n" + "\n".join(GOOD[2:]) + "\n",
     "line 3: column 'P_star' = 'foo' is not a number"),
    ("P_star,phi\n" + "\n".join(g.split(",")[0] + ",0" for g in GOOD) + "\n",
     "line 2: column 'phi' = '0' is out of range: a solid fraction is in (0, 1]"),
    ("P_star,phi\n" + "\n".join(GOOD[:3]) + "\n0.1,-1\n" + "\n".join(GOOD[4:]) + "\n",
     "line 5: column 'phi' = '-1' is out of range: a solid fraction is in (0, 1]"),
    ("P_star,phi\n" + "\n".join(GOOD[:3]) + "\n-1,0.6\n" + "\n".join(GOOD[4:]) + "\n",
     "line 5: column 'P_star' = '-1' is out of range: the reduced pressure P* of a stage in equilibrium is finite"),
    ("# made by hand\nP_star,phi\n0.01,0.50\n# a remark\n0.02,0.5x\n" + "\n".join(GOOD[2:]) + "\n",
     "line 5: column 'phi' = '0.5x' is not a number"),   # lines counted in the file, comments too
    ("a,b\n1,2\n", "needs a header with columns P_star (or pressure_reduced) and phi (or solid_fraction); it has a, b"),
    ("", "is empty: no header naming its columns, no stage"),
    ("P_star,phi\n", "has a header and no stage"),
    # A branch word the fit does not know: its stages were left out without a word.
    ("P_star,phi,branch\n" + "\n".join(g + ",loading" for g in GOOD[:4]) + "\n0.3,0.68,Loading\n1,0.74,loading\n",
     "line 6: column 'branch' = 'Loading' is out of range: a branch is loading or unloading"),
], ids=["missing-field", "garbage-number", "phi-0", "phi-negative", "p-negative", "line-after-comments",
        "missing-columns", "empty", "header-only", "branch-word"])
def test_a_bad_table_given_to_the_fit_is_named_with_its_line_column_and_value(tmp_path, text, said):
    table = tmp_path / "stages.csv"
    table.write_text(text)
    r = subprocess.run([sys.executable, RUNNER / "consolidation_fit.py", table, "-o", tmp_path / "fit.png"],
                       capture_output=True, text=True, timeout=120)
    refused(r, f"consolidation_fit: stage table '{table}' ", said)
    assert not (tmp_path / "fit.png").exists()


def test_a_stage_short_of_equilibrium_or_in_preparation_may_have_a_negative_pressure(tmp_path):
    """grains writes a negative P* for the aggregation and for a stage that missed its target: those stages are left
    out, not refused; a solid fraction out of range is refused wherever it is."""
    table = tmp_path / "stages.csv"
    rows = ["stage,phase,branch,target_pressure,P_star,phi,reached", "0,aggregation,preparation,nan,-0.001,0.36,1",
            "1,equilibrate,preparation,0,-1e-8,0.36,1", "2,equilibrate,loading,0.01,-0.003,0.5,0"]
    rows += [f"{k + 3},loading,loading,{g.split(',')[0]},{g},1" for k, g in enumerate(GOOD)]
    table.write_text("\n".join(rows) + "\n")
    p, phi, branch = cf.read_stages(table)
    assert p.tolist() == [float(g.split(",")[0]) for g in GOOD] and set(branch) == {"loading"}
    table.write_text("\n".join(rows[:3] + ["2,equilibrate,loading,0.01,-0.003,1.5,0"] + rows[4:]) + "\n")
    with pytest.raises(cf.TableError, match="line 4: column 'phi' = '1.5' is out of range"):
        cf.read_stages(table)


def occupy(path, kind):
    """Puts a folder, a FIFO or a file of the given text at path."""
    if kind == "folder":
        path.mkdir()
    elif kind == "FIFO":
        os.mkfifo(path)
    else:
        path.write_text(kind)


# A campaign's stage table cut to its first stages (grains consolidate's columns, the ones the report reads).
CAMPAIGN_HEADER = "stage,phase,branch,target_pressure,P_star,phi,reached,steps,coordination"
CAMPAIGN_ROWS = ["0,aggregation,preparation,nan,-0.00136,0.36,1,96600,3.13",
                 "1,equilibrate,preparation,0,1.9e-08,0.36,1,4000,3.13",
                 "2,equilibrate,loading,0.01,0.011,0.49,0,2000000,3.09",
                 "3,loading,loading,0.0133,0.0133,0.54,1,900000,3.14"]


@pytest.mark.parametrize("kind, said", [
    ("a,b\n1,2\n", "needs a header with columns branch, reached, P_star, phi, coordination and phase; it has a, b"),
    ("\n".join([CAMPAIGN_HEADER] + CAMPAIGN_ROWS[:3] + [CAMPAIGN_ROWS[3].replace(",0.54,", ",xyz,")]) + "\n",
     "line 5: column 'phi' = 'xyz' is not a number"),
    ("\n".join([CAMPAIGN_HEADER] + CAMPAIGN_ROWS[:3] + [CAMPAIGN_ROWS[3].replace(",0.0133,0.54,", ",-1,0.54,")]) + "\n",
     "line 5: column 'P_star' = '-1' is out of range"),
    ("\n".join([CAMPAIGN_HEADER] + CAMPAIGN_ROWS[:3] + ["3,loading,loading,0.0133"]) + "\n",
     "line 5: column 'P_star' is missing: the row has 4 of the header's 9 fields"),
    ("folder", "is a folder, not a CSV file"),
    ("FIFO", "is a FIFO (named pipe), not a CSV file"),
], ids=["missing-columns", "garbage-number", "p-negative", "row-cut-short", "folder", "fifo"])
def test_a_bad_table_in_a_campaign_report_is_named_not_a_traceback_or_a_wait(grains_bin, tmp_path, kind, said):
    table = tmp_path / "consolidation-seed1.csv"
    occupy(table, kind)
    r = subprocess.run([sys.executable, RUNNER / "consolidation_campaign.py", "--grains", grains_bin, "--report",
                        "--out", tmp_path, "--samples", "1", "--scene", "consolidation", "--resamples", "0"],
                       capture_output=True, text=True, timeout=120)
    refused(r, "consolidation_campaign.py: error: ", str(table), said)


def test_an_unfinished_table_still_empty_is_a_sample_with_no_stage_yet(grains_bin, tmp_path):
    """grains writes a programme's header with its first stage's row: until the aggregation ends a running sample's
    table is empty, which the report beside the campaign takes as a sample not loaded yet, as before."""
    (tmp_path / "consolidation-seed1.partial.csv").write_text("")
    (tmp_path / "consolidation-seed2.csv").write_text("\n".join([CAMPAIGN_HEADER] + CAMPAIGN_ROWS) + "\n")
    r = subprocess.run([sys.executable, RUNNER / "consolidation_campaign.py", "--grains", grains_bin, "--report",
                        "--out", tmp_path, "--samples", "2", "--scene", "consolidation", "--resamples", "0"],
                       capture_output=True, text=True, timeout=120)
    assert r.returncode == 0 and "consolidation seed 1: no loading stage yet" in r.stdout, r.stdout + r.stderr
    assert "| consolidation | phi_0.01 | 0.4900 (1) |" in r.stdout, r.stdout


@pytest.mark.parametrize("kind, said", [
    ("", "is empty: no header naming its columns, no stage"),
    ("phi,coordination,reached,steps\n", "has a header and no stage"),
    ("a,b\n1,2\n", "needs a header with columns phi, coordination, reached and steps; it has a, b"),
    ("phi,coordination,reached,steps\n0.72,3.9,1,1000\n0.72,xyz,1,2000\n",
     "line 3: column 'coordination' = 'xyz' is not a number"),
    ("phi,coordination,reached,steps\n0,3.9,1,1000\n", "line 2: column 'phi' = '0' is out of range"),
    ("phi,coordination,reached,steps\n0.72,3.9,1,1e3\n", "line 2: column 'steps' = '1e3' is not a whole number"),
    ("folder", "is a folder, not a CSV file"),
    ("FIFO", "is a FIFO (named pipe), not a CSV file"),
], ids=["empty", "header-only", "missing-columns", "garbage-number", "phi-0", "steps-not-whole", "folder", "fifo"])
def test_a_bad_table_in_an_initial_states_report_is_named_not_a_traceback_or_a_wait(grains_bin, tmp_path, kind, said):
    table = tmp_path / "type1-seed1.csv"
    occupy(table, kind)
    r = subprocess.run([sys.executable, RUNNER / "initial_states.py", "--grains", grains_bin, "--report",
                        "--out", tmp_path, "--state", "type1", "--samples", "1"],
                       capture_output=True, text=True, timeout=120)
    refused(r, "initial_states.py: error: ", str(table), said)


@pytest.mark.parametrize("kind", ["folder", "FIFO"])
def test_loading_by_size_reads_a_campaigns_tables_through_the_same_checks(tmp_path, kind):
    """loading_by_size.py reads the tables with consolidation_campaign.summarise: a folder at a table's name was an
    IsADirectoryError, a FIFO held it without end. Now one line naming the table as what it is, status 2."""
    table = tmp_path / "consolidation-seed1.csv"
    occupy(table, kind)
    r = subprocess.run([sys.executable, RUNNER / "loading_by_size.py", "--campaign", f"1400={tmp_path}", "--scene",
                        "consolidation", "--out", tmp_path / "l.png"], capture_output=True, text=True, timeout=120)
    what = "a folder" if kind == "folder" else "a FIFO (named pipe)"
    assert r.returncode == 2 and f"stage table '{table}' is {what}, not a CSV file" in r.stderr, r.stderr
    assert "Traceback" not in r.stderr
