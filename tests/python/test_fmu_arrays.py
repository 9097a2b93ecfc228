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


def test_a_read_sized_for_another_count_names_the_arrays_and_the_count():
    """fmpy sizes the arrays from the count's default when only a start value changed it (README): the
    error says which arrays hold how many values for which particles.count, not only two numbers."""
    unit = Unit(fmu_path("aggregation", 3))
    try:
        unit.initialize({"particles.count": 100, "run.threads": 1})
        refs = [unit.variables[n].valueReference for n in ("kinetic_energy", "particles.position", "particles.radius")]
        for room in (1 + 4 * 1000, 1 + 4 * 50):   # room for 1000 particles, for 50
            before = len(unit.errors())
            try:
                unit.fmu.getFloat64(refs, nValues=room)
            except Exception:
                pass
            new = unit.errors()[before:]
            assert any(f"passes {room} values for variables holding 401" in m and "particles.count = 100" in m
                       and "particles.position has 300" in m for m in new), new
        assert len(unit.fmu.getFloat64(refs, nValues=401)) == 401
    finally:
        unit.free()
