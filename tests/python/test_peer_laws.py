"""The side-by-side scripts give LAMMPS and grains the same contact law: the LAMMPS pair style written for
the frictional gas reads back as grains' scene law, and disks2d.lmp's pair style (dampflag 0: no
tangential dashpot) as the law grains runs beside it. Until 2026-12-04 both scripts ran LAMMPS with
dampflag 0 against grains' damped tangential spring, a 14 % difference in what a collision dissipates."""
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
