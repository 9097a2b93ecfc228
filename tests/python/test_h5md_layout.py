"""The run file of `grains run` follows H5MD 1.1, its XDMF companion points at real data, and
runner/plot.py can draw it. Needs GRAINS_BIN (the built `grains` executable); skipped otherwise."""
import os
import shutil
import subprocess
import sys
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest

h5py = pytest.importorskip("h5py")

from h5text import text  # noqa: E402

REPO = Path(__file__).resolve().parents[2]
SCENE = REPO / "models" / "collision.toml"


@pytest.fixture(scope="module")
def run_file(tmp_path_factory):
    binary = os.environ.get("GRAINS_BIN")
    if not binary:
        pytest.skip("GRAINS_BIN is not set")
    out = tmp_path_factory.mktemp("h5md") / "run.h5"
    proc = subprocess.run([binary, "run", str(SCENE), "--out", str(out)], capture_output=True, text=True,
                          timeout=600)
    assert proc.returncode == 0, f"grains run failed:\n{proc.stdout}\n{proc.stderr}"
    assert out.is_file()
    return out


def test_h5md_header(run_file):
    with h5py.File(run_file, "r") as f:
        assert list(f["h5md"].attrs["version"]) == [1, 1]
        assert text(f["h5md/author"].attrs["name"])
        assert text(f["h5md/creator"].attrs["name"]) == "grains"
        assert text(f["h5md/creator"].attrs["version"])


@pytest.mark.parametrize("who", [{}, {"GRAINS_AUTHOR": "Ada Lovelace", "GRAINS_AUTHOR_EMAIL": "ada@example.org"}])
def test_h5md_author_is_the_person_not_the_program(tmp_path, who):
    """H5MD's author is whoever ran the simulation (the program is the creator); it said "grains"."""
    binary = os.environ.get("GRAINS_BIN")
    if not binary:
        pytest.skip("GRAINS_BIN is not set")
    env = {k: v for k, v in os.environ.items() if not k.startswith("GRAINS_AUTHOR")} | who
    out = tmp_path / "who.h5"
    proc = subprocess.run([binary, "run", str(SCENE), "--out", str(out), "--quiet",
                           "--set", "output.xdmf=false"], capture_output=True, text=True, timeout=120, env=env)
    assert proc.returncode == 0, proc.stderr
    with h5py.File(out, "r") as f:
        author = f["h5md/author"].attrs
        assert text(author["name"]) == who.get("GRAINS_AUTHOR", "unknown")
        assert ("email" in author) == bool(who) and (not who or text(author["email"]) == who["GRAINS_AUTHOR_EMAIL"])


def test_particle_elements(run_file):
    with h5py.File(run_file, "r") as f:
        box = f["particles/all/box"]
        dim = int(box.attrs["dimension"])
        assert dim in (2, 3)
        assert [text(b) for b in box.attrs["boundary"]] and all(
            text(b) in ("periodic", "none") for b in box.attrs["boundary"])
        assert len(box.attrs["boundary"]) == dim

        pos = f["particles/all/position"]
        frames, n, d = pos["value"].shape
        assert frames >= 1 and n >= 1 and d == dim
        for name in ("position", "velocity", "radius", "mass"):
            el = f["particles/all"][name]
            step, time = el["step"][()], el["time"][()]
            assert len(step) == len(time) == el["value"].shape[0] == frames, name
            assert np.all(np.diff(step) > 0) and np.all(np.diff(time) > 0), f"{name}: step/time not increasing"
            assert el["value"].maxshape[0] is None, f"{name}: not extendable"
        assert f["particles/all/velocity/value"].shape == (frames, n, dim)
        assert f["particles/all/radius/value"].shape == (frames, n)
        assert box["edges/value"].shape == (frames, dim)
        # particles/all/image (unwrapped = position + image * edges) only with a periodic axis, on the position's clock
        periodic = any(text(b) == "periodic" for b in box.attrs["boundary"])
        assert ("image" in f["particles/all"]) == periodic
        if periodic:
            image = f["particles/all/image"]
            assert image["value"].shape == (frames, n, dim) and image["value"].dtype == np.int64
            assert image["step"].id == pos["step"].id and image["time"].id == pos["time"].id


def test_observables(run_file):
    with h5py.File(run_file, "r") as f:
        ke = f["observables/kinetic_energy"]
        assert len(ke["step"]) == len(ke["time"]) == len(ke["value"]) > 0
        assert np.all(np.diff(ke["step"][()]) > 0)
        assert np.all(np.isfinite(ke["value"][()]))


def test_scene_is_stored(run_file):
    with h5py.File(run_file, "r") as f:
        params = f["parameters"]
        scene = text(params["scene.toml"][()]) if "scene.toml" in params else text(params.attrs["scene.toml"])
        assert "restitution" in scene


def test_xdmf_references_existing_data(run_file):
    xdmf = run_file.with_suffix(".xdmf")
    assert xdmf.is_file()
    root = ET.parse(xdmf).getroot()  # raises on malformed XML
    grids = root.findall(".//Grid[@GridType='Uniform']")
    assert grids, "no per-frame grids"
    refs = [item for item in root.iter("DataItem") if item.get("Format") == "HDF"]
    assert refs, "no HDF5 references"
    with h5py.File(run_file, "r") as f:
        for item in refs:
            filename, _, dataset = item.text.strip().partition(":")
            assert (xdmf.parent / filename).is_file(), f"{filename} is not beside the .xdmf"
            assert dataset in f, f"{dataset} missing from {run_file.name}"
            dims = tuple(int(x) for x in item.get("Dimensions").split())
            assert dims == f[dataset].shape, f"{dataset}: XDMF says {dims}, file has {f[dataset].shape}"


def test_plot_makes_png(run_file, tmp_path):
    pytest.importorskip("matplotlib")
    png = tmp_path / "observables.png"
    proc = subprocess.run([sys.executable, str(REPO / "runner" / "plot.py"), str(run_file), "-o", str(png)],
                          capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr
    assert str(png) in proc.stdout
    assert png.is_file() and png.stat().st_size > 0


def test_box_step_and_time_are_the_positions(run_file):
    """H5MD 1.1: the box's step and time must be hard links to those of the position."""
    with h5py.File(run_file, "r") as f:
        position, box = f["particles/all/position"], f["particles/all/box"]
        for name in box:
            for part in ("step", "time"):
                assert box[name][part].id == position[part].id, f"box/{name}/{part} is not position/{part}"
            assert box[name]["value"].shape[0] == position["value"].shape[0]


@pytest.mark.parametrize("own_clock", [False, True], ids=["linked", "written-before-the-links"])
def test_a_resumed_run_keeps_one_clock_for_the_box(run_file, tmp_path, own_clock):
    """A run killed after its last checkpoint resumes to the unbroken run's box rows, its box steps still the
    position's; a file whose box has its own step and time (grains before the links) goes on appending to them."""
    binary = os.environ["GRAINS_BIN"]
    scene = REPO / "models" / "collision-2d.toml"
    args = ["--set", "output.snapshots_every=50", "--set", "output.checkpoint_every=200", "--quiet"]
    whole, killed = tmp_path / "whole.h5", tmp_path / "killed.h5"
    assert subprocess.run([binary, "run", str(scene), "--out", str(whole), *args], capture_output=True).returncode == 0
    shutil.copy(whole, killed)
    with h5py.File(killed, "r+") as f:
        f["grains"].attrs["status"] = "running"
        if own_clock:
            for name in f["particles/all/box"]:
                for part in ("step", "time"):
                    values = f[f"particles/all/box/{name}/{part}"][()]
                    del f[f"particles/all/box/{name}/{part}"]
                    f[f"particles/all/box/{name}"].create_dataset(part, data=values, maxshape=(None,), chunks=(64,))
    resumed = subprocess.run([binary, "resume", str(killed), "--quiet"], capture_output=True, text=True)
    assert resumed.returncode == 0, resumed.stderr
    with h5py.File(whole, "r") as a, h5py.File(killed, "r") as b:
        for name in a["particles/all/box"]:
            for part in ("step", "time", "value"):
                element = f"particles/all/box/{name}/{part}"
                assert np.array_equal(a[element][()], b[element][()]), element
            shared = b[f"particles/all/box/{name}/step"].id == b["particles/all/position/step"].id
            assert shared != own_clock
