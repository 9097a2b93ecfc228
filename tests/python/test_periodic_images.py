"""particles/all/image (H5MD 1.1): in a run with a periodic axis, position + image * box edges frame by frame
are the particles' unwrapped positions, continuous however often they cross the cell, also while the barostat
moves it; a resumed run writes the unbroken run's images; a run without a periodic axis has no image element."""
import shutil

import h5py
import numpy as np
import pytest

from interrupt import interrupted, run

# A hot, nearly elastic gas of 324 disks in a cell some 30 diameters wide; with `squeezed`, the barostat
# compresses the cell while the particles cross it.
GAS = """
[scene]
dimension = 2
[particles]
layout = "lattice"
count = 324
solid_fraction = 0.3
velocity = "gaussian"
kinetic_energy = 6.0
seed = 11
[box]
periodic = true
[contact]
restitution = 0.98
duration = 0.05
[time]
steps = 30000
[output]
observables_every = 500
snapshots_every = 50
checkpoint_every = 10000
[run]
threads = 1
"""
SQUEEZE = """
[cell]
enabled = true
force_unit = 0
pressure = 2e-3
"""


def gas_run(grains_bin, tmp_path, name, squeezed=False, *options):
    scene = tmp_path / f"{name}.toml"
    scene.write_text(GAS + (SQUEEZE if squeezed else ""))
    out = tmp_path / f"{name}.h5"
    done = run(grains_bin, "run", scene, "--out", out, "--quiet", "--set", "output.xdmf=false", *options)
    assert done.returncode == 0, done.stderr
    return out


def frames(path):
    """(time, position, image, velocity, edges, offset) of every frame."""
    with h5py.File(path) as f:
        p = f["particles/all"]
        return (p["position/time"][()], p["position/value"][()], p["image/value"][()], p["velocity/value"][()],
                p["box/edges/value"][()], p["box/offset/value"][()])


@pytest.mark.parametrize("squeezed", [False, True], ids=["fixed cell", "barostat"])
def test_position_plus_image_times_edges_is_continuous(grains_bin, tmp_path, squeezed):
    t, x, image, v, edges, offset = frames(gas_run(grains_bin, tmp_path, "gas", squeezed))
    assert image.dtype == np.int64 and image.shape == x.shape
    unwrapped = x + image * edges[:, None, :]
    # The most a particle can move between frames: its speed (the fastest at either end, with room for the
    # collisions between) over the frames' interval, plus the cell's affine flow.
    dt = np.diff(t)[:, None, None]
    speed = np.maximum(np.abs(v[1:]), np.abs(v[:-1])).max()
    flow = np.abs(edges[1:] / edges[:-1] - 1)[:, None, :] * np.abs(unwrapped[:-1] - offset[:-1, None, :])
    allowed = 2 * speed * dt + flow
    assert allowed.max() < 0.1 * edges.min()   # the bound can tell a crossing from a move
    move = np.abs(np.diff(unwrapped, axis=0))
    assert np.all(move <= allowed), f"an unwrapped position jumped by {move.max()} (allowed {allowed.max()})"
    wrapped_jumps = np.abs(np.diff(x, axis=0)) > edges[:-1, None, :] / 2
    crossings = np.diff(image, axis=0) != 0
    assert np.array_equal(wrapped_jumps, crossings)   # every crossing shows as a jump of the wrapped position
    assert crossings.sum() > 2 * x.shape[1] and (np.abs(image[-1]) > 0).any()
    if squeezed:
        assert edges[-1, 0] < 0.98 * edges[0, 0]   # the cell moved while the particles crossed it
    else:
        assert np.all(edges == edges[0])


def test_image_is_on_the_positions_clock(grains_bin, tmp_path):
    out = gas_run(grains_bin, tmp_path, "gas", False, "--set", "time.steps=200")
    with h5py.File(out) as f:
        position, image = f["particles/all/position"], f["particles/all/image"]
        for part in ("step", "time"):
            assert image[part].id == position[part].id, f"image/{part} is not position/{part}"
        assert image["value"].shape == position["value"].shape
        assert image["value"].maxshape[0] is None


def test_an_open_box_has_no_image(grains_bin, root, tmp_path):
    out = tmp_path / "collision.h5"
    assert run(grains_bin, "run", root / "models/collision.toml", "--out", out, "--quiet").returncode == 0
    with h5py.File(out) as f:
        assert "image" not in f["particles/all"]


def images(path):
    with h5py.File(path) as f:
        return {part: f[f"particles/all/image/{part}"][()] for part in ("step", "time", "value")}


def killed_copy(whole, killed):
    """A copy of a finished run's file as a run killed after its last checkpoint leaves it, its images after that
    checkpoint spoiled (a resume that kept them would show)."""
    shutil.copy(whole, killed)
    with h5py.File(killed, "r+") as f:
        f["grains"].attrs["status"] = "running"
        slots = [f[f"grains/checkpoint_{k}"] for k in (0, 1)]
        last = int(max(s.attrs["step"] for s in slots))
        later = f["particles/all/image/step"][()] > last
        assert later.any()
        spoiled = f["particles/all/image/value"][()]
        spoiled[later] = 0
        f["particles/all/image/value"][...] = spoiled
    return killed


@pytest.mark.parametrize("squeezed", [False, True], ids=["fixed cell", "barostat"])
def test_a_killed_run_resumes_to_the_unbroken_runs_images(grains_bin, tmp_path, squeezed):
    whole = gas_run(grains_bin, tmp_path, "gas", squeezed)
    killed = killed_copy(whole, tmp_path / "killed.h5")
    resumed = run(grains_bin, "resume", killed, "--quiet")
    assert resumed.returncode == 0, resumed.stderr
    a, b = images(whole), images(killed)
    for part in a:
        assert np.array_equal(a[part], b[part]), part
    assert (a["value"][-1] != 0).any()
    with h5py.File(killed) as f:   # still one clock
        assert f["particles/all/image/step"].id == f["particles/all/position/step"].id


def test_a_run_stopped_by_a_signal_resumes_to_the_unbroken_runs_images(grains_bin, tmp_path):
    options = ["--set", "time.steps=400000", "--set", "output.snapshots_every=20000"]
    whole = gas_run(grains_bin, tmp_path, "whole", False, *options)
    scene = tmp_path / "whole.toml"
    stopped = tmp_path / "stopped.h5"
    code, out, err = interrupted([grains_bin, "run", scene, "--out", stopped, "--quiet", "--set", "output.xdmf=false",
                                  *options], stopped, 0.5)
    assert code == 130, "the run ended before the signal: make it longer\n" + err
    resumed = run(grains_bin, "resume", stopped, "--quiet")
    assert resumed.returncode == 0, resumed.stderr
    a, b = images(whole), images(stopped)
    for part in a:
        assert np.array_equal(a[part], b[part]), part


def test_a_file_without_images_resumes_without_them(grains_bin, tmp_path):
    """A file whose frames have no image element (grains before it) goes on without one: its frames stay aligned."""
    whole = gas_run(grains_bin, tmp_path, "gas", False)
    killed = tmp_path / "killed.h5"
    shutil.copy(whole, killed)
    with h5py.File(killed, "r+") as f:
        f["grains"].attrs["status"] = "running"
        del f["particles/all/image"]
    resumed = run(grains_bin, "resume", killed, "--quiet")
    assert resumed.returncode == 0, resumed.stderr
    with h5py.File(whole) as a, h5py.File(killed) as b:
        assert "image" not in b["particles/all"]
        for name in ("position", "velocity"):
            for part in ("step", "value"):
                element = f"particles/all/{name}/{part}"
                assert np.array_equal(a[element][()], b[element][()]), element
