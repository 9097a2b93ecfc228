"""runner/stage_traces.py: a stage's course from a grains consolidate output's trace (grains/trace/*), and the
picture of the first compressions."""
import csv
import importlib.util
import subprocess
import sys

import h5py
import numpy as np
import pytest

from conftest import ROOT

spec = importlib.util.spec_from_file_location("stage_traces", ROOT / "runner" / "stage_traces.py")
stage_traces = importlib.util.module_from_spec(spec)
spec.loader.exec_module(stage_traces)


@pytest.fixture(scope="module")
def programme(grains_bin, tmp_path_factory):
    """A small type-2 programme: aggregation, relaxation at P* = 0, the first compression to 0.01, one loading stage."""
    folder = tmp_path_factory.mktemp("traces")
    out = folder / "small.h5"
    r = subprocess.run([grains_bin, "consolidate", ROOT / "models" / "consolidation.toml", "--set", "particles.count=100",
                        "--set", "programme.aggregation_budget=4000", "--set", "programme.stage_budget=6000", "--set",
                        "programme.top_pressure=0.0134", "--set", "programme.unload=false", "--set",
                        "programme.trace_every=500", "--set", "run.threads=1", "--out", out, "--table",
                        folder / "small.csv", "--quiet"], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    return out


def test_the_first_compression_is_the_first_loading_stage_from_its_start(programme):
    rows = list(csv.DictReader(programme.with_suffix(".csv").open()))
    assert [r["branch"] for r in rows] == ["preparation", "preparation", "loading", "loading"]
    (label, t, phi, end_phi, reached, end_time), = stage_traces.first_compressions([programme])
    assert label == "small" and end_phi == float(rows[2]["phi"]) and reached == (rows[2]["reached"] == "1")
    start = float(rows[1]["time"])
    assert end_time == pytest.approx(float(rows[2]["time"]) - start, rel=1e-9)
    with h5py.File(programme) as f:
        here = f["grains/trace/stage/value"][()] == 2
        assert np.array_equal(phi, f["grains/trace/solid_fraction/value"][()][here])
        assert np.allclose(t, f["grains/trace/stage/time"][()][here] - start, rtol=0, atol=1e-9)
        # The stage's last trace row is its end, its stage record (the initial state's, then stage k's at k + 1): the
        # line reaches the dot of its table row (which rounds Phi and the time to 9 digits).
        record = f["observables/solid_fraction"]
        assert t[-1] == record["time"][3] - start and phi[-1] == record["value"][3]
    assert len(t) >= 5 and (t > 0).all() and (t[:-1] < end_time).all() and (np.diff(t) > 0).all()
    assert phi[-1] == pytest.approx(end_phi, rel=1e-8, abs=0)


def test_the_picture_and_its_refusals(programme, tmp_path):
    out = tmp_path / "first.png"
    r = subprocess.run([sys.executable, ROOT / "runner" / "stage_traces.py", programme, "-o", out], capture_output=True,
                       text=True)
    assert r.returncode == 0 and out.stat().st_size > 0, r.stderr
    r = subprocess.run([sys.executable, ROOT / "runner" / "stage_traces.py", tmp_path / "none.h5"], capture_output=True,
                       text=True)
    assert r.returncode == 2 and "none.h5' does not exist" in r.stderr
    lone = tmp_path / "lone.h5"
    lone.write_bytes(programme.read_bytes())   # no stage table beside it, none named where it points
    with h5py.File(lone, "r+") as f:
        f["grains"].attrs["stage_table"] = np.bytes_("missing.csv")
    r = subprocess.run([sys.executable, ROOT / "runner" / "stage_traces.py", lone], capture_output=True, text=True)
    assert r.returncode == 2 and "no file has a stage table" in r.stderr, r.stderr
