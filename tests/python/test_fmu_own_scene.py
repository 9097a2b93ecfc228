"""A user's own scene packaged as an FMU (fmu/package_fmu.cmake, what `-DGRAINS_FMU_SCENES=...` runs): its particle file
travels in resources/, without which the FMU cannot be instantiated."""
import os
import pathlib
import subprocess
import zipfile

import h5py
import pytest

from fmu_host import Unit

SCENE = """[scene]
name = "rows"
description = "Two spheres from a particle file, colliding head-on"
dimension = 3

[particles]
layout = "file"
file = "{file}"

[box]
periodic = false

[contact]
restitution = 0.5
duration = 0.1

[time]
steps_per_contact = 50
duration = 0.5
"""
ROWS = "# x y z diameter mass vx vy vz\n-0.6 0 0 1 1 0.5 0 0\n0.6 0 0 1 1 -0.5 0 0\n"


def package(build, scene, out):
    """Runs the build's packaging step for `scene`; returns the finished process."""
    fmu = build / "fmu"
    return subprocess.run(
        ["cmake", f"-DSCENE={scene}", "-DIDENTIFIER=grains_rows", "-DMODEL=rows", "-DVERSION=0",
         f"-DDESCRIBE={fmu / 'grains_fmu_describe'}", f"-DBINARY={fmu / 'grains_fmu.so'}",
         f"-DPLUGIN={fmu / 'grains_snapshots.so'}", f"-DFORK_GUARD={fmu / 'grains_fork_guard.so'}",
         f"-DSTAGE={out / 'stage' / 'rows'}", f"-DOUT={out}", "-P", str(pathlib.Path(__file__).parents[2] / "fmu" / "package_fmu.cmake")],
        capture_output=True, text=True, timeout=300)


@pytest.fixture(scope="module")
def build():
    return pathlib.Path(os.environ["GRAINS_BIN"]).resolve().parents[1]


def test_a_scene_with_a_particle_file_is_packaged_with_it(build, grains_bin, tmp_path):
    (tmp_path / "my data").mkdir()   # a space, which the depfile escapes for make
    (tmp_path / "my data" / "rows.txt").write_text(ROWS)
    scene = tmp_path / "rows.toml"
    scene.write_text(SCENE.format(file="my data/rows.txt"))
    r = package(build, scene, tmp_path / "out")
    assert r.returncode == 0, r.stderr
    for version in (2, 3):
        path = tmp_path / "out" / f"fmi{version}" / "rows.fmu"
        with zipfile.ZipFile(path) as z:
            assert z.read("resources/my data/rows.txt").decode() == ROWS
        unit = Unit(path)
        unit.initialize({})
        for _ in range(50):
            unit.step(0.01)
        fmu_energy = unit.get("kinetic_energy")
        unit.free()
        # the runner's run of the same scene, at the same time
        subprocess.run([grains_bin, "run", str(scene), "--out", str(tmp_path / f"run{version}.h5"), "--quiet"],
                       check=True, cwd=tmp_path)
        with h5py.File(tmp_path / f"run{version}.h5") as f:
            k = f["observables/kinetic_energy"]
            assert fmu_energy == k["value"][-1] and k["time"][-1] == pytest.approx(0.5)
        assert 0 < fmu_energy < 0.25   # a collision with e = 0.5 has happened (K was 0.25)
    assert (tmp_path / "out" / "stage" / "rows.d").read_text().strip().endswith("/my\\ data/rows.txt")


@pytest.mark.parametrize("where", ["../rows.txt", "ABSOLUTE"])
def test_a_particle_file_outside_the_scene_folder_is_refused_at_packaging(build, tmp_path, where):
    (tmp_path / "scene").mkdir()
    (tmp_path / "rows.txt").write_text(ROWS)
    scene = tmp_path / "scene" / "rows.toml"
    scene.write_text(SCENE.format(file=str(tmp_path / "rows.txt") if where == "ABSOLUTE" else where))
    r = package(build, scene, tmp_path / "out")
    assert r.returncode != 0
    assert "particles.file" in r.stderr and "relative path inside the scene's folder" in r.stderr, r.stderr
    assert not (tmp_path / "out" / "fmi2" / "rows.fmu").exists()
