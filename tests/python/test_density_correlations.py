"""Density correlations (physics.md section 9): the scattering intensity of a single disk against its
closed form, the fractal dimension of objects whose dimension is known, no fractal range in a
homogeneous packing, and the command on a stages file with its errors for bad input."""
import csv
import math
import subprocess
import sys

import h5py
import numpy as np
import pytest
from scipy.special import j1

from conftest import ROOT

sys.path.insert(0, str(ROOT / "runner"))
import density_correlations as dc  # noqa: E402


def test_single_disk_matches_its_fourier_transform():
    """|chi^(k)|^2 / A of one disk of radius R is (2 pi R^2 J1(kR) / (kR))^2 / A. Sampled at 16 points
    per diameter the grid keeps it within 5 % for k R < 2 (and the area within 1 %); at 32 points the
    worst error falls at least threefold."""
    radius, edge = 0.5, 20.0
    worst = []
    for points in (16, 32):
        chi, h = dc.density_field(np.array([[7.3, 11.1]]), np.array([radius]), np.array([edge, edge]), 2 * radius / points)
        assert chi.sum() * h[0] * h[1] == pytest.approx(math.pi * radius ** 2, rel=0.01)
        k, intensity = dc.scattering_intensity(chi, h)
        x = k * radius
        exact = (2 * math.pi * radius ** 2 * j1(x) / x) ** 2 / edge ** 2
        low = x < 2.0
        assert low.sum() > 300
        worst.append(np.max(np.abs(intensity[low] / exact[low] - 1)))
    assert worst[0] < 0.05
    assert worst[1] < worst[0] / 3


def test_disks_across_the_periodic_boundary_are_wrapped():
    """A disk straddling a corner of the cell is the same set of grid points as the disk moved inside."""
    corner, _ = dc.density_field(np.array([[9.9, -0.2]]), np.array([0.5]), np.array([10.0, 10.0]), 1 / 16)
    shifted, _ = dc.density_field(np.array([[4.9, 4.8]]), np.array([0.5]), np.array([10.0, 10.0]), 1 / 16)
    assert corner.sum() == shifted.sum()
    assert np.array_equal(np.roll(shifted, (80, -80), axis=(0, 1)), corner)   # 5 = 80 grid spacings


def rods(rng, count, length, edge):
    """Straight chains of touching unit disks, random positions and directions."""
    out = []
    for _ in range(count):
        angle = rng.uniform(0, 2 * math.pi)
        out.append(rng.uniform(0, edge, 2) + np.outer(np.arange(length) - length / 2, [math.cos(angle), math.sin(angle)]))
    return np.concatenate(out)


def test_straight_chains_have_dimension_one():
    """I(k) of rods of length l falls as k^-1 for 2 pi / l << k << 1 / a: d_F = 1."""
    positions = rods(np.random.default_rng(2), 20, 60, 300.0)
    fit = dc.analyse([(positions, np.full(len(positions), 0.5), np.array([300.0, 300.0]))], 8, k_max=1.0)
    assert fit["fractal_range"]
    assert fit["d_F"] == pytest.approx(1.0, abs=0.05)


def test_fit_recovers_the_blob_form():
    """Shells drawn from the blob form with the scatter of a finite number of wave vectors: the fit
    returns d_F and xi within three of its standard errors, which are below 0.05 and 20 %."""
    rng = np.random.default_rng(5)
    k = np.logspace(math.log10(0.15), math.log10(6.3), 16)
    counts = np.round(200 * k ** 2).astype(int) + 4
    d_f, xi = 1.55, 9.3
    mean = np.exp(dc.blob_form(k, math.log(2.0), d_f, math.log(xi)))
    noisy = mean * np.array([rng.exponential(1.0, max(n // 2, 1)).mean() for n in counts])
    fit = dc.fit_blob(k, noisy, counts, k[0], k[-1])
    assert fit["fractal_range"]
    assert fit["d_F_error"] < 0.05 and fit["xi_error"] < 0.2 * fit["xi"]
    assert abs(fit["d_F"] - d_f) < 3 * fit["d_F_error"]
    assert abs(fit["xi"] - xi) < 3 * fit["xi_error"]


def random_sequential_disks(rng, count, edge, radius):
    """Disks added one by one at random positions where they overlap none placed before (periodic)."""
    placed = np.empty((0, 2))
    while len(placed) < count:
        trial = rng.uniform(0, edge, 2)
        d = placed - trial
        d -= edge * np.round(d / edge)
        if not len(placed) or np.min(np.einsum("ij,ij->i", d, d)) >= (2 * radius) ** 2:
            placed = np.vstack([placed, trial])
    return placed


def test_a_homogeneous_packing_has_no_fractal_range():
    """Disks placed at random without overlap (solid fraction 0.4) scatter flatly below k = 2 pi / a."""
    edge, radius = 40.0, 0.5
    count = int(0.4 * edge ** 2 / (math.pi * radius ** 2))
    positions = random_sequential_disks(np.random.default_rng(3), count, edge, radius)
    fit = dc.analyse([(positions, np.full(count, radius), np.array([edge, edge]))])
    assert not fit["fractal_range"] and math.isnan(fit["d_F"])


def write_stages(path, frames):
    """A minimal stages file and its table as `grains consolidate` writes them: frame 0 the initial
    state, frame s + 1 the end of stage s."""
    steps = np.arange(len(frames)) * 1000
    with h5py.File(path, "w") as f:
        group = f.create_group("particles/all")
        for name, values in (("position", [p for p, _, _, _ in frames]), ("radius", [r for _, r, _, _ in frames]),
                             ("box/edges", [e for _, _, e, _ in frames])):
            group[f"{name}/value"] = np.array(values)
            group[f"{name}/step"] = steps
        f["observables/pressure_reduced/value"] = np.array([p for *_, p in frames])
        f["observables/pressure_reduced/step"] = steps
        f["observables/solid_fraction/value"] = np.full(len(frames), 0.4)
        f["observables/solid_fraction/step"] = steps
    with open(path.with_suffix(".csv"), "w", newline="") as f:
        writer = csv.writer(f)
        writer.writerow(["stage", "target_pressure", "P_star"])
        for s, (*_, p) in enumerate(frames[1:]):
            writer.writerow([s, "nan" if s == 0 else [0.0, 0.01][s - 1], p])


def test_command_writes_its_table_and_plot_and_names_bad_input(tmp_path):
    rng = np.random.default_rng(4)
    edge, radius = 40.0, 0.5
    count = int(0.4 * edge ** 2 / (math.pi * radius ** 2))
    frames = [(random_sequential_disks(rng, count, edge, radius), np.full(count, radius), np.array([edge, edge]), p)
              for p in (0.02, 1e-4, 2e-8, 0.013)]   # gas, aggregated, relaxed at P* = 0, stage short of 0.01
    stages = tmp_path / "sample.h5"
    write_stages(stages, frames)
    run = subprocess.run([sys.executable, str(ROOT / "runner/density_correlations.py"), str(stages),
                          "--pressures", "0", "0.01"], capture_output=True, text=True)
    assert run.returncode == 0, run.stderr
    with open(tmp_path / "sample-intensity.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    assert [float(r["P_star"]) for r in rows] == [0.0, 0.01]   # found by the table's targets
    assert (tmp_path / "sample-intensity.png").stat().st_size > 10000
    for args, message in ((["--points-per-diameter", "2"], "--points-per-diameter: 2"),
                          (["--pressures", "-1"], "--pressures"),
                          (["--pressures", "5"], "none of [5.0]"),
                          (["--k-max", "0.3"], "--k-max: 0.3: blob fit")):   # below 2 pi / L: was a traceback
        bad = subprocess.run([sys.executable, str(ROOT / "runner/density_correlations.py"), str(stages), *args],
                             capture_output=True, text=True)
        assert bad.returncode == 2 and message in bad.stderr, bad.stderr
    missing = subprocess.run([sys.executable, str(ROOT / "runner/density_correlations.py"), str(tmp_path / "none.h5")],
                             capture_output=True, text=True)
    assert missing.returncode == 2 and f"h5: '{tmp_path / 'none.h5'}' does not exist" in missing.stderr, missing.stderr


def test_stage_targets_come_from_a_running_samples_partial_table(tmp_path):
    """A campaign sample still running (or stopped) has STEM.partial.csv beside STEM.h5: its targets were not
    read, so frames were found by measured P* (an unreached stage's can be near 0 or negative)."""
    rows = [{"stage": 0, "target_pressure": "0", "P_star": "-0.002"}, {"stage": 1, "target_pressure": "0.01", "P_star": "0.004"}]
    with (tmp_path / "s.partial.csv").open("w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    measured = np.array([0.0, -0.002, 0.004])
    assert dc.stage_targets(tmp_path / "s.h5", measured).tolist() == [0.0, 0.0, 0.01]


def test_a_fit_whose_d_f_error_passes_half_of_it_has_no_fractal_range():
    """Six noisy shells (two wave vectors each): the blob form fits d_F 0.77 +- 0.58 with xi of 90,000, which was
    reported as a fractal dimension (a 16-disk campaign sample printed d_F 0.26 +- 1.99)."""
    rng = np.random.default_rng(1)
    k = np.geomspace(0.4, 6.28, 6)
    intensity = (1 + (3 * k) ** 2) ** -0.4 * np.exp(rng.normal(0, 0.8, k.size))
    fit = dc.fit_blob(k, intensity, np.full(k.size, 2), 0.4, 6.28)
    assert not fit["fractal_range"] and math.isnan(fit["d_F"])
    # The same form without the noise, over many wave vectors per shell, keeps its range.
    fit = dc.fit_blob(k, (1 + (3 * k) ** 2) ** -0.8, np.full(k.size, 200), 0.4, 6.28)
    assert fit["fractal_range"] and fit["d_F"] == pytest.approx(1.6, rel=1e-6)


def test_plot_legend_names_the_solid_fraction_of_each_state(tmp_path, monkeypatch):
    """A stage is drawn at its target P*, also when it ended short of it: the legend gives the state's Phi too, so a
    state that never compressed (Phi of the gas) shows as such."""
    rng = np.random.default_rng(4)
    edge, radius = 40.0, 0.5
    count = int(0.4 * edge ** 2 / (math.pi * radius ** 2))
    frames = [(random_sequential_disks(rng, count, edge, radius), np.full(count, radius), np.array([edge, edge]), p)
              for p in (0.02, 1e-4, 2e-8, 0.013)]
    stages = tmp_path / "sample.h5"
    write_stages(stages, frames)
    drawn, plot = [], dc.plot
    monkeypatch.setattr(dc, "plot", lambda *args: drawn.append(plot(*args)))
    dc.report([(stages, *dc.read_frames(stages))], [0.0, 0.01])
    labels = [t.get_text() for t in drawn[0].axes[0].get_legend().get_texts()]
    assert [label.split(":")[0] for label in labels] == ["P* = 0 (Φ 0.400)", "P* = 0.01 (Φ 0.400)"]


def small_stages(path, edge=20.0):
    """A stages file of disks on a jittered square lattice (cheap; no fractal range) whose frames reach P* = 0 and
    0.01."""
    side = int(edge / 1.25)
    lattice = (np.stack(np.meshgrid(np.arange(side), np.arange(side)), -1).reshape(-1, 2) + 0.5) * (edge / side)
    lattice += np.random.default_rng(7).uniform(-0.1, 0.1, lattice.shape)
    write_stages(path, [(lattice, np.full(len(lattice), 0.5), np.array([edge, edge]), p) for p in (0.02, 1e-4, 2e-8, 0.0101)])
    return path


def command(*args, cwd=None):
    return subprocess.run([sys.executable, str(ROOT / "runner/density_correlations.py"), *map(str, args)],
                          capture_output=True, text=True, timeout=120, cwd=cwd)


def refused(run, *words):
    assert run.returncode == 2 and "Traceback" not in run.stderr, run.stderr
    assert "density_correlations.py: error: " in run.stderr and all(w in run.stderr for w in words), run.stderr


def test_outputs_that_are_an_input_or_a_folder_are_refused_before_any_work(tmp_path):
    """--table naming the input overwrote the HDF5 file with the CSV (exit 0); a folder as -o or --table ended in a
    traceback after the table was written."""
    stages = small_stages(tmp_path / "sample.h5")
    before = stages.read_bytes(), stages.with_suffix(".csv").read_bytes()
    refused(command(stages, "--table", stages), f"--table '{stages}' is an input")
    refused(command(stages, "--table", tmp_path / "." / "sample.csv"), "is the stage table of the input")
    refused(command(stages, "--table", tmp_path / "t.png", "-o", tmp_path / "t.png"), "both name")
    (tmp_path / "adir.png").mkdir()
    (tmp_path / "adir").mkdir()
    refused(command(stages, "-o", tmp_path / "adir.png"), "adir.png", "is a folder")
    refused(command(stages, "--table", tmp_path / "adir"), "--table", "adir' is a folder")
    (tmp_path / "sample-intensity.png").mkdir()   # the default plot
    refused(command(stages), "-o/--out", "sample-intensity.png' is a folder", "the default")
    assert (stages.read_bytes(), stages.with_suffix(".csv").read_bytes()) == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["adir", "adir.png", "sample-intensity.png", "sample.csv", "sample.h5"]


def test_a_table_written_at_the_stage_tables_name_is_not_taken_for_one(tmp_path):
    """A run whose stage table is gone (moved, not copied): --table sample.csv wrote the intensity table there, and
    the next run refused that name as the input's stage table (and would have read its frame targets from it)."""
    stages = small_stages(tmp_path / "sample.h5")
    stages.with_suffix(".csv").unlink()
    first = command(stages, "--pressures", "0.01", "--table", tmp_path / "sample.csv")
    assert first.returncode == 0, first.stderr
    written = (tmp_path / "sample.csv").read_text()
    assert written.splitlines()[0].startswith("P_star,samples,phi_mean,"), written   # the intensity table
    second = command(stages, "--pressures", "0.01", "--table", tmp_path / "sample.csv")
    assert second.returncode == 0, second.stderr
    assert (tmp_path / "sample.csv").read_text() == written
    # The measured P* serve for the frames, not the intensity table's columns.
    measured = np.array([0.02, 1e-4, 2e-8, 0.0101])
    assert dc.stage_targets(stages, measured).tolist() == measured.tolist()


def test_k_max_is_blamed_only_for_the_fits_range(tmp_path):
    """A 2D run that is no consolidation output, or --pressures inf, were reported as --k-max errors ("All-NaN slice",
    "math domain error"); --k-max inf was taken."""
    run = tmp_path / "run.h5"
    with h5py.File(run, "w") as f:   # snapshots of 2D disks, no P* and no stage table
        group = f.create_group("particles/all")
        group["position/value"] = np.zeros((3, 2, 2))
        group["position/step"] = np.arange(3)
        group["radius/value"] = np.full((3, 2), 0.5)
        group["box/edges/value"] = np.full((3, 2), 10.0)
    bad = command(run)
    refused(bad, f"h5: {run}: no stages in it", "not an output of `grains consolidate`")
    assert "--k-max" not in bad.stderr.splitlines()[-1]
    stages = small_stages(tmp_path / "sample.h5")
    for args, words in ((["--pressures", "inf"], ["--pressures: [inf]", "finite"]),
                        (["--pressures", "0.01", "nan"], ["--pressures", "finite"]),
                        (["--k-max", "inf"], ["--k-max: inf", "finite"]),
                        (["--k-max", "-1"], ["--k-max: -1.0", "> 0"])):
        bad = command(stages, *args)
        refused(bad, *words)
    assert not (tmp_path / "sample-intensity.csv").exists()


def test_points_per_diameter_has_an_upper_bound(tmp_path):
    """100,000 points per diameter ended in an ArrayMemoryError (139 GiB): at most 128, and no more than keep the grids
    within the memory budget (a cell 2000 diameters long at 64 points: 1.6e10 points)."""
    stages = small_stages(tmp_path / "sample.h5")
    refused(command(stages, "--points-per-diameter", "100000"), "--points-per-diameter: 100000", "at most 128")
    refused(command(stages, "--points-per-diameter", "2"), "--points-per-diameter: 2", "at least 4")
    wide = tmp_path / "wide.h5"
    positions = np.array([[1.0, 1.0], [500.0, 700.0]])
    write_stages(wide, [(positions, np.full(2, 0.5), np.array([2000.0, 2000.0]), p) for p in (0.02, 1e-4, 2e-8, 0.0101)])
    refused(command(wide, "--points-per-diameter", "64"), "--points-per-diameter: 64", "GiB", "at most about")
    assert not (tmp_path / "wide-intensity.csv").exists()


def test_the_same_file_given_twice_is_one_sample(tmp_path):
    """`sample.h5 ./sample.h5` was pooled as 2 samples."""
    small_stages(tmp_path / "sample.h5")
    run = command("sample.h5", "./sample.h5", "--pressures", "0.01", cwd=tmp_path)
    assert run.returncode == 0, run.stderr
    assert "'./sample.h5' is the file 'sample.h5' again: counted once" in run.stderr
    with open(tmp_path / "sample-intensity.csv", newline="") as f:
        assert [r["samples"] for r in csv.DictReader(f)] == ["1"]


def test_a_blob_fit_that_does_not_converge_finds_no_fractal_range(monkeypatch):
    """curve_fit's RuntimeError (no convergence within maxfev) means no fractal range, not a traceback."""
    def gives_up(*args, **kwargs):
        raise RuntimeError("Optimal parameters not found: Number of calls to function has reached maxfev = 20000.")
    monkeypatch.setattr(dc, "curve_fit", gives_up)
    k = np.linspace(0.4, 6.28, 30)
    fit = dc.fit_blob(k, (1 + (3 * k) ** 2) ** -0.8, np.full(k.size, 200), 0.4, 6.28)
    assert not fit["fractal_range"] and math.isnan(fit["d_F"]) and math.isnan(fit["xi"])
    assert fit["I0"] > 0


def test_the_aggregation_is_no_stage_of_the_loading_branch():
    """In a short run the aggregation's measured P* (a fixed cell: no target) comes above the first loading targets,
    and taken as the branch's top it would make P* = 0.01 "no loading stage"."""
    rows = [{"phase": "aggregation", "target_pressure": "nan", "P_star": "0.0183"},
            {"phase": "equilibrate", "target_pressure": "0", "P_star": "0.0146"},
            {"phase": "equilibrate", "target_pressure": "0.01", "P_star": "0.0090"},
            {"phase": "loading", "target_pressure": "0.0133352143", "P_star": "0.0052"}]
    targets = np.array([0.0] + [dc.target_pressure(row) for row in rows])
    assert math.isnan(targets[1])
    assert dc.loading_frame(targets, 0.01) == 3 and dc.loading_frame(targets, 0) == 2
    assert dc.target_pressure({"P_star": "0.5"}) == 0.5   # an older table without targets: the measured P*


def test_a_disk_reaching_round_a_small_cell_onto_itself_is_drawn_whole():
    """Where a disk's index range wraps onto itself (2 R + 2 h > L), the grid's |= kept one write per point, and a
    point the disk covers through one image but not the other could end free."""
    edge, radius, spacing = 2.0, 0.95, 0.2
    chi, h = dc.density_field(np.array([[1.0, 1.0]]), np.array([radius]), np.array([edge, edge]), spacing)
    centres = (np.arange(10) + 0.5) * h[0]
    gap = np.abs(centres - 1.0)
    nearest = np.minimum(gap, edge - gap)   # the nearest image, per axis
    expected = nearest[:, None] ** 2 + nearest[None, :] ** 2 <= radius ** 2
    assert np.array_equal(chi, expected)
