"""fmpy.simulate_fmu on the real .fmu files gives the runner's numbers: the same observables, bit for
bit, at the same steps, for the packaged parameters and with overrides, in FMI 2 and FMI 3."""
import subprocess

import fmpy
import h5py
import numpy as np
import pytest

from fmu_host import Unit, fmu_path

# (model, parameter overrides, internal steps per communication step, communication steps)
CASES = [
    ("aggregation", {}, 20, 5),   # packaged parameters (1000 particles, 2 threads)
    ("aggregation", {"particles.count": 300, "contact.restitution": 0.3, "gravity.G": 2.0, "run.threads": 1}, 25, 8),
    # an enumeration: the text key's item by its value (the tree, gravity.solver = "tree" in the runner)
    ("aggregation", {"particles.count": 300, "gravity.solver": 2, "run.threads": 1}, 20, 5),
    ("collision", {}, 10, 10),
    ("collision", {"contact.restitution": 0.8, "contact.duration": 0.5}, 7, 12),
    ("consolidation", {"particles.count": 300, "cell.pressure": 0.5}, 50, 6),
]
# Wall-clock measurements (cvode_seconds) are outputs too, but no two runs share them.
WALL_CLOCK = ("_seconds",)


def toml(value):
    return str(value).lower() if isinstance(value, bool) else repr(value)


def runner_observables(grains_bin, root, tmp_path, model, overrides, every, chunks, items=None):
    """`items`: each enumeration's values' names, which the runner's scene takes as text."""
    items = items or {}
    out = tmp_path / f"{model}.h5"
    sets = [a for k, v in overrides.items() for a in ("--set", f'{k}="{items[k][v]}"' if k in items else f"{k}={toml(v)}")]
    subprocess.run([grains_bin, "run", root / "models" / f"{model}.toml", *sets, "--set", f"time.steps={every * chunks}",
                    "--set", f"output.observables_every={every}", "--set", "output.snapshots_every=0",
                    "--out", out, "--quiet"], check=True, capture_output=True)
    with h5py.File(out) as f:
        return {name: (f[f"observables/{name}/step"][()], f[f"observables/{name}/value"][()])
                for name in f["observables"]}


@pytest.mark.parametrize("version", [2, 3])
@pytest.mark.parametrize("model,overrides,every,chunks", CASES, ids=["aggregation", "aggregation-overrides", "aggregation-tree",
                                                                     "collision", "collision-overrides", "consolidation"])
def test_fmu_outputs_equal_the_runner_observables(grains_bin, root, tmp_path, version, model, overrides, every, chunks):
    path = str(fmu_path(model, version))
    md = fmpy.read_model_description(path)
    outputs = [v.name for v in md.modelVariables if v.causality == "output" and not v.dimensions]
    # dt as the FMU itself reports it (a calculated parameter), so the host's step is exactly `every` steps
    unit = Unit(path).initialize(overrides)
    dt = unit.get("time.dt")
    unit.free()

    result = fmpy.simulate_fmu(path, start_values=overrides, stop_time=every * chunks * dt, output_interval=every * dt,
                               output=outputs)
    items = {v.name: {int(i.value): i.name for i in v.declaredType.items} for v in md.modelVariables if v.type == "Enumeration"}
    runner = runner_observables(grains_bin, root, tmp_path, model, overrides, every, chunks, items)

    assert list(result["step"]) == [every * k for k in range(chunks + 1)]
    compared = 0
    for name in outputs:
        if name == "step" or name.endswith(WALL_CLOCK):
            continue
        assert name in runner, f"the FMU output {name} is not a runner observable"
        steps, values = runner[name]
        assert list(steps) == list(result["step"]), name
        np.testing.assert_array_equal(result[name], values, err_msg=f"{name} differs from the runner")
        compared += 1
    assert compared >= 15
    assert set(runner) <= set(outputs), f"runner observables the FMU lacks: {set(runner) - set(outputs)}"
