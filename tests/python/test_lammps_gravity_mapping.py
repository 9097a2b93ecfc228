"""runner/compare_lammps_gravity.py gives LAMMPS grains' aggregation law and reads LAMMPS' output with grains'
rules (no LAMMPS needed): the gravity table holds the softened force and energy, gran/hooke's gamma_n is grains'
c_n per unit reduced mass with limit_damping (the non-adhesion clamp), and the script's clusters and D_f give
back grains' own on a grains run."""
import math
import subprocess
import sys

import h5py
import numpy as np
import pytest

from conftest import ROOT

sys.path.insert(0, str(ROOT / "runner"))
sys.path.insert(0, str(ROOT / "tests" / "python"))
import compare_lammps_gravity as gravity  # noqa: E402
import head_on  # noqa: E402


def read_table(path):
    lines = path.read_text().splitlines()
    at = next(k for k, l in enumerate(lines) if l.startswith("N "))
    header = lines[at].split()
    rows = np.array([l.split() for l in lines[at + 1:] if l.strip()], dtype=float)
    return header, rows


def test_the_table_holds_softened_gravity_and_its_end_slopes(tmp_path):
    eps, mass = 0.05, 0.3
    gravity.gravity_table(tmp_path / "g.table", eps, 1e-3, 60.0, points=500, mass=mass)
    header, rows = read_table(tmp_path / "g.table")
    r, e, f = rows[:, 1], rows[:, 2], rows[:, 3]
    assert header[:2] == ["N", "500"] and header[2] == "FPRIME"
    assert np.array_equal(rows[:, 0], np.arange(1, 501))
    assert r[0] == pytest.approx(1e-3) and r[-1] == pytest.approx(60.0)
    gm2 = gravity.G * mass * mass
    assert np.allclose(e, -gm2 / np.sqrt(r * r + eps * eps), rtol=1e-15, atol=0)
    assert np.allclose(f, -gm2 * r / (r * r + eps * eps) ** 1.5, rtol=1e-15, atol=0)   # attractive: F < 0
    assert np.allclose(f[1:-1], -np.gradient(e, r)[1:-1], rtol=1e-3)                      # F = -dE/dr
    for end, slope in ((r[0], float(header[3])), (r[-1], float(header[4]))):
        h = 1e-6 * end
        force = lambda x: -gm2 * x / (x * x + eps * eps) ** 1.5
        assert slope == pytest.approx((force(end + h) - force(end - h)) / (2 * h), rel=1e-6)


def test_lammps_runs_grains_calibration_with_the_non_adhesion_clamp():
    kn, cn, m_star = gravity.kn_cn()
    e, tc = gravity.E, gravity.TC
    assert kn == pytest.approx(0.5 * (math.pi ** 2 + math.log(e) ** 2) / tc ** 2, rel=1e-15)
    script = gravity.lammps_script("c.data", "c.table", gravity.DT, 10, (kn, cn / m_star, True), 5)
    words = next(l for l in script.splitlines() if l.startswith("pair_style")).split()
    at = words.index("gran/hooke")
    assert float(words[at + 1]) == kn                                    # k_n, not scaled by the reduced mass
    assert float(words[at + 3]) == pytest.approx(-2 * math.log(e) / tc, rel=1e-15)   # gamma_n = c_n / m*
    assert words[at + 7] == "limit_damping"
    assert f"table spline {gravity.TABLE_POINTS}" in script
    assert "boundary s s s" in script
    # The clamped law's realised restitution, which LAMMPS with limit_damping converges to.
    assert gravity.clamped_restitution(e) == pytest.approx(head_on.clamped_restitution(e), rel=1e-14)
    assert gravity.clamped_restitution(0.05) == pytest.approx(head_on.clamped_restitution(0.05), rel=1e-14)


def test_the_scene_stiffness_is_the_one_given_to_lammps(grains_bin, tmp_path):
    out = tmp_path / "a.h5"
    subprocess.run([grains_bin, "run", gravity.SCENE, "--quiet", "--out", out, "--set", "time.steps=0"], check=True)
    with h5py.File(out) as f:
        k_star = f["observables/normalised_stiffness/value"][-1]
    k_g = gravity.G / (4 * (gravity.DIAMETER / 2) ** 3)   # G m^2 / (4 R^3)
    assert k_star * k_g == pytest.approx(gravity.kn_cn()[0], rel=1e-12)


def test_the_scripts_clusters_and_fractal_dimension_are_grains(grains_bin, tmp_path):
    """After 1.1 t_ff the scene's cloud holds aggregates of every size: the script's rule on grains' last
    positions must give grains' cluster count, largest fraction and D_f."""
    out = tmp_path / "a.h5"
    subprocess.run([grains_bin, "run", gravity.SCENE, "--quiet", "--out", out, "--set", "time.free_fall_times=1.1",
                    "--set", "run.threads=1", "--set", "output.xdmf=false"], check=True)
    with h5py.File(out) as f:
        x = f["particles/all/position/value"][-1]
        o = f["observables"]
        count, largest, df = (o[k]["value"][-1] for k in ("cluster_count", "largest_cluster_fraction", "fractal_dimension"))
        first = f["particles/all/position/value"][0]
        t_ff = o["free_fall_time/value"][0]
    sizes, labels = gravity.clusters(x)
    assert 1 < len(sizes) < len(x) - 10          # a state with clusters, not all or none
    assert len(sizes) == count
    assert sizes.max() / len(x) == largest
    assert gravity.fractal_dimension(x[labels == np.argmax(sizes)]) == pytest.approx(df, rel=1e-12)
    assert gravity.free_fall_time(first) == pytest.approx(t_ff, rel=1e-12)
