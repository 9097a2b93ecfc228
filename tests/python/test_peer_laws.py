"""The side-by-side scripts give LAMMPS and grains the same contact law: the LAMMPS pair style written for
the frictional gas reads back as grains' scene law, and disks2d.lmp's pair style (dampflag 0: no
tangential dashpot) as the law grains runs beside it: LAMMPS with dampflag 0 against grains' damped tangential
spring differs by 14 % in what a collision dissipates."""
import math
import sys
import tomllib

import pytest

from conftest import ROOT

sys.path.insert(0, str(ROOT / "runner"))
import bench_cohesive  # noqa: E402
import compare_lammps  # noqa: E402


def law_of(text):
    """(contact, friction) tables of scene text."""
    scene = tomllib.loads(text)
    return scene["contact"], scene["friction"]


def test_the_frictional_gas_lammps_runs_is_grains_scene_law():
    contact, friction = law_of(bench_cohesive.hooke_history_law(compare_lammps.lammps_pair_style(True)))
    gas = tomllib.loads((ROOT / "models" / "gas.toml").read_text())["contact"]
    gas_friction = tomllib.loads((ROOT / "models" / "gas-friction.toml").read_text())["friction"]
    assert contact["restitution"] == pytest.approx(gas["restitution"], rel=1e-12)
    assert contact["duration"] == pytest.approx(gas["duration"], rel=1e-12)
    for key in ("coefficient", "stiffness_ratio", "damping_ratio"):
        assert friction[key] == pytest.approx(gas_friction[key], rel=1e-12), key
    assert compare_lammps.FRICTION == gas_friction   # the script's grains side is the scene's law


def test_dampflag_zero_drops_the_tangential_dashpot_and_null_means_lammps_defaults():
    line = "pair_style gran/hooke/history 100000.0 NULL 50.0 NULL 0.5 {}"
    _, undamped = law_of(bench_cohesive.hooke_history_law(line.format(0)))
    _, damped = law_of(bench_cohesive.hooke_history_law(line.format(1)))
    assert undamped["damping_ratio"] == 0.0
    assert damped["damping_ratio"] == 0.5          # gamma_t NULL: gamma_n / 2
    assert damped["stiffness_ratio"] == pytest.approx(2 / 7, rel=1e-15)   # Kt NULL: 2/7 Kn
    assert damped["coefficient"] == 0.5


def test_disks2d_law_matches_its_stiffness_and_damping():
    """The peer file's line (or the scripts' copy where the peer inputs are absent): grains' calibration from
    (e, t_c) with m* = 1/2 gives back k_n = 1e5 and c_n = m* gamma_n = 25."""
    contact, friction = law_of(bench_cohesive.hooke_history_law(bench_cohesive.peer_pair_style(ROOT.parent / "shared" / "peers")))
    e, tc, mstar = contact["restitution"], contact["duration"], 0.5
    kn = mstar * (math.pi ** 2 + math.log(e) ** 2) / tc ** 2
    cn = -2 * mstar * math.log(e) / tc
    assert kn == pytest.approx(1e5, rel=1e-12)
    assert cn == pytest.approx(25.0, rel=1e-12)
    assert friction["damping_ratio"] == 0.0
    assert friction["stiffness_ratio"] == pytest.approx(2 / 7, rel=1e-15)


def test_a_pair_style_of_another_form_is_refused():
    with pytest.raises(ValueError, match="gran/hooke/history"):
        bench_cohesive.hooke_history_law("pair_style gran/hooke 1.0 0.0 1.0 0.0 0.0 0")


def test_the_rolling_law_lammps_runs_is_grains_law_per_type_pair():
    """compare_lammps_rolling.py: LAMMPS' `rolling sds` moment is R_eff |f_r| with f_r = -k_roll xi - gamma_roll v_rl
    and xi built from R_eff (w_i - w_j) x n, so each type pair needs k_roll R_eff^2 = K_R, mu_roll R_eff = mu_R and
    gamma_roll R_eff^2 = c_r = beta c_n R_i R_j, with grains' c_n = 2 zeta sqrt(m* K_N) and K_R = ratio K_N a^2."""
    import compare_lammps_rolling as rolling
    radii, masses = [0.5, 0.35], [1.0, 0.49]
    scene = tomllib.loads(rolling.grains_law(0.5, 0.005, 0.015, 0.01))
    kn, e = scene["adhesion"]["stiffness"], scene["adhesion"]["restitution"]
    assert scene["adhesion"]["force"] == 0.0 and scene["friction"]["damping_ratio"] == 0.0
    kr = scene["rolling"]["stiffness_ratio"] * kn   # a = 1, the largest diameter
    zeta = -math.log(e) / math.sqrt(math.pi ** 2 + math.log(e) ** 2)
    lines = rolling.lammps_pair(radii, masses, 0.5, 0.005, 0.015, beta=0.01).splitlines()
    assert lines[0] == "pair_style granular" and len(lines) == 4
    for line in lines[1:]:
        w = line.split()
        s, t = int(w[1]) - 1, int(w[2]) - 1
        at = lambda word, k: float(w[w.index(word) + k])
        reff = radii[s] * radii[t] / (radii[s] + radii[t])
        cn = 2 * zeta * math.sqrt(masses[s] * masses[t] / (masses[s] + masses[t]) * kn)
        assert at("hooke", 1) == kn and at("hooke", 2) == pytest.approx(cn, rel=1e-14) and "velocity" in w
        assert at("linear_history", 1) == scene["friction"]["stiffness_ratio"] * kn and at("linear_history", 2) == 0.0
        assert at("linear_history", 3) == scene["friction"]["coefficient"]
        assert at("sds", 1) * reff ** 2 == pytest.approx(kr, rel=1e-14)
        assert at("sds", 2) * reff ** 2 == pytest.approx(0.01 * cn * radii[s] * radii[t], rel=1e-14)
        assert at("sds", 3) * reff == pytest.approx(scene["rolling"]["coefficient"], rel=1e-14)
        assert w[-2:] == ["twisting", "none"]


def test_the_chains_closed_form_sticks_slides_and_swings_back_at_the_bound():
    """compare_lammps_rolling.stick_slip against the law it solves: a spring theta' = u held at +-theta_b =
    decel / Omega^2 while it slides, u' = -Omega^2 theta. The spring reaches the bound, and swings back to the
    other side of it without sliding again."""
    import numpy as np
    import compare_lammps_rolling as rolling
    omega, decel, h = 17.0, 8.0, 2.5e-6
    t = np.arange(0.0, 1.0, h)
    u = rolling.stick_slip(2.0, omega, decel, t)
    bound = decel / omega ** 2
    theta = np.empty_like(u)
    theta[0] = 0.0
    for k in range(1, len(t)):   # the spring of the law, integrated from the closed form's u
        theta[k] = min(bound, max(-bound, theta[k - 1] + 0.5 * (u[k] + u[k - 1]) * h))
    assert theta.max() == pytest.approx(bound, rel=1e-12) and theta.min() == pytest.approx(-bound, rel=1e-3)
    assert np.abs(np.gradient(u, h) + omega ** 2 * theta).max() < 1e-3 * decel
    assert np.array_equal(rolling.stick_slip(0.1, omega, decel, t), 0.1 * np.cos(omega * t))   # below the bound
