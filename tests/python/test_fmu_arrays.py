"""FMI 3 per-particle arrays: sized by the structural parameter particles.count (set in configuration
mode), and equal to the runner's particle snapshot."""
import subprocess

import h5py
import numpy as np

from fmu_host import Unit, fmu_path


def test_structural_particle_count_sizes_the_arrays():
    unit = Unit(fmu_path("aggregation", 3))
    assert len(unit.get("particles.radius")) == 1000
    unit.fmu.enterConfigurationMode()
    unit.set("particles.count", 150)
    unit.fmu.exitConfigurationMode()
    unit.initialize({"run.threads": 1})
    unit.step(5 * unit.get("time.dt"))
    assert len(unit.get("particles.radius")) == 150
    assert np.array(unit.get("particles.position")).shape == (450,)
    unit.free()


def test_arrays_equal_the_runner_snapshot(grains_bin, root, tmp_path):
    out = tmp_path / "c.h5"
    subprocess.run([grains_bin, "run", root / "models" / "collision.toml", "--set", "time.steps=70", "--out", out,
                    "--quiet"], check=True, capture_output=True)
    with h5py.File(out) as f:
        position = f["particles/all/position/value"][-1]
        radius = f["particles/all/radius/value"][-1] if f["particles/all/radius"].__class__ is h5py.Group \
            else f["particles/all/radius"][()]
    unit = Unit(fmu_path("collision", 3)).initialize()
    unit.step(70 * unit.get("time.dt"))
    assert unit.get("step") == 70
    np.testing.assert_array_equal(np.array(unit.get("particles.position")).reshape(-1, 3), position)
    np.testing.assert_array_equal(unit.get("particles.radius"), np.ravel(radius))
    unit.free()
