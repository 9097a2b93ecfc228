"""The runner and the FMUs run on any x86-64 processor, shown on processors QEMU emulates: the x86-64 baseline
(qemu64: SSE2 and SSE3, nothing wider), an x86-64-v2 without AVX (Nehalem; fmpy's NumPy needs v2) and a
Haswell (AVX2 and FMA, no AVX-512). QEMU stops a program with SIGILL at any instruction the emulated
processor lacks, so a run that finishes there executed none.

Each emulated run must also end where a run on this machine ends with the same code, bit for bit:
GRAINS_PAIR_ISA and GRAINS_GRAVITY_ISA hold the engine's vector code to the emulated processor's, and
glibc.cpu.hwcaps holds glibc's libm to its variants without FMA where the emulated processor has none (its FMA
builds of log, exp, sin and pow differ from the others in the last bit now and then: one of consolidation-rr's
1400 initial velocities differs by 3.5e-18 without the setting). The Haswell runs also compare the
integrator's AVX2 loops, which only a processor without AVX-512 picks, with this machine's AVX-512 ones.
"""
import json
import os
import pathlib
import shutil
import subprocess
import sys

import h5py
import numpy as np
import pytest

from fmu_host import fmu_path
from h5text import text

HERE = pathlib.Path(__file__).resolve().parent
ROOT = HERE.parents[1]
QEMU = shutil.which("qemu-x86_64")
WITHOUT_FMA = "glibc.cpu.hwcaps=-AVX,-AVX2,-FMA,-FMA4"   # glibc's libm as a processor without AVX gets it

pytestmark = pytest.mark.skipif(os.uname().machine != "x86_64", reason="the emulated processors are x86-64 ones")

# The emulated processor, the engine's vector code it runs, and the glibc setting that gives this machine's libm
# the same variants.
PROCESSORS = {
    "qemu64": ("portable", WITHOUT_FMA),
    "Nehalem": ("portable", WITHOUT_FMA),
    "Haswell": ("avx2", None),
}


def dense_disks(folder):
    """400 cohesive unit disks on a hexagonal lattice, each pressed 5e-4 into its six neighbours, with friction
    and rolling resistance in a pressure-controlled cell: the steady-contact kernels, their caps and CVODE."""
    a, nx, ny = 0.9995, 20, 20
    rng = np.random.default_rng(7)
    rows = []
    for j in range(ny):
        for i in range(nx):
            vx, vy = rng.standard_normal(2) * 0.01
            rows.append(f"{(i + 0.5 * (j % 2)) * a:.17g} {j * a * np.sqrt(3) / 2:.17g} 1 1 {vx:.17g} {vy:.17g}")
    (folder / "disks.txt").write_text("\n".join(rows) + "\n")
    scene = folder / "dense-disks.toml"
    scene.write_text(f"""[scene]
name = "dense-disks"
dimension = 2
[particles]
layout = "file"
file = "{folder / 'disks.txt'}"
[box]
lengths = [{nx * a:.17g}, {ny * a * np.sqrt(3) / 2:.17g}]
[adhesion]
enabled = true
[friction]
coefficient = 0.5
[rolling]
coefficient = 0.005
[cell]
enabled = true
pressure = 1.0
""")
    return scene


# Scenes, run lengths and settings: self-gravity with 3D contacts (the default scene), a frictional gas of
# spheres with rotations, and dense cohesive disks. Short: QEMU runs them 10-300 times slower, the AVX2
# gravity kernel slowest.
SCENES = {
    "aggregation": (lambda folder: ROOT / "models" / "aggregation.toml", 10, []),
    "gas-friction": (lambda folder: ROOT / "models" / "gas-friction.toml", 100, ["particles.count=1728"]),
    "dense-disks": (dense_disks, 300, []),
}


def qemu():
    if QEMU is None:
        pytest.fail("qemu-x86_64 is missing: tests/run.sh installs Debian's qemu-user")
    return QEMU


def run_on(processor, emulated, command):
    """Runs `command` on the emulated processor, or here with the same code (the engine's vector code capped, and
    glibc's libm held to the processor's variants); fails the test unless it succeeds. Returns its stdout."""
    isa, libm = PROCESSORS[processor]
    env = dict(os.environ, GRAINS_PAIR_ISA=isa, GRAINS_GRAVITY_ISA=isa, OMP_WAIT_POLICY="passive")
    env.pop("GLIBC_TUNABLES", None)
    if emulated:
        command = [qemu(), "-cpu", processor] + command
    elif libm:
        env["GLIBC_TUNABLES"] = libm
    done = subprocess.run(command, env=env, capture_output=True, text=True, timeout=600)
    if done.returncode != 0:
        why = "SIGILL: it executed an instruction the emulated processor lacks" if done.returncode == -4 else f"status {done.returncode}"
        pytest.fail(f"{' '.join(str(c) for c in command[:5])} ... ended with {why}:\n{done.stderr[-2000:]}")
    return done.stdout


def run_grains(grains_bin, scene, out, processor, emulated):
    make, steps, settings = SCENES[scene]
    command = [grains_bin, "run", str(make(out.parent)), "--quiet", "--out", str(out), "--set", f"time.steps={steps}",
               "--set", "run.threads=2", "--set", "output.xdmf=false"]
    for setting in settings:
        command += ["--set", setting]
    run_on(processor, emulated, command)
    with h5py.File(out, "r") as f:
        state = {k: f[f"particles/all/{k}/value"][-1] for k in ("position", "velocity", "angular_velocity")
                 if f"particles/all/{k}" in f}
        observables = {k: f[f"observables/{k}/value"][-1] for k in f["observables"]
                       if f[f"observables/{k}/value"].ndim == 1 and k != "cvode_seconds"}
        return state, observables, text(f["grains"].attrs["pair_loop_build"])


def this_machine_has(*flags):
    with open("/proc/cpuinfo") as f:
        have = next((line.split(":", 1)[1].split() for line in f if line.startswith("flags")), [])
    return all(flag in have for flag in flags)


@pytest.mark.parametrize("processor", list(PROCESSORS))
@pytest.mark.parametrize("scene", list(SCENES))
def test_the_runner_on_an_emulated_processor_ends_where_this_machine_does(grains_bin, tmp_path, processor, scene):
    if PROCESSORS[processor][0] == "avx2" and not this_machine_has("avx2", "fma"):
        pytest.skip("this machine has no AVX2 and FMA to compare the emulated Haswell's code with")
    emulated = run_grains(grains_bin, scene, tmp_path / "emulated.h5", processor, True)
    here = run_grains(grains_bin, scene, tmp_path / "here.h5", processor, False)
    isa = PROCESSORS[processor][0]
    assert emulated[2] == here[2] == isa, f"pair loop builds {emulated[2]} (emulated) and {here[2]} (here), wanted {isa}"
    for name, value in here[0].items():
        assert np.array_equal(emulated[0][name], value), (
            f"{scene} on {processor}: {name} differs by up to {np.abs(emulated[0][name] - value).max():.3g}")
    differ = [k for k, v in here[1].items() if not (v == emulated[1][k] or (np.isnan(v) and np.isnan(emulated[1][k])))]
    assert not differ, f"{scene} on {processor}: observables differ: {differ}"


HOST = """
import json, sys
sys.path.insert(0, sys.argv[1])
from fmu_host import Unit
unit = Unit(sys.argv[2]).initialize()
dt = unit.get("time.dt")
for _ in range(int(sys.argv[3])):
    unit.step(20 * dt)
print(json.dumps({k: float(v).hex() for k, v in unit.outputs().items()}))
unit.free()
"""


def fmu_outputs(path, chunks, processor, emulated):
    stdout = run_on(processor, emulated, [sys.executable, "-c", HOST, str(HERE), str(path), str(chunks)])
    return json.loads(stdout.splitlines()[-1])


@pytest.mark.parametrize("model,version,chunks", [("aggregation", 2, 1), ("consolidation", 3, 10)])
def test_an_fmu_on_a_processor_without_avx_gives_this_machines_outputs(grains_bin, model, version, chunks):
    path = fmu_path(model, version)
    emulated = fmu_outputs(path, chunks, "Nehalem", True)
    here = fmu_outputs(path, chunks, "Nehalem", False)
    assert emulated.keys() == here.keys() and len(here) > 5
    differ = {k: (here[k], emulated[k]) for k in here if here[k] != emulated[k] and k != "cvode_seconds"}
    assert not differ, f"{model} FMI {version} without AVX: outputs differ: {differ}"
