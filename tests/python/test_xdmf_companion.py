"""The .xdmf beside a run's file names, for every frame, plain datasets of that frame (no HyperSlab items: ParaView
5.11's Xdmf3 readers read none, and showed a 3D run with no points and crashed on a 2D one), with the polyvertex
connectivity written out (the Xdmf3 readers make no cells without it), positions and velocities as three components
(z = 0 in 2D), each equal to its row of the H5MD file; a resumed run's companion names its own frames only."""
import shutil
import xml.etree.ElementTree as ET

import h5py
import numpy as np
import pytest

from interrupt import run


def frames(xdmf):
    """(time, {array name: (dataset path, shape)}) per frame; the geometry is 'position', the topology 'vertices'."""
    root = ET.parse(xdmf).getroot()
    assert not [i for i in root.iter("DataItem") if i.get("ItemType") not in (None, "Uniform")], "a non-plain DataItem"
    out = []
    for grid in root.iter("Grid"):
        if grid.get("GridType") != "Uniform":
            continue
        arrays = {}
        for tag, name in (("Topology", "vertices"), ("Geometry", "position")):
            element = grid.find(tag)
            arrays[name] = element.find("DataItem")
            assert arrays[name] is not None, f"{tag} without a DataItem"
        assert grid.find("Geometry").get("GeometryType") == "XYZ"
        for attribute in grid.findall("Attribute"):
            arrays[attribute.get("Name")] = attribute.find("DataItem")
        refs = {}
        for name, item in arrays.items():
            assert item.get("Format") == "HDF", name
            file_name, _, dataset = item.text.strip().partition(":")
            refs[name] = (file_name, dataset, tuple(int(n) for n in item.get("Dimensions").split()))
        out.append((float(grid.find("Time").get("Value")), refs))
    return out


def assert_companion_shows_the_file(h5, expect_arrays):
    with h5py.File(h5) as f:
        listed = frames(h5.with_suffix(".xdmf"))
        times = f["particles/all/position/time"][()]
        assert len(listed) == len(times)
        for k, (time, refs) in enumerate(listed):
            assert time == times[k]
            assert set(refs) == expect_arrays
            for name, (file_name, dataset, dims) in refs.items():
                assert file_name == h5.name
                data = f[dataset][()]
                assert data.shape == dims, (k, name)
                if name == "vertices":
                    assert np.array_equal(data, np.arange(dims[0]))
                    continue
                row = f[f"particles/all/{name}/value"][k]
                if row.ndim == 2 and row.shape[1] < 3:   # a 2D vector, shown in three components
                    assert np.all(data[:, row.shape[1]:] == 0), (k, name)
                    data = data[:, :row.shape[1]]
                assert np.array_equal(data, row), (k, name)


@pytest.mark.parametrize("scene, arrays", [
    ("collision.toml", {"vertices", "position", "radius", "mass", "velocity", "angular_velocity"}),
    ("collision-2d.toml", {"vertices", "position", "radius", "mass", "velocity", "angular_velocity"}),
])
def test_every_array_is_a_plain_dataset_of_its_frame(grains_bin, root, tmp_path, scene, arrays):
    out = tmp_path / "run.h5"
    done = run(grains_bin, "run", root / "models" / scene, "--set", "output.snapshots_every=100", "--out", out, "--quiet")
    assert done.returncode == 0, done.stderr
    assert_companion_shows_the_file(out, arrays)


@pytest.mark.parametrize("views", ["kept", "written-before-the-views"])
def test_a_resumed_run_names_the_frames_it_wrote_again(grains_bin, root, tmp_path, views):
    """A run killed after its last checkpoint: the frames past it are dropped and written again, and so are the
    datasets the companion names for them (spoiled here, so that keeping them would show); a file from before the
    views gets them for the frames it keeps."""
    args = [root / "models/collision-2d.toml", "--set", "output.snapshots_every=50", "--set",
            "output.checkpoint_every=200", "--quiet"]
    whole = tmp_path / "whole.h5"
    assert run(grains_bin, "run", args[0], "--out", whole, *args[1:]).returncode == 0
    killed = tmp_path / "killed.h5"
    shutil.copy(whole, killed)
    with h5py.File(killed, "r+") as f:
        f["grains"].attrs["status"] = "running"
        position = f["particles/all/position"]
        position["value"][-1] = 7.0
        del f[f"grains/xdmf/velocity/{len(position['step']) - 1}"]
        if views != "kept":
            del f["grains/xdmf"]
    resumed = run(grains_bin, "resume", killed, "--quiet")
    assert resumed.returncode == 0, resumed.stderr
    assert_companion_shows_the_file(killed, {"vertices", "position", "radius", "mass", "velocity", "angular_velocity"})
    with h5py.File(whole) as a, h5py.File(killed) as b:
        assert np.array_equal(a["particles/all/position/value"][()], b["particles/all/position/value"][()])
        assert {k: len(g) for k, g in a["grains/xdmf"].items()} == {k: len(g) for k, g in b["grains/xdmf"].items()}
