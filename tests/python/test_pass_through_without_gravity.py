"""Grains passing through each other in scenes without gravity: a head-on pair at a contact time of 3 swaps sides,
which is warned about, and with 3D friction the crossing pair's tangential spring must not be turned by 0 / 0 (its
normal reversed within one step), which would stop the run with a non-finite value blamed on the initial state."""
import os
import subprocess

import h5py
import numpy as np
import pytest

# Two spheres of models/collision.toml meeting head on at 1 each: with a contact time of 300 and 1e5 steps per
# contact (dt = 0.003) the clamped spring holds nothing, and the pair crosses within one step's reach.
CROSSING = ["--set", "contact.duration=300", "--set", "time.steps_per_contact=1e5", "--set", "time.duration=6",
            "--set", "run.threads=1", "--set", "output.observables_every=10", "--quiet"]


def run(grains_bin, root, out, *extra, env=None):
    return subprocess.run([str(grains_bin), "run", str(root / "models" / "collision.toml"), "--out", str(out),
                           *CROSSING, *extra], capture_output=True, text=True, timeout=120,
                          env=dict(os.environ, **(env or {})))


def test_a_pair_passing_through_is_warned_without_gravity(grains_bin, root, tmp_path):
    r = run(grains_bin, root, tmp_path / "cross.h5")
    assert r.returncode == 0, r.stderr
    assert "warning: contact check: at t = " in r.stderr and "they are passing through each other" in r.stderr, r.stderr
    assert "raise the stiffness (a shorter contact.duration" in r.stderr
    with h5py.File(tmp_path / "cross.h5") as f:
        x = f["particles/all/position/value"][-1][:, 0]
    assert x[0] > x[1]   # they did swap sides: the warning is not a false alarm
    # The scene as shipped (contact time 0.02) warns nothing
    ok = subprocess.run([str(grains_bin), "run", str(root / "models" / "collision.toml"), "--out", str(tmp_path / "ok.h5"),
                         "--quiet"], capture_output=True, text=True, timeout=120)
    assert ok.returncode == 0 and "warning" not in ok.stderr, ok.stderr


@pytest.mark.parametrize("isa", ["portable", "avx2", "avx512"])
def test_a_frictional_pair_whose_normal_reverses_in_a_step_stays_finite_and_alike_in_every_kernel(grains_bin, root,
                                                                                                   tmp_path, isa):
    frictional = ["--set", "friction.coefficient=0.5"]   # on the axis: the normal reverses exactly
    r = run(grains_bin, root, tmp_path / f"{isa}.h5", *frictional, env={"GRAINS_PAIR_ISA": isa})
    if r.returncode != 0 and "cannot run" in r.stderr:
        pytest.skip(f"this processor cannot run the {isa} kernels")
    assert r.returncode == 0, r.stderr
    assert "passing through each other" in r.stderr
    with h5py.File(tmp_path / f"{isa}.h5") as f:
        state = [f[f"particles/all/{n}/value"][()] for n in ("position", "velocity", "angular_velocity")]
    assert all(np.isfinite(s).all() for s in state)
    if isa != "portable":
        portable = tmp_path / "portable-reference.h5"
        assert run(grains_bin, root, portable, *frictional, env={"GRAINS_PAIR_ISA": "portable"}).returncode == 0
        with h5py.File(portable) as f:
            for s, n in zip(state, ("position", "velocity", "angular_velocity")):
                assert np.array_equal(s, f[f"particles/all/{n}/value"][()]), n


def test_the_adhesive_law_gets_its_own_advice(grains_bin, root, tmp_path):
    """The cohesionless reference (the adhesive law with F0 = 0) is told adhesion.stiffness, not to shorten
    contact.duration, a key that law does not read."""
    scene = tmp_path / "deep.toml"
    scene.write_text('[scene]\nname = "deep"\ndimension = 2\n[particles]\nlayout = "list"\n'
                     'positions = [[5.0, 5.0], [5.2, 5.0]]\ndiameter = 1.0\nmass = 1.0\n[box]\nlengths = [10.0, 10.0]\n'
                     'periodic = true\n[adhesion]\nenabled = true\nforce = 0.0\n[time]\nsteps = 10\n[run]\nthreads = 1\n')
    r = subprocess.run([str(grains_bin), "run", str(scene), "--out", str(tmp_path / "deep.h5"), "--quiet"],
                       capture_output=True, text=True, timeout=60)
    assert r.returncode == 0, r.stderr
    assert "passing through each other" in r.stderr and "raise adhesion.stiffness" in r.stderr, r.stderr
    assert "contact.duration" not in r.stderr.split("contact check")[1]
