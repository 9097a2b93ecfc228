"""Optional HDF5 snapshots from inside the FMU (fmu.snapshots_every), through the plugin library that is
loaded only when asked for: the runner's H5MD layout and numbers; a clear error when the plugin is absent."""
import os
import shutil
import subprocess

import h5py
import numpy as np
import pytest

from fmu_host import Unit, _extracted, extracted, fmu_path, host_process


@pytest.mark.parametrize("version", [2, 3])
def test_snapshots_equal_the_runner_frames(grains_bin, root, tmp_path, monkeypatch, version):
    monkeypatch.chdir(tmp_path)
    subprocess.run([grains_bin, "run", root / "models" / "collision.toml", "--set", "time.steps=30", "--set",
                    "output.snapshots_every=10", "--out", tmp_path / "runner.h5", "--quiet"], check=True, capture_output=True)
    unit = Unit(fmu_path("collision", version), name="snap")
    unit.initialize({"fmu.snapshots_every": 10})
    for _ in range(6):
        unit.step(5 * unit.get("time.dt"))
    unit.free()
    with h5py.File(tmp_path / "snap.h5") as fmu, h5py.File(tmp_path / "runner.h5") as runner:
        for field in ("position", "velocity"):
            np.testing.assert_array_equal(fmu[f"particles/all/{field}/value"][()], runner[f"particles/all/{field}/value"][()])
        np.testing.assert_array_equal(fmu["particles/all/position/step"][()], [0, 10, 20, 30])
    assert (tmp_path / "snap.xdmf").exists()


@pytest.mark.parametrize("version", [2, 3])
def test_instance_name_that_is_not_a_file_name_is_made_one_in_the_working_directory(tmp_path, monkeypatch, version):
    """The snapshots go to <instance name>.h5 in the working directory: "../snap" would write beside it, so it is made
    a plain file name there, and the host told which: a host that names its instances by the FMU's path (Ecos) takes
    snapshots too."""
    work = tmp_path / "work"
    work.mkdir()
    monkeypatch.chdir(work)
    for name, file in (("../snap", "_._snap"), ("/opt/models/fmi2/collision.fmu", "_opt_models_fmi2_collision.fmu"),
                       ("/" + "d" * 120 + "/a b.fmu", "d" * 92 + "_a_b.fmu")):
        unit = Unit(fmu_path("collision", version), name=name)
        unit.initialize({"fmu.snapshots_every": 10})
        assert any(f'instance name "{name}" is not a plain file name' in m and f'they go to "{file}.h5"' in m
                   for m in unit.warnings()), unit.warnings()
        for _ in range(3):
            unit.step(10 * unit.get("time.dt"))
        unit.free()
        with h5py.File(work / f"{file}.h5") as f:
            assert f["particles/all/position/step"][()].tolist() == [0, 10, 20, 30]
    assert sorted(p.name for p in tmp_path.rglob("*") if p.parent != work) == ["work"]   # nothing outside it


@pytest.mark.parametrize("version", [2, 3])
def test_missing_plugin_is_a_clear_error(tmp_path, monkeypatch, version):
    monkeypatch.chdir(tmp_path)
    path = fmu_path("collision", version)
    copy = tmp_path / "no-plugin"
    shutil.copytree(extracted(path), copy)
    for platform in ("linux64", "x86_64-linux"):
        plugin = copy / "binaries" / platform / "grains_snapshots.so"
        if plugin.exists():
            os.remove(plugin)
    shutil.copy(path, str(copy) + ".fmu")
    _extracted[str(copy) + ".fmu"] = str(copy)
    unit = Unit(str(copy) + ".fmu")
    with pytest.raises(Exception):
        unit.initialize({"fmu.snapshots_every": 5})
    assert any("grains_snapshots.so" in m and "HDF5" in m for m in unit.errors()), unit.errors()
    unit.reset()
    unit.initialize()   # without snapshots the FMU runs
    unit.step(0.1)
    unit.free()


@pytest.mark.parametrize("version", [2, 3])
def test_snapshots_of_a_periodic_cell_carry_images_that_a_state_keeps(tmp_path, monkeypatch, version):
    """The consolidation FMU's cell is periodic: its snapshots hold particles/all/image on the position's clock,
    and an instance continuing from another's serialized state writes the same images as the other."""
    monkeypatch.chdir(tmp_path)
    start = {"particles.count": 200, "fmu.snapshots_every": 500}
    first = Unit(fmu_path("consolidation", version), name="first").initialize(start)
    h = 1000 * first.get("time.dt")
    for _ in range(5):
        first.step(h)
    state, t0 = first.serialize(first.get_state()), first.time
    for _ in range(5):
        first.step(h)
    first.free()
    second = Unit(fmu_path("consolidation", version), name="second").initialize(start)
    second.set_state(second.deserialize(state))
    second.time = t0
    for _ in range(5):
        second.step(h)
    second.free()
    with h5py.File(tmp_path / "first.h5") as a, h5py.File(tmp_path / "second.h5") as b:
        for f in (a, b):
            assert f["particles/all/image/step"].id == f["particles/all/position/step"].id
        last = a["particles/all/position/step"][-1]
        assert b["particles/all/position/step"][-1] == last
        for field in ("image", "position"):
            np.testing.assert_array_equal(a[f"particles/all/{field}/value"][-1], b[f"particles/all/{field}/value"][-1])
        assert (a["particles/all/image/value"][-1] != 0).any()   # some particles crossed the cell by then


FILE_SIZE_LIMIT_HOST = r"""
import resource, signal, sys
from fmu_host import Unit, fmu_path
version = int(sys.argv[1])
signal.signal(signal.SIGXFSZ, signal.SIG_IGN)   # a write past the limit fails with EFBIG, as on a full disk
unit = Unit(fmu_path("consolidation", version), name="limited")   # unpacked before the limit
resource.setrlimit(resource.RLIMIT_FSIZE, (700_000, 700_000))
try:
    unit.initialize({"fmu.snapshots_every": 1, "particles.count": 200})
    for _ in range(400):
        unit.step(unit.get("time.dt"))
    print("no write failed")
except Exception:
    print("refused:", " | ".join(unit.errors()))
unit.fmu.terminate()
unit.fmu.freeInstance()
print("freed")
"""


@pytest.mark.parametrize("version", [2, 3])
def test_a_failed_snapshot_write_is_an_error_and_the_host_exits_cleanly(tmp_path, version):
    """A write that fails (here a file-size limit, as a full disk does) is an Error naming the file; the host then
    terminates and frees the instance, and exits cleanly (not SIGSEGV in HDF5's exit handler)."""
    r = host_process(FILE_SIZE_LIMIT_HOST, version, timeout=120, cwd=tmp_path)
    assert r.returncode == 0, (r.returncode, r.stdout, r.stderr)
    assert "refused:" in r.stdout and "limited.h5" in r.stdout and r.stdout.rstrip().endswith("freed"), r.stdout
