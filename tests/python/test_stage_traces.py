"""runner/stage_traces.py: a stage's course from a grains consolidate output's trace (grains/trace/*), and the
picture of the first compressions."""
import csv
import importlib.util
import math
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

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
    (label, t, phi, end_phi, reached, end_time, unfinished), = stage_traces.first_compressions([programme])
    assert label == "small" and end_phi == float(rows[2]["phi"]) and reached == (rows[2]["reached"] == "1")
    assert unfinished is None
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
    assert f"note: {lone}: left out of the first-compression figure: no stage table" in r.stderr
    # A stage table cut short or edited by hand: named with what it lacks (a KeyError before).
    (tmp_path / "missing.csv").write_text("stage,phi\n0,0.5\n")
    r = subprocess.run([sys.executable, ROOT / "runner" / "stage_traces.py", lone], capture_output=True, text=True)
    assert r.returncode == 2 and "Traceback" not in r.stderr, r.stderr
    assert "needs a header with columns stage, branch, phi, time and reached; it has stage, phi" in r.stderr, r.stderr
    # These end in one line, not a traceback: a file h5py cannot open (here a CSV), and an -o checked before the
    # figure is drawn (a format matplotlib does not write, a missing folder, a folder at the name).
    table = tmp_path / "stages.csv"
    table.write_text("stage,phi\n0,0.5\n")
    (tmp_path / "folder.png").mkdir()
    for args, words in (([table], [f"'{table}' cannot be read as the HDF5 file grains consolidate wrote"]),
                        ([programme, "-o", tmp_path / "x.txt"], ["-o/--out", "supported image format"]),
                        ([programme, "-o", tmp_path / "no" / "x.png"], ["-o/--out", "does not exist"]),
                        ([programme, "-o", tmp_path / "folder.png"], ["-o/--out", "is a folder"])):
        r = subprocess.run([sys.executable, ROOT / "runner" / "stage_traces.py", *args], capture_output=True, text=True)
        assert r.returncode == 2 and "Traceback" not in r.stderr and all(w in r.stderr for w in words), r.stderr


def test_samples_of_the_same_name_in_two_folders_are_told_apart(programme, tmp_path):
    """Campaigns name their samples alike (consolidation-seed4.h5 in each): such files are labelled with their folder."""
    copies = []
    for folder in ("slow", "fast"):
        (tmp_path / folder).mkdir()
        for suffix in (".h5", ".csv"):
            shutil.copy(programme.with_suffix(suffix), tmp_path / folder / programme.with_suffix(suffix).name)
        copies.append(tmp_path / folder / programme.name)
    labels = [c.label for c in stage_traces.first_compressions(copies + [programme])]
    assert labels == ["slow/small", "fast/small", f"{programme.parent.name}/small"]
    assert [c.label for c in stage_traces.first_compressions([copies[0]])] == ["small"]


@pytest.fixture(scope="module")
def stopped(grains_bin, tmp_path_factory):
    """The small type-2 programme stopped by Ctrl-C inside its first compression: the signal goes once the table has
    the two preparation stages' rows, and that stage's ramp (programme.first_compression_time) makes it long enough
    for the signal to land in it."""
    folder = tmp_path_factory.mktemp("stopped")
    out, table = folder / "sample.h5", folder / "sample.csv"
    cmd = [grains_bin, "consolidate", ROOT / "models" / "consolidation.toml", "--set", "particles.count=100", "--set",
           "programme.aggregation_budget=4000", "--set", "programme.stage_budget=2000", "--set",
           "programme.first_compression_time=1e6", "--set", "programme.trace_every=500", "--set", "run.threads=1",
           "--out", out, "--table", table, "--quiet"]
    p = subprocess.Popen([str(c) for c in cmd], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    deadline = time.monotonic() + 120
    while p.poll() is None and time.monotonic() < deadline and (
            not table.exists() or len(table.read_text().splitlines()) < 3):
        time.sleep(0.05)
    time.sleep(0.5)   # some of the stage's trace rows
    p.send_signal(signal.SIGINT)
    stdout, stderr = p.communicate(timeout=60)
    assert p.returncode == 130 and "INTERRUPTED in stage 2" in stdout, stdout + stderr
    return out


def test_a_programme_stopped_in_its_first_compression_is_drawn_dashed_as_far_as_it_got(stopped, programme, tmp_path):
    """A sample still in its first compression (a campaign running, or a programme stopped there) has no table row
    for it: it was left out of the picture. Its trace so far is drawn dashed, without an end, and the legend says
    whether its file is still being written or stopped."""
    rows = list(csv.DictReader(stopped.with_suffix(".csv").open()))
    assert [r["branch"] for r in rows] == ["preparation", "preparation"]
    course, = stage_traces.first_compressions([stopped])
    assert course.label == "sample" and course.unfinished == "stopped" and not course.reached
    assert math.isnan(course.end_phi) and math.isnan(course.end_time)
    start = float(rows[1]["time"])
    with h5py.File(stopped) as f:
        here = f["grains/trace/stage/value"][()] == 2
        assert here.sum() >= 2
        assert np.array_equal(course.phi, f["grains/trace/solid_fraction/value"][()][here])
        assert np.allclose(course.t, f["grains/trace/stage/time"][()][here] - start, rtol=0, atol=1e-9)
    # A campaign's sample still running reads as one: its file's status 'running'.
    running = tmp_path / "running.h5"
    shutil.copy(stopped, running)
    shutil.copy(stopped.with_suffix(".csv"), tmp_path / "running.csv")
    with h5py.File(running, "r+") as f:
        f["grains"].attrs["stage_table"] = np.bytes_("running.csv")
        f["grains"].attrs["status"] = np.bytes_("running")
    finished, under_way, still = stage_traces.first_compressions([programme, stopped, running])
    assert finished.unfinished is None and (under_way.label, under_way.unfinished) == ("sample", "stopped")
    assert (still.label, still.unfinished) == ("running", "still running")
    import matplotlib.pyplot as plt
    fig = stage_traces.first_compression_figure({"samples": [finished, under_way, still]})
    ax = fig.axes[0]
    drawn = [(None if line.get_label().startswith("_") else line.get_label(), line.get_linestyle()) for line in ax.lines]
    # The finished one solid with its end's dot (no legend entry); the unfinished ones dashed, no dot.
    assert drawn == [("small", "-"), (None, "None"), ("sample (stopped)", "--"), ("running (still running)", "--")]
    assert np.array_equal(ax.lines[2].get_ydata(), course.phi)
    assert ax.get_legend().get_title().get_text() == "open: not in equilibrium; dashed: unfinished"
    plt.close(fig)
    out = tmp_path / "first.png"
    r = subprocess.run([sys.executable, ROOT / "runner" / "stage_traces.py", stopped, "-o", out], capture_output=True,
                       text=True)
    assert r.returncode == 0 and out.stat().st_size > 0, r.stderr


def test_labels_are_the_shortest_path_ends_that_tell_the_files_apart(tmp_path):
    """Labelled folder/stem, a/x/s.h5 and b/x/s.h5 were both x/s: each takes as much of its path as tells it from the
    others, a stem of its own stays alone, and a file given twice is one file."""
    paths = [tmp_path / "a/x/s.h5", tmp_path / "b/x/s.h5", tmp_path / "c/y/s.h5", tmp_path / "c/t.h5"]
    assert stage_traces.labels_of(paths) == ["a/x/s", "b/x/s", "y/s", "t"]
    assert stage_traces.labels_of([tmp_path / "a/x/s.h5", tmp_path / "a/x/s.h5"]) == ["s", "s"]
    # Files that differ by their suffix alone were both labelled s: they keep it.
    assert stage_traces.labels_of([tmp_path / "a/s.h5", tmp_path / "a/s.h5md", tmp_path / "b/s.h5"]) == ["a/s.h5", "s.h5md", "b/s.h5"]
    relative = [Path("a/x/s.h5"), Path("b/x/s.h5")]
    assert stage_traces.labels_of(relative) == ["a/x/s", "b/x/s"]


def without_trace(stopped, h5, trace_every):
    """A copy of the stopped programme at h5, with its table, as a file inside its first compression without a trace
    row of it: its trace gone, and its scene's programme.trace_every set to `trace_every`."""
    shutil.copy(stopped, h5)
    shutil.copy(stopped.with_suffix(".csv"), h5.with_suffix(".csv"))
    with h5py.File(h5, "r+") as f:
        f["grains"].attrs["stage_table"] = np.bytes_(h5.with_suffix(".csv").name)
        del f["grains/trace"]
        scene = f["parameters/scene.toml"][()].decode()
        assert "trace_every = 500\n" in scene
        del f["parameters/scene.toml"]
        f["parameters/scene.toml"] = scene.replace("trace_every = 500\n", f"trace_every = {trace_every}\n")
    return h5


def test_a_sample_in_its_first_compression_without_a_trace_row_is_left_out_with_a_note(stopped, programme, tmp_path,
                                                                                        capsys):
    """A sample stopped (or still running) before the first trace row of its first compression, or run without
    programme.trace_every, had an empty legend entry: it is left out, a note naming its file and why; with nothing left
    to draw, the tool says so."""
    quiet = without_trace(stopped, tmp_path / "quiet.h5", 500)
    untraced = without_trace(stopped, tmp_path / "untraced.h5", 0)
    courses = stage_traces.first_compressions([programme, quiet, untraced])
    assert [c.label for c in courses] == ["small"]
    notes = capsys.readouterr().err.splitlines()
    assert notes == [f"note: {quiet}: left out of the first-compression figure: no trace rows for its first compression "
                     "(stage 2, to P* = 0.01) yet",
                     f"note: {untraced}: left out of the first-compression figure: its programme runs without a trace "
                     "(programme.trace_every = 0), so its first compression (stage 2, to P* = 0.01) has none"]
    out = tmp_path / "first.png"
    r = subprocess.run([sys.executable, ROOT / "runner" / "stage_traces.py", quiet, untraced, "-o", out],
                       capture_output=True, text=True)
    assert r.returncode == 2 and not out.exists(), r.stderr
    assert f"note: {quiet}: left out" in r.stderr and f"note: {untraced}: left out" in r.stderr
    assert "error: nothing to draw: " in r.stderr and "under way with trace rows" in r.stderr


def recreate(f, name, data):
    del f[name]
    f[name] = data


def edit_table(column, change):
    """A change to the stage table's rows (a list of dicts, in the file's order) at `column`."""
    return lambda rows: [row.__setitem__(column, v) for row, v in zip(rows, change([r[column] for r in rows]))]


DAMAGE = {   # name -> (change to the file, change to its table's rows, words the refusal must hold)
    "trace_value_missing": (lambda f: f.__delitem__("grains/trace/stage/value"), None,
                            ["grains/trace/stage/value is missing", "need a dataset of numbers"]),
    "trace_time_short": (lambda f: recreate(f, "grains/trace/stage/time", f["grains/trace/stage/time"][:3]), None,
                         ["grains/trace/stage/time holds 3 row(s)", "need one per step", "its status is 'complete"]),
    "trace_phi_nan": (lambda f: f["grains/trace/solid_fraction/value"].__setitem__(slice(None), np.nan), None,
                      ["grains/trace/solid_fraction/value holds nan (row 0)", "(0, 1]"]),
    "trace_stage_strings": (lambda f: recreate(f, "grains/trace/stage/value", f["grains/trace/stage/value"][()].astype("S")),
                            None, ["grains/trace/stage/value holds values of type |S", "need numbers"]),
    "trace_steps_rotated": (lambda f: f["grains/trace/stage/step"].__setitem__(slice(None), np.roll(f["grains/trace/stage/step"][()], 1)),
                            None, ["grains/trace/stage/step is not strictly increasing"]),
    "table_time_nan": (None, edit_table("time", lambda t: [t[0], "nan", *t[2:]]),
                       ["line 3: column 'time' = 'nan' is out of range", "finite"]),
    "table_rows_swapped": (None, lambda rows: rows.insert(1, rows.pop(2)),
                           ["line 3: column 'stage' = '2' is out of order", "stage 1 belongs there"]),
    "table_time_later": (None, edit_table("time", lambda t: [t[0], "5.0", *t[2:]]),
                         ["line 4: column 'time' = '", "is out of order: stage 2 ends before stage 1 (at 5.0)"]),
}


def damaged_copy(programme, folder, name):
    """The programme and its stage table copied into `folder`, with DAMAGE[name]'s changes."""
    folder.mkdir()
    h5, table = folder / programme.name, folder / programme.with_suffix(".csv").name
    shutil.copy(programme, h5)
    change_file, change_rows, _ = DAMAGE[name]
    if change_file:
        with h5py.File(h5, "r+") as f:
            change_file(f)
    with programme.with_suffix(".csv").open(newline="") as source:
        reader = csv.DictReader(source)
        rows = list(reader)
    if change_rows:
        change_rows(rows)
    with table.open("w", newline="") as out:
        writer = csv.DictWriter(out, reader.fieldnames, lineterminator="\n")
        writer.writeheader()
        writer.writerows(rows)
    return h5


@pytest.mark.parametrize("name", DAMAGE)
def test_a_damaged_trace_or_stage_table_is_refused_in_one_line(programme, tmp_path, name):
    """A trace's dataset missing or cut short must not end in a traceback (KeyError, IndexError); a NaN Phi, a stage
    index of text, a table's NaN end time or rows out of order must not draw a first compression without its course,
    or from another stage's start, with exit status 0."""
    h5 = damaged_copy(programme, tmp_path / "sample", name)
    out = tmp_path / "first.png"
    r = subprocess.run([sys.executable, ROOT / "runner" / "stage_traces.py", h5, "-o", out], capture_output=True,
                       text=True, timeout=120)
    assert r.returncode == 2 and "Traceback" not in r.stderr, (r.returncode, r.stderr)
    error = r.stderr.splitlines()[-1]
    assert error.startswith("stage_traces.py: error: ") and (f"'{h5}'" in error or f"'{h5.with_suffix('.csv')}'" in error)
    assert all(w in error for w in DAMAGE[name][2]), r.stderr
    assert not out.exists()


def test_a_trace_still_being_written_is_drawn_as_far_as_all_its_series_go(programme, tmp_path):
    """While a run writes its file (status running), a trace's series may differ in length by the rows being appended:
    not refused, drawn to the rows all hold."""
    h5 = damaged_copy(programme, tmp_path / "sample", "trace_time_short")
    with h5py.File(h5, "r+") as f:
        f["grains"].attrs["status"] = np.bytes_("running")
    (course,) = stage_traces.first_compressions([h5])
    assert len(course.t) == len(course.phi) == 0 and course.end_phi > 0   # the stage's rows start past the third
