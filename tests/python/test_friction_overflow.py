"""A tangential spring so stiff that |F_t|^2 overflows a double (friction.stiffness_ratio = 1e160): the Coulomb cap
would divide by sqrt(inf) and set the force to zero, friction off without a word. The force is capped at mu F_n
instead: the collision is the same as with any spring stiff enough to slide at once."""
import os
import subprocess

import h5py
import numpy as np
import pytest

# Two spheres of models/collision.toml meeting obliquely (impact parameter 0.3 d) while sliding past each other at 4
# along z, fast enough to slide through the whole contact.
OBLIQUE = ["--set", "particles.positions=[[-0.48, 0.0, 0.0], [0.48, 0.3, 0.0]]",
           "--set", "particles.velocities=[[0.5, 0.0, 2.0], [-0.5, 0.0, -2.0]]", "--set", "contact.duration=0.01",
           "--set", "friction.coefficient=0.5", "--set", "time.duration=0.05", "--set", "run.threads=1", "--quiet"]


def final_state(grains_bin, root, out, stiffness_ratio, isa):
    r = subprocess.run([str(grains_bin), "run", str(root / "models" / "collision.toml"), "--out", str(out), *OBLIQUE,
                        "--set", f"friction.stiffness_ratio={stiffness_ratio}"], capture_output=True, text=True,
                       timeout=120, env=dict(os.environ, GRAINS_PAIR_ISA=isa))
    if r.returncode != 0 and "cannot run" in r.stderr:
        pytest.skip(f"this processor cannot run the {isa} kernels")
    assert r.returncode == 0, r.stderr
    with h5py.File(out) as f:
        return f["particles/all/velocity/value"][-1], f["particles/all/angular_velocity/value"][-1]


@pytest.mark.parametrize("isa", ["portable", "avx2", "avx512"])
def test_a_spring_whose_force_squared_overflows_still_slides_at_the_coulomb_bound(grains_bin, root, tmp_path, isa):
    v, w = final_state(grains_bin, root, tmp_path / "overflowing.h5", "1e160", isa)
    v_ref, w_ref = final_state(grains_bin, root, tmp_path / "stiff.h5", "1e6", isa)
    assert v[1][2] > -1.9   # friction slowed the sliding (without it the z velocity stays -2)
    np.testing.assert_allclose(v, v_ref, rtol=0, atol=1e-12)
    np.testing.assert_allclose(w, w_ref, rtol=0, atol=1e-12)
    if isa != "portable":   # the vector kernels' overflow branch is the portable code's, bit for bit
        v_portable, w_portable = final_state(grains_bin, root, tmp_path / "portable.h5", "1e160", "portable")
        assert np.array_equal(v, v_portable) and np.array_equal(w, w_portable)
