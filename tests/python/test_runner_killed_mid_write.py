"""A run killed while HDF5 writes its file resumes to the records of the unbroken run, and leaves a file h5py reads
whole. A SIGKILL can leave an XDMF view group that `grains resume` cannot cut back ("bad heap free list", "address of
object past end of allocation"; 3 of 45 SIGKILLs of a 4096-sphere gas), after it has cut the records back already, so
that the run could never go on. Here kill_at_write.cpp, preloaded, kills a smaller run at chosen pwrite calls of
HDF5."""
import os
import shutil
import subprocess

import h5py
import numpy as np
import pytest

SETS = ["--set", "particles.count=512", "--set", "time.steps=3000", "--set", "output.checkpoint_every=500",
        "--set", "output.snapshots_every=50", "--set", "run.threads=1", "--quiet"]
KILL_POINTS = range(1500, 5900, 262)   # pwrite calls; the whole run makes about 5900


@pytest.fixture(scope="module")
def kill_shim(tmp_path_factory, root):
    compiler = shutil.which("g++") or shutil.which("c++")
    assert compiler, "no C++ compiler (runner/setup.sh installs g++)"
    lib = tmp_path_factory.mktemp("kill-shim") / "kill_at_write.so"
    subprocess.run([compiler, "-shared", "-fPIC", "-O1", "-Wall", "-Wextra", "-Werror",
                    str(root / "tests" / "python" / "kill_at_write.cpp"), "-ldl", "-o", str(lib)], check=True)
    return lib


def records(path):
    with h5py.File(path, "r") as f:   # cvode_seconds: a clock
        out = {f"observables/{k}": (s["step"][()], s["value"][()]) for k, s in f["observables"].items()
               if k != "cvode_seconds"}
        for name, s in f["particles/all"].items():
            if name != "box":
                out[f"particles/{name}"] = (s["step"][()], s["value"][()])
    return out


def allocation_ends_short(path):
    """Whether the superblock (version 0: its end of allocation is the 8 bytes at 40) ends before the bytes the run
    wrote: what HDF5 1.10 reads as objects past the end of allocation, or as a damaged heap."""
    data = path.read_bytes()
    assert data[8] == 0, "superblock version 0 expected"
    return int.from_bytes(data[40:48], "little") < len(data)


def read_whole(path):
    """Every object of the file visited and every dataset read; False where HDF5 fails."""
    try:
        with h5py.File(path, "r") as f:
            f.visititems(lambda name, obj: obj[()] if isinstance(obj, h5py.Dataset) else None)
        return True
    except Exception:
        return False


def test_a_run_killed_inside_hdf5_writes_resumes_to_the_unbroken_records(grains_bin, root, tmp_path, kill_shim):
    scene = root / "models" / "gas-friction.toml"
    whole = tmp_path / "whole.h5"
    subprocess.run([grains_bin, "run", scene, "--out", whole, *SETS], check=True, capture_output=True)
    expected = records(whole)
    damaged = 0
    for point in KILL_POINTS:
        killed = tmp_path / f"killed-{point}.h5"
        env = dict(os.environ, KILL_AT_WRITE=str(point), LD_PRELOAD=str(kill_shim))
        run = subprocess.run([grains_bin, "run", scene, "--out", killed, *SETS], env=env, capture_output=True)
        assert run.returncode == -9, (point, run.returncode)   # killed, not finished: the point is inside the run
        damaged += allocation_ends_short(killed)
        resumed = subprocess.run([grains_bin, "resume", killed, "--quiet"], capture_output=True, text=True)
        assert resumed.returncode == 0, (point, resumed.stderr)
        assert read_whole(killed), point
        got = records(killed)
        assert got.keys() == expected.keys(), point
        for name, (steps, values) in expected.items():
            assert np.array_equal(got[name][0], steps) and np.array_equal(got[name][1], values, equal_nan=True), (point, name)
    assert damaged >= 1, f"{damaged} killed files end short: the kill points no longer reach HDF5's flushes"


PROGRAMME = ["--set", "particles.count=100", "--set", "programme.stage_budget=3000", "--set",
             "programme.aggregation_budget=20000", "--set", "output.checkpoint_every=1000", "--set", "run.threads=1",
             "--quiet"]


def test_a_programme_killed_inside_hdf5_writes_resumes_to_the_unbroken_table_and_views(grains_bin, root, tmp_path,
                                                                                        kill_shim):
    """A 100-disk type-2 programme (35 stages, about 20,700 writes). Killed at its 12,500th write, its resume can end
    with records and stage table right but the XDMF views of 24 of its 36 frames gone from their groups' listings,
    with no call failing: the resume sets every view aside and makes the kept frames' anew."""
    scene = root / "models" / "consolidation.toml"
    whole, table = tmp_path / "whole.h5", tmp_path / "whole.csv"
    subprocess.run([grains_bin, "consolidate", scene, "--table", table, "--out", whole, *PROGRAMME], check=True,
                   capture_output=True)
    expected, rows = records(whole), stage_rows(table)
    for point in range(2500, 20000, 2500):
        killed, killed_table = tmp_path / f"killed-{point}.h5", tmp_path / f"killed-{point}.csv"
        env = dict(os.environ, KILL_AT_WRITE=str(point), LD_PRELOAD=str(kill_shim))
        run = subprocess.run([grains_bin, "consolidate", scene, "--table", killed_table, "--out", killed, *PROGRAMME],
                             env=env, capture_output=True)
        assert run.returncode == -9, (point, run.returncode)
        resumed = subprocess.run([grains_bin, "resume", killed, "--quiet"], capture_output=True, text=True)
        assert resumed.returncode == 0, (point, resumed.stderr)
        assert read_whole(killed), point
        assert stage_rows(killed_table) == rows, point
        got = records(killed)
        assert got.keys() == expected.keys(), point
        for name, (steps, values) in expected.items():
            assert np.array_equal(got[name][0], steps) and np.array_equal(got[name][1], values, equal_nan=True), (point, name)
        with h5py.File(killed, "r") as f:   # every frame has its views again
            frames = len(f["particles/all/position/value"])
            assert sorted(map(int, f["grains/xdmf/position"])) == list(range(frames)), point


def stage_rows(path):
    """The stage table's rows, the wall-clock columns aside."""
    import csv
    with open(path, newline="") as f:
        return [{k: v for k, v in row.items() if "seconds" not in k and k != "cvode_share"} for row in csv.DictReader(f)]
