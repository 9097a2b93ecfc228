"""`grains consolidate`: every consolidation scene is valid, and a run writes one table row, one H5MD
observable record and one snapshot per stage, reporting stages that miss equilibrium."""
import csv
import subprocess

import h5py
import numpy as np
import pytest

from h5text import text
from interrupt import interrupted, run

SCENES = ["consolidation", "consolidation-rr", "consolidation-type1", "cohesionless", "consolidation-3d",
          "consolidation-rr-3d"]


@pytest.mark.parametrize("name", SCENES)
def test_consolidation_scenes_are_valid(grains_bin, root, name):
    r = run(grains_bin, "check", root / "models" / f"{name}.toml")
    assert r.returncode == 0, r.stderr
    assert "enabled = true" in r.stdout


def test_consolidate_writes_a_row_per_stage_and_reports_unreached_stages(grains_bin, root, tmp_path):
    table, out = tmp_path / "stages.csv", tmp_path / "stages.h5"
    # A small cohesionless programme with a budget far too small for equilibrium: every stage must be
    # recorded and reported, none hidden.
    r = run(grains_bin, "consolidate", root / "models" / "cohesionless.toml", "--table", table, "--out", out,
            "--set", "particles.count=60", "--set", "programme.load=true", "--set", "programme.unload=true", "--set", "programme.top_pressure=4e-5",
            "--set", "programme.stages_per_decade=2", "--set", "programme.stage_budget=300")
    assert r.returncode == 0, r.stderr
    rows = list(csv.DictReader(table.open()))
    assert [row["phase"] for row in rows] == ["equilibrate", "loading", "unloading"]
    assert all(row["reached"] == "0" and row["steps"] == "300" for row in rows)
    assert r.stderr.count("did not reach equilibrium") == 3
    assert "3 not reached" in r.stdout and "CVODE" in r.stdout
    # Said up front: 300 steps cannot hold the 5 confirming checks of 100 steps each
    assert ("programme.stage_budget = 300 holds fewer than the programme.confirm_checks = 5 checks (one every "
            "programme.check_every = 100 steps, and one at the budget's end)") in r.stderr
    # 450 steps hold them: checks at 100, 200, 300, 400 and the budget's end (not warned about)
    r = run(grains_bin, "consolidate", root / "models" / "cohesionless.toml", "--table", tmp_path / "t450.csv", "--out",
            tmp_path / "t450.h5", "--set", "particles.count=60", "--set", "programme.load=false", "--set",
            "programme.unload=false", "--set", "programme.stage_budget=450", "--quiet")
    assert r.returncode == 0 and "no stage can reach" not in r.stderr, r.stderr
    for key in ("solid_fraction", "pressure_reduced", "coordination", "rattler_fraction", "contacts_kept",
                "force_histogram_00"):
        assert key in rows[0]
    # The elastic moduli (analysis.elastic_moduli = true in the consolidation scenes), in the table and the
    # H5MD stage records.
    moduli = ("B", "G", "C11", "C22", "C12", "B_Voigt", "G_Voigt", "B_Reuss", "Z2", "moduli_mechanisms",
              "moduli_unstable_modes", "moduli_floppy_modes")
    for key in moduli:
        assert key in rows[0]
    # 300 steps leave the 60 grains a gas without contacts: no stiffness at all, both strain directions free
    last = rows[-1]
    assert float(last["coordination"]) == 0
    assert all(float(last[key]) == 0 for key in ("B", "G", "C11", "C22", "C12", "B_Voigt", "G_Voigt"))
    assert last["moduli_mechanisms"] == "2" and last["moduli_unstable_modes"] == "0"
    with h5py.File(out) as f:
        assert len(f["observables/solid_fraction/value"]) == 1 + len(rows)   # the initial state + one per stage
        for key in moduli:
            assert len(f[f"observables/{key}/value"]) == 1 + len(rows)
        status = text(f["grains"].attrs["status"])
        assert "did not reach" in status or "not reached" in status


def test_an_unfinished_aggregation_is_reported_without_a_pressure(grains_bin, root, tmp_path):
    """The type-2 aggregation runs in a fixed cell: its report names that, not "P* = nan"."""
    out = tmp_path / "agg.h5"
    r = run(grains_bin, "consolidate", root / "models" / "consolidation.toml", "--out", out, "--table", tmp_path / "agg.csv",
            "--set", "particles.count=60", "--set", "run.threads=1", "--set", "programme.aggregation_budget=500",
            "--set", "programme.stage_budget=100", "--set", "programme.load=false")
    assert r.returncode == 0, r.stderr
    assert "stage 0 (aggregation in its fixed cell) did not reach one cluster within its budget of 500 steps" in r.stderr
    assert "nan" not in r.stderr.lower() and "nan" not in r.stdout.lower()
    assert "stage  0 aggregation P* -" in r.stdout
    with h5py.File(out) as f:
        assert any(w.decode().startswith("stage 0 (aggregation, fixed cell) not reached") for w in f["grains/warnings"][:])


def test_each_stage_record_in_the_output_equals_its_table_row(grains_bin, root, tmp_path):
    """The H5MD stage records hold the table's quantities. contacts_kept / lost / gained were read after the
    programme had marked the stage's network as the next reference, so the records said (contacts, 0, 0)."""
    table, out = tmp_path / "stages.csv", tmp_path / "stages.h5"
    r = run(grains_bin, "consolidate", root / "models" / "consolidation.toml", "--table", table, "--out", out,
            "--set", "particles.count=100", "--set", "run.threads=1", "--set", "programme.stage_budget=20000",
            "--set", "programme.aggregation_budget=200000", "--set", "programme.top_pressure=0.05", "--quiet")
    assert r.returncode == 0, r.stderr
    assert "no stage can reach" not in r.stderr
    rows = list(csv.DictReader(table.open()))
    assert len(rows) >= 4
    lost = 0
    with h5py.File(out) as f:
        for stage, row in enumerate(rows):
            for key, text in row.items():
                if key in ("stage", "phase", "branch", "target_pressure", "P_star", "phi", "reached", "steps", "time") or text == "":
                    continue
                recorded = float(f[f"observables/{key}/value"][stage + 1])   # record 0: the initial state
                assert recorded == pytest.approx(float(text), rel=1e-8, abs=1e-300, nan_ok=True), (stage, key)
            lost += int(row["contacts_lost"]) + int(row["contacts_gained"])
    assert lost > 0   # the networks changed between stages: the check above compared real counts


def test_consolidate_writes_to_output_file_and_says_a_run_length_is_not_used(grains_bin, root, tmp_path):
    """A scene shared with `grains run` may name its output file and a run length: the programme writes to the
    file and says that the run length does not apply (it was silently ignored)."""
    out = tmp_path / "named.h5"
    r = subprocess.run([grains_bin, "consolidate", root / "models" / "cohesionless.toml", "--table", "t.csv",
                        "--set", f"output.file={out}", "--set", "time.steps=1000", "--set", "particles.count=60",
                        "--set", "programme.stage_budget=300", "--quiet"], capture_output=True, text=True, cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    assert out.exists() and not (tmp_path / "cohesionless-stages.h5").exists()
    assert "time.steps is not used by grains consolidate" in r.stderr
    with h5py.File(out) as f:
        assert any(b"time.steps is not used" in w for w in f["grains/warnings"][()])


@pytest.mark.parametrize("overrides, expected", [
    # A cohesionless cell refuses P* = 0, where the ramp starts: it failed at the first step with a message
    # about cell.pressure, after writing the output file.
    (["--set", "programme.preparation=type1", "--set", "programme.first_compression_time=10"],
     "programme.first_compression_time: value 10 ramps the first compression's target from P* = 0"),
    # More steps than a long holds: the ramp's step count wrapped to 0 and the stage ran at the full pressure.
    (["--set", "programme.preparation=type1", "--set", "cell.force_unit=1", "--set",
      "programme.first_compression_time=1e30"],
     "programme.first_compression_time: value 1e+30 is"),
])
def test_a_first_compression_ramp_that_cannot_run_is_refused_before_anything_is_written(grains_bin, root, tmp_path,
                                                                                       overrides, expected):
    out = tmp_path / "ramp.h5"
    r = run(grains_bin, "consolidate", root / "models" / "cohesionless.toml", "--table", tmp_path / "t.csv", "--out", out,
            "--set", "particles.count=60", "--set", "programme.stage_budget=300", *overrides)
    assert r.returncode != 0 and expected in r.stderr, r.stderr
    assert not out.exists()


def test_consolidate_acts_on_an_interrupt_between_rare_checks(grains_bin, root, tmp_path):
    """Ctrl-C was read only at the equilibrium checks: with programme.check_every = 1e8, never in practice."""
    out = tmp_path / "co.h5"
    code, stdout, stderr = interrupted([grains_bin, "consolidate", root / "models" / "cohesionless.toml", "--out", out,
                                        "--table", tmp_path / "co.csv", "--quiet", "--set", "particles.count=60", "--set",
                                        "programme.check_every=100000000", "--set", "programme.stage_budget=1000000000"],
                                       out, 0.5, within=10)
    assert code == 130, stderr
    assert f"INTERRUPTED in stage 0 (continue it with grains resume {out})" in stdout
    with h5py.File(out) as f:
        status = text(f["grains"].attrs["status"])
        assert status.startswith("interrupted in stage 0 at step ")
        assert 0 < int(status.split()[-1]) < 100000000
        assert "checkpoint_0" in f["grains"]


def test_a_programme_that_fails_says_so_in_its_file(grains_bin, root, tmp_path):
    """A programme stopped by an error says so in its file, not with the status "running" of a killed one."""
    out = tmp_path / "blown.h5"
    r = run(grains_bin, "consolidate", root / "models/cohesionless.toml", "--set", "particles.count=100", "--set",
            "time.dt=10", "--set", "run.threads=1", "--out", out, "--table", tmp_path / "blown.csv", "--quiet")
    assert r.returncode == 1 and "CVODE integration" in r.stderr
    with h5py.File(out) as f:
        assert text(f["grains"].attrs["status"]).startswith("failed after step 1: barostat: CVODE integration")


def test_consolidate_traces_every_stage_at_its_checks_and_its_end_and_changes_nothing(grains_bin, root, tmp_path):
    """programme.trace_every: within the stages, at the first equilibrium check (every programme.check_every = 100
    steps into a stage) at or past each multiple of it, and at each stage's end (its stage record's state), the
    stage's course goes to grains/trace/*; the stage records, one per stage, and the table are the programme's
    without a trace, which writes none."""
    programme = [root / "models" / "consolidation-type1.toml", "--set", "particles.count=100", "--set",
                 "programme.top_pressure=0.02", "--set", "programme.stage_budget=12000", "--set", "run.threads=1"]
    plain, traced = tmp_path / "plain", tmp_path / "traced"
    for out, every in ((plain, 0), (traced, 2550)):
        r = run(grains_bin, "consolidate", *programme, "--set", f"programme.trace_every={every}", "--table",
                out.with_suffix(".csv"), "--out", out.with_suffix(".h5"), "--quiet")
        assert r.returncode == 0, r.stderr
    assert traced.with_suffix(".csv").read_text() == plain.with_suffix(".csv").read_text()
    rows = list(csv.DictReader(traced.with_suffix(".csv").open()))
    # The checks each stage made that did not end it, and of those the ones the trace is due at (a multiple of 2550
    # since the previous check); then the stage's end.
    expected_steps, expected_stages, ends, start = [], [], [], 0
    for row in rows:
        end = start + int(row["steps"])
        for step in range(start + 100, end, 100):
            if step // 2550 != (step - 100) // 2550:
                expected_steps.append(step)
                expected_stages.append(int(row["stage"]))
        expected_steps.append(end)
        expected_stages.append(int(row["stage"]))
        ends.append(end)
        start = end
    assert len(expected_steps) > 10 + len(rows) and len(rows) > 1
    assert any(end % 2550 for end in ends)   # a stage end off the multiples: there by the new rule alone
    with h5py.File(plain.with_suffix(".h5")) as p, h5py.File(traced.with_suffix(".h5")) as f:
        assert "trace" not in p["grains"] and "trace" in f["grains"]
        assert sorted(f["observables"]) == sorted(p["observables"])
        # Every stage record at a frame's step, the initial state's included (MDAnalysis reads the observables' rows
        # by the frame's index: quench_start and quench_drag a row short made it fail at the last frame).
        frames = list(f["particles/all/position/step"][()])
        assert len(frames) == 1 + len(rows)
        for k in f["observables"]:
            assert list(f[f"observables/{k}/step"][()]) == frames, k
        for k in p["observables"]:
            if not k.startswith("cvode"):
                for part in ("step", "value"):
                    assert np.array_equal(f[f"observables/{k}/{part}"][()], p[f"observables/{k}/{part}"][()], equal_nan=True), k
        trace = f["grains/trace"]
        assert {"stage", "pressure_reduced", "pressure_target", "solid_fraction", "coordination", "kinetic_energy",
                "equilibrium_force", "equilibrium_torque", "equilibrium_stress", "equilibrium_kinetic"} <= set(trace)
        for name in trace:
            assert list(trace[f"{name}/step"][()]) == expected_steps, name
        assert list(trace["stage/value"][()]) == expected_stages
        # Each stage's target, as its table row gives it (NaN for a type-2 aggregation in its fixed cell: see below).
        target = {int(row["stage"]): float(row["target_pressure"]) for row in rows}
        assert np.allclose(trace["pressure_target/value"][()], [target[s] for s in expected_stages], rtol=1e-8)
        # A stage's end row is its stage record: the observables' values at that step, bit for bit (the line of a
        # stage's course ends at its record's dot).
        at_end = np.isin(trace["stage/step"][()], ends)
        assert list(trace["stage/step"][()][at_end]) == ends
        for name in trace:
            if name in f["observables"]:
                record = f[f"observables/{name}"]
                assert np.array_equal(trace[f"{name}/value"][()][at_end], record["value"][1:], equal_nan=True), name
                assert np.array_equal(trace[f"{name}/time"][()][at_end], record["time"][1:]), name
        # The last Phi within each stage lies between the stage's start and end values (type 1 compacts).
        phi = trace["solid_fraction/value"][()]
        phi_ends = [0.36] + [float(row["phi"]) for row in rows]
        for s in set(expected_stages):
            within = [k for k, e in enumerate(expected_stages) if e == s and expected_steps[k] not in ends]
            if within:
                assert min(phi_ends[s], phi_ends[s + 1]) - 1e-9 <= phi[within[-1]] <= max(phi_ends[s], phi_ends[s + 1]) + 1e-9


def test_the_trace_and_record_of_an_aggregation_in_its_fixed_cell_have_no_target(grains_bin, root, tmp_path):
    """The type-2 aggregation holds the cell fixed: its trace's target and its stage record's are NaN, as in the stage
    table, not the cell.pressure the scene gives for later (nor does the initial state's record, before the
    aggregation)."""
    out = tmp_path / "agg.h5"
    r = run(grains_bin, "consolidate", root / "models" / "consolidation.toml", "--set", "particles.count=100", "--set",
            "programme.aggregation_budget=3000", "--set", "programme.stage_budget=2000", "--set", "programme.load=false",
            "--set", "programme.trace_every=1000", "--set", "run.threads=1", "--table", tmp_path / "agg.csv", "--out", out,
            "--quiet")
    assert r.returncode == 0, r.stderr
    rows = list(csv.DictReader((tmp_path / "agg.csv").open()))
    assert [row["phase"] for row in rows] == ["aggregation", "equilibrate", "equilibrate"]
    ends = np.cumsum([int(row["steps"]) for row in rows])
    with h5py.File(out) as f:
        steps = f["grains/trace/stage/step"][()]
        stage = f["grains/trace/stage/value"][()]
        target = f["grains/trace/pressure_target/value"][()]
        clusters = f["grains/trace/bonded_clusters/value"][()]
        recorded_clusters = f["observables/bonded_clusters/value"][1:]
        recorded_target = f["observables/pressure_target/value"][1:]
        initial_target = f["observables/pressure_target/value"][0]
    assert np.isnan(initial_target)
    # Every stage ends with a row, the aggregation's too (with its record's clusters, its target NaN as in the table).
    at_end = np.isin(steps, ends)
    assert list(steps[at_end]) == list(ends) and list(stage[at_end]) == [0, 1, 2]
    assert np.array_equal(clusters[at_end], recorded_clusters)
    assert np.isnan(target[stage == 0]).all() and (stage == 0).sum() >= 2
    assert list(target[stage > 0]) == [float(rows[int(s)]["target_pressure"]) for s in stage[stage > 0]]
    # The stage records say the same: the aggregation's NaN, the later stages' targets as their rows give them.
    table_target = np.array([float(row["target_pressure"]) for row in rows])
    assert np.isnan(recorded_target[0]) and np.isnan(table_target[0])
    assert np.array_equal(recorded_target, table_target, equal_nan=True)
    assert np.array_equal(target[at_end], recorded_target, equal_nan=True)


def test_a_stage_ending_with_contacts_past_the_overlap_clamp_is_warned_about_once(grains_bin, root, tmp_path):
    """Counted in the outputs only, a stage in "equilibrium" with contacts past the clamp would go by unsaid. 60 disks
    at kappa = 1e4 with the clamp at 0.2 R_min: P* = 100 holds (largest overlap 0.07 R_min),
    P* = 1000 crushes the packing past it."""
    out = tmp_path / "crushed.h5"
    r = run(grains_bin, "consolidate", root / "models" / "consolidation.toml", "--out", out, "--table",
            tmp_path / "crushed.csv", "--set", "particles.count=60", "--set", "programme.preparation=none",
            "--set", "cell.pressure=100", "--set", "programme.top_pressure=1000", "--set", "programme.stages_per_decade=1",
            "--set", "programme.unload=false", "--set", "programme.stage_budget=300000", "--set", "adhesion.stiffness=1e4",
            "--set", "contact.overlap_limit=0.2", "--set", "analysis.elastic_moduli=false", "--set", "run.threads=1")
    assert r.returncode == 0, r.stderr
    said = [line for line in r.stderr.splitlines() if "past the overlap clamp" in line]
    assert len(said) == 1 and said[0].startswith("warning: stage 1 (loading, P* = 1000) ended with "), r.stderr
    with h5py.File(out) as f:
        clamped = f["observables/clamped_contacts/value"][()]
        assert clamped[1] == 0 and clamped[2] > 0   # stage 0 held, stage 1 did not: the warning is no false alarm
        assert sum("past the overlap clamp" in text(w) for w in f["grains/warnings"][()]) == 1
