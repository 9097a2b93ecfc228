"""The normal-force distributions found again from the stage snapshots (runner/force_distribution.py) equal the
engine's own histograms of every stage record, with and without adhesion; the command's panels and its errors."""
import csv
import subprocess
import sys

import h5py
import numpy as np
import pytest

from conftest import ROOT

sys.path.insert(0, str(ROOT / "runner"))
import density_correlations as dc  # noqa: E402
import force_distribution as fd  # noqa: E402


@pytest.fixture(scope="module")
def programmes(grains_bin, tmp_path_factory):
    """A short type-2 programme of 100 cohesive disks (aggregated: bonds from the start) and a cohesionless one of 60,
    each with its stage records."""
    folder = tmp_path_factory.mktemp("forces")
    runs = {"type2": ["consolidation", "--set", "particles.count=100", "--set", "programme.top_pressure=0.05",
                      "--set", "programme.stage_budget=20000", "--set", "programme.aggregation_budget=200000"],
            "cohesionless": ["cohesionless", "--set", "particles.count=60", "--set", "programme.top_pressure=4e-5",
                             "--set", "programme.load=true", "--set", "programme.stage_budget=20000"]}
    out = {}
    for name, (model, *sets) in runs.items():
        h5 = folder / f"{name}.h5"
        r = subprocess.run([str(grains_bin), "consolidate", str(ROOT / "models" / f"{model}.toml"), "--out", str(h5),
                            "--table", str(folder / f"{name}.csv"), "--set", "run.threads=1", "--set",
                            "programme.unload=false", *sets, "--quiet"], capture_output=True, text=True, timeout=300)
        assert r.returncode == 0, r.stderr
        out[name] = h5
    return out


@pytest.mark.parametrize("name", ["type2", "cohesionless"])
def test_the_forces_found_from_the_geometry_give_the_engines_histogram_at_every_stage(programmes, name):
    positions, radii, edges, p_star, phi = dc.read_frames(programmes[name], (2, 3))
    law = fd.law_of(programmes[name], 2 * float(np.max(radii)))
    with h5py.File(programmes[name]) as f:
        recorded = np.array([f[f"observables/force_histogram_{b:02}/value"][()] for b in range(21)]).T
        interactions = f["observables/coordination/value"][()] * positions.shape[1] / 2
    assert len(recorded) == len(positions) >= 4
    for frame in range(len(positions)):
        forces = fd.normal_forces(positions[frame], radii[frame], edges[frame], law)
        assert len(forces) == pytest.approx(interactions[frame], abs=1e-9), frame
        scale = law[1] if law[1] > 0 or len(forces) == 0 else np.mean(np.abs(forces))
        assert np.array_equal(fd.histogram(forces, scale, -1.0, 0.5, 21), recorded[frame]), frame
    assert max(np.count_nonzero(h[:20]) for h in recorded) >= 2   # forces spread over bins: real distributions compared


def test_the_command_writes_both_panels_and_refuses_what_it_cannot_read(programmes, tmp_path):
    table, out = tmp_path / "f.csv", tmp_path / "f.png"
    r = subprocess.run([sys.executable, str(ROOT / "runner/force_distribution.py"), str(programmes["type2"]),
                        "--pressures", "0.01", "0.0316", "--scaled", "0.0316", "--table", str(table), "-o", str(out)],
                       capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, r.stderr
    assert out.stat().st_size > 10_000
    rows = list(csv.DictReader(table.open()))
    positions, radii, edges, p_star, _ = dc.read_frames(programmes["type2"], (2, 3))
    frame = dc.loading_frame(p_star, 0.0316)
    law = fd.law_of(programmes["type2"], 2 * float(np.max(radii)))
    forces = fd.normal_forces(positions[frame], radii[frame], edges[frame], law)
    for panel, pressures in (("F_N / F0", {"0.01", "0.0316"}), ("F_N / P*F0", {"0.0316"})):
        mine = [row for row in rows if row["panel"] == panel]
        assert {row["P_star"] for row in mine} == pressures
        for p in pressures:   # each distribution's density integrates to one; the rescaled wing to the compressive share
            density = [(float(row["density"]), float(row["bin_low"])) for row in mine if row["P_star"] == p]
            width = density[1][1] - density[0][1]
            total = 1.0 if panel == "F_N / F0" else np.mean(forces >= 0)
            assert sum(d for d, _ in density) * width == pytest.approx(total)
    bad = subprocess.run([sys.executable, str(ROOT / "runner/force_distribution.py"), str(programmes["type2"]),
                          "--pressures", "-1"], capture_output=True, text=True, timeout=60)
    assert bad.returncode == 2 and "--pressures: [-1.0]; reduced pressures must be finite numbers > 0" in bad.stderr
    none = subprocess.run([sys.executable, str(ROOT / "runner/force_distribution.py"), str(programmes["type2"]),
                           "--pressures", "50", "--scaled", "60", "--table", str(tmp_path / "n.csv"), "-o",
                           str(tmp_path / "n.png")], capture_output=True, text=True, timeout=60)
    assert none.returncode == 2 and "none of [50.0, 60.0] is a loading stage" in none.stderr, none.stderr


def test_outputs_that_would_overwrite_what_the_programme_wrote_are_refused(programmes, tmp_path):
    """A --table naming the programme's own stage table (as the documented command once did) would be overwritten;
    the table and the plot naming one file, the plot would replace the table."""
    h5 = programmes["type2"]
    for args, said in ((["--table", str(h5.with_suffix(".csv"))], "is the stage table of the input"),
                       (["-o", str(tmp_path / "x.png"), "--table", str(tmp_path / "x.png")], "both name")):
        before = h5.with_suffix(".csv").read_text()
        r = subprocess.run([sys.executable, str(ROOT / "runner/force_distribution.py"), str(h5), *args],
                           capture_output=True, text=True, timeout=60)
        assert r.returncode == 2 and said in r.stderr, r.stderr
        assert h5.with_suffix(".csv").read_text() == before


def test_the_attraction_range_defaults_to_the_largest_given_diameters(tmp_path):
    """Listed particles have no size distribution, which must not make D0 NaN (every interaction lost).
    The engine's default is 1e-3 of the largest given diameter."""
    h5 = tmp_path / "listed.h5"
    with h5py.File(h5, "w") as f:
        f["parameters/scene.toml"] = ('[adhesion]\nenabled = true\nforce = 2.0\nstiffness = 1e4\n[contact]\noverlap_limit = 0.5\n'
                                      '[particles]\nlayout = "list"\n').encode()
    assert fd.law_of(h5, 3.0) == (1e4, 2.0, 3e-3, 0.5)
