"""density_correlations.py and force_distribution.py read a programme's frames through one reader
(density_correlations.read_frames), which refuses damaged frames in one line naming the file, the dataset, the value
and what is allowed (not a traceback, an exit 0 with negative cell edges, or rotated steps that take a stage's
observables from another stage)."""
import subprocess
import sys

import h5py
import numpy as np
import pytest

from conftest import ROOT
from test_density_correlations import small_stages

TOOLS = ["density_correlations.py", "force_distribution.py"]


def recreate(f, name, data):
    del f[name]
    f[name] = data


def group_for(f, name):
    del f[name]
    f.create_group(name)


DAMAGE = {   # name -> (change to the file, words the refusal must hold)
    "step_rotated": (lambda f: f["particles/all/position/step"].__setitem__(slice(None), np.roll(f["particles/all/position/step"][()], 1)),
                     ["particles/all/position/step", "not strictly increasing", "3000 at record 0, then 0"]),
    "observable_step_reversed": (lambda f: f["observables/pressure_reduced/step"].__setitem__(slice(None), f["observables/pressure_reduced/step"][()][::-1]),
                                 ["observables/pressure_reduced/step", "not strictly increasing"]),
    "observable_strings": (lambda f: recreate(f, "observables/pressure_reduced/value", np.array([b"a"] * 4)),
                           ["observables/pressure_reduced/value", "|S1", "need numbers"]),
    "observable_a_group": (lambda f: group_for(f, "observables/solid_fraction/value"),
                           ["observables/solid_fraction/value is a group", "need a dataset of numbers"]),
    "edges_zero": (lambda f: f["particles/all/box/edges/value"].__setitem__(slice(None), 0.0),
                   ["particles/all/box/edges/value holds 0.0 (frame 0, axis 0)", "finite and > 0"]),
    "edges_nan": (lambda f: f["particles/all/box/edges/value"].__setitem__((2, 1), np.nan),
                  ["particles/all/box/edges/value holds nan (frame 2, axis 1)", "finite and > 0"]),
    "edges_negative": (lambda f: f["particles/all/box/edges/value"].__setitem__(slice(None), -20.0),
                       ["particles/all/box/edges/value holds -20.0", "finite and > 0"]),
    "position_nan": (lambda f: f["particles/all/position/value"].__setitem__((1, 5, 0), np.nan),
                     ["particles/all/position/value holds nan (frame 1, particle 5)", "must be finite"]),
    "position_inf": (lambda f: f["particles/all/position/value"].__setitem__((3, 0, 1), np.inf),
                     ["particles/all/position/value holds inf (frame 3, particle 0)", "must be finite"]),
    "radius_negative": (lambda f: f["particles/all/radius/value"].__setitem__((3, 7), -1.0),
                        ["particles/all/radius/value holds -1.0 (frame 3, particle 7)", "finite and > 0"]),
    "frames_fewer": (lambda f: recreate(f, "particles/all/position/value", f["particles/all/position/value"][:2]),
                     ["particles/all/position/value holds 2 frame(s)", "position/step records 4", "killed", "grains resume"]),
}


def damaged(tmp_path, name):
    path = small_stages(tmp_path / f"{name}.h5")
    with h5py.File(path, "r+") as f:
        DAMAGE[name][0](f)
    return path


def run(tool, path, *args):
    return subprocess.run([sys.executable, str(ROOT / "runner" / tool), str(path), "--pressures", "0.01", *args,
                           "-o", str(path.with_suffix(".png")), "--table", str(path.parent / "out.csv")],
                          capture_output=True, text=True, timeout=120)


def refused(r, tool, path, words):
    assert r.returncode == 2 and "Traceback" not in r.stderr, r.stderr
    # one line says it all (argparse's usage lines above it aside)
    *usage, last = r.stderr.strip().splitlines()
    assert last.startswith(f"{tool}: error: h5: {path}: ") and all(w in last for w in words), r.stderr
    assert all(line.startswith(("usage:", " ")) for line in usage), r.stderr
    assert not (path.parent / "out.csv").exists()


@pytest.mark.parametrize("tool", TOOLS)
@pytest.mark.parametrize("name", list(DAMAGE))
def test_damaged_frames_are_refused_in_one_line(tmp_path, tool, name):
    path = damaged(tmp_path, name)
    refused(run(tool, path, *(["--scaled", "0.01"] if tool == "force_distribution.py" else [])), tool, path, DAMAGE[name][1])


def test_the_undamaged_file_is_read():
    """The reader of the tests above takes the file they damage as it is."""
    import tempfile
    import pathlib
    sys.path.insert(0, str(ROOT / "runner"))
    import density_correlations as dc
    with tempfile.TemporaryDirectory() as tmp:
        positions, radii, edges, p_star, phi = dc.read_frames(small_stages(pathlib.Path(tmp) / "s.h5"), (2, 3))
    assert positions.shape[0] == 4 and dc.loading_frame(p_star, 0.01) == 3


def test_three_columns_of_positions_in_a_2d_file_are_refused(tmp_path):
    """force_distribution.py takes 2D and 3D files: 3 position columns beside 2 cell edges ended in a broadcast error."""
    path = small_stages(tmp_path / "cols.h5")
    with h5py.File(path, "r+") as f:
        p = f["particles/all/position/value"][()]
        recreate(f, "particles/all/position/value", np.concatenate([p, p[:, :, :1]], 2))
    refused(run("force_distribution.py", path, "--scaled", "0.01"), "force_distribution.py", path,
            ["particles/all/position/value has 3 columns", "particles/all/box/edges/value 2", "2D file's positions have 2"])
    refused(run("density_correlations.py", path), "density_correlations.py", path, ["need 2D disks"])


def test_a_disk_wider_than_its_cell_is_refused_before_its_grid_is_made(tmp_path):
    """Radius 1e6 passed the memory guard (the grid itself is one point) and then asked for 241 GiB to draw one disk."""
    path = small_stages(tmp_path / "huge.h5")
    with h5py.File(path, "r+") as f:
        f["particles/all/radius/value"][...] = 1e6
    refused(run("density_correlations.py", path), "density_correlations.py", path,
            ["a disk of radius 1e+06", "GiB", "past the 4 GiB allowed"])
