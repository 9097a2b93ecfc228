"""The benchmarks and LAMMPS comparisons refuse bad arguments in one line naming the option, with exit status 2 and
before anything runs (runner/bench_fmu.py, bench_cohesive.py, compare_lammps*.py): an audit found tracebacks, a
folder taken as the grains program, an --out left empty behind, and engine refusals whose reason was never shown.
Only the arguments are tried: a check that let bad input through would start minutes of LAMMPS (hence the timeout)."""
import importlib.util
import subprocess
import sys

import pytest

from conftest import ROOT

COMPARISONS = ["compare_lammps.py", "compare_lammps_gravity.py", "compare_lammps_rolling.py"]


def tool(name, *args, cwd):
    return subprocess.run([sys.executable, str(ROOT / "runner" / name), *map(str, args)], capture_output=True, text=True,
                          cwd=cwd, timeout=60)


def refused(run, name, *words):
    assert run.returncode == 2 and "Traceback" not in run.stderr, (run.returncode, run.stderr)
    assert f"{name}: error: " in run.stderr and all(w in run.stderr for w in words), run.stderr


@pytest.mark.parametrize("name", COMPARISONS)
def test_comparisons_refuse_an_out_that_is_no_folder_and_make_none(grains_bin, tmp_path, name):
    """--out naming a file (FileExistsError), or below a file (FileNotFoundError, NotADirectoryError), ended in a
    traceback; a folder as --binary was taken (compare_lammps_gravity.py ran LAMMPS, then left an empty --out)."""
    (tmp_path / "afile").write_text("")
    refused(tool(name, "--binary", grains_bin, "--out", "afile", cwd=tmp_path), name, "--out afile is a file, not a folder")
    refused(tool(name, "--binary", grains_bin, "--out", "afile/sub", cwd=tmp_path), name, "--out afile/sub",
            "no folder can be made there", "afile is a file")
    (tmp_path / "taken").mkdir()
    (tmp_path / "taken" / "summary.md").mkdir()
    refused(tool(name, "--binary", grains_bin, "--out", "taken", cwd=tmp_path), name, "summary.md is a folder")
    refused(tool(name, "--binary", tmp_path, "--out", "g1", cwd=tmp_path), name, f"--binary {tmp_path} is a folder")
    refused(tool(name, "--binary", tmp_path / "none", "--out", "g1", cwd=tmp_path), name, "--binary", "no such file")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["afile", "taken"]


def test_compare_lammps_names_missing_peers_as_a_usage_error(grains_bin, tmp_path):
    """--peers and --binary naming nothing ended with exit status 1, without the program's name."""
    refused(tool("compare_lammps.py", "--peers", tmp_path / "none", "--binary", grains_bin, cwd=tmp_path),
            "compare_lammps.py", f"--peers {tmp_path / 'none'}: no gas_data.py there")
    assert not any(tmp_path.iterdir())


def test_gravity_comparison_checks_the_seeds_range_before_running(grains_bin, tmp_path):
    """particles.seed goes to 9.2e18: a larger seed passed the check (>= 0) and grains refused it only when its runs
    began."""
    refused(tool("compare_lammps_gravity.py", "--binary", grains_bin, "--seeds", "1", "9300000000000000000", cwd=tmp_path),
            "compare_lammps_gravity.py", "--seeds 9300000000000000000: grains refuses it", "particles.seed",
            "[0, 9.2e+18]")
    assert not any(tmp_path.iterdir())


@pytest.mark.parametrize("cells", ["0", "1", "2"])
def test_bench_cohesive_names_too_few_cells(grains_bin, tmp_path, cells):
    """--cells 1 ended (after the LAMMPS run) in grains' box.lengths message, which does not say --cells; 3 cells
    (3.15 long) are the fewest whose box is longer than twice the interaction reach (2.202)."""
    refused(tool("bench_cohesive.py", "--binary", grains_bin, "--cells", cells, cwd=tmp_path), "bench_cohesive.py",
            f"--cells = {cells}: must be at least 3", "2.202")


def test_bench_cohesive_says_a_folder_is_a_folder(tmp_path):
    refused(tool("bench_cohesive.py", "--binary", tmp_path, cwd=tmp_path), "bench_cohesive.py",
            f"--binary {tmp_path} is a folder")


def test_bench_cohesive_smallest_cells_make_a_scene_grains_takes(grains_bin, tmp_path):
    """The bound is grains' own: at MIN_CELLS every law's scene passes `grains check`, one fewer does not."""
    sys.path.insert(0, str(ROOT / "runner"))
    import bench_cohesive
    import scene_check
    for variant in ("adhesion+friction+rolling", "adhesion+friction", "spring-dashpot+friction"):
        scene, _ = bench_cohesive.grains_scene(tmp_path, bench_cohesive.MIN_CELLS, variant, bench_cohesive.PEER_PAIR_STYLE)
        scene_check.resolve(grains_bin, scene, [])
        scene, _ = bench_cohesive.grains_scene(tmp_path, bench_cohesive.MIN_CELLS - 1, variant, bench_cohesive.PEER_PAIR_STYLE)
        with pytest.raises(scene_check.SceneError, match="periodic axis 0"):
            scene_check.resolve(grains_bin, scene, [])


@pytest.mark.skipif(not (ROOT / "build" / "fmus").is_dir() or importlib.util.find_spec("fmpy") is None,
                    reason="bench_fmu.py needs the built FMUs (it takes dt from one) and fmpy")
@pytest.mark.parametrize("args, words", [
    (["--duration", "inf"], ["--duration = inf", "finite"]),   # OverflowError
    (["--duration", "nan"], ["--duration = nan", "finite"]),
    (["--duration", "1e300"], ["--duration = 1e+300: grains refuses it", "time.steps", "1.5e+303"]),   # CalledProcessError
    (["--threads", "5000", "--duration", "0.07"], ["--threads = 5000: grains refuses it", "run.threads", "[0, 1024]"]),
])
def test_bench_fmu_refuses_what_grains_would_with_its_reason(tmp_path, args, words):
    refused(tool("bench_fmu.py", *args, cwd=tmp_path), "bench_fmu.py", *words)
    assert not any(tmp_path.iterdir())


def test_a_failed_grains_command_is_told_in_one_line(tmp_path):
    """child_runs.run_grains ends a tool with grains' reason: grains' stderr (warnings, a heading, the problems) came
    over several lines after the tool's own words (bench_fmu.py's timing runs); it is one line now, and a grains that
    said nothing is said to have said nothing."""
    sys.path.insert(0, str(ROOT / "runner"))
    import child_runs
    fake = tmp_path / "grains"
    fake.write_text("#!/bin/sh\nprintf 'warning: dt is large\\n\\nerror: the run stopped\\n  - particle 7: position is nan\\n' >&2\nexit 1\n")
    fake.chmod(0o755)
    with pytest.raises(SystemExit) as ended:
        child_runs.run_grains("tool.py", [fake, "run", "scene.toml"])
    assert str(ended.value) == ("tool.py: grains run ended with status 1: warning: dt is large; error: the run stopped; "
                                "particle 7: position is nan")
    fake.write_text("#!/bin/sh\nexit 3\n")
    with pytest.raises(SystemExit) as ended:
        child_runs.run_grains("tool.py", [fake, "run", "scene.toml"])
    assert str(ended.value) == "tool.py: grains run ended with status 3: it said nothing"


def test_bench_cohesive_refuses_more_threads_than_cores_before_running(grains_bin, tmp_path):
    """--threads 3 on 2 cores would run LAMMPS on one core, then end in a CalledProcessError traceback from mpirun
    -np 3, whose reason (too few slots) is captured and never shown."""
    import os
    cores = len(os.sched_getaffinity(0))
    refused(tool("bench_cohesive.py", "--binary", grains_bin, "--threads", f"1,{cores + 1}", "--steps", "10", cwd=tmp_path),
            "bench_cohesive.py", f"--threads 1,{cores + 1}", f"{cores + 1} is more than the {cores} core(s)")
    assert not any(tmp_path.iterdir())


def test_bench_cohesive_times_grains_after_the_warm_up_lammps_has(tmp_path, monkeypatch):
    """LAMMPS is timed after disks2d.lmp's 1000-step warm-up, grains was timed from step 1 (its whole run's rate):
    at --steps 300 the ratio read 1.6-1.7 against 2.0-2.3 at 20000. grains' rate is now that of the steps after a
    run of WARMUP steps: the difference of a run of WARMUP + steps and one of WARMUP."""
    import h5py
    sys.path.insert(0, str(ROOT / "runner"))
    import bench_cohesive
    import child_runs
    particles, asked = 1400, []

    def fake_grains(prog, command):   # start-up 0.5 s, the first 1000 steps 0.2 s slower, then 1 ms a step
        steps = int(next(a for a in command if str(a).startswith("time.steps=")).split("=")[1])
        asked.append(steps)
        wall = 0.5 + 0.2 * min(steps, 1000) / 1000 + 1e-3 * steps
        with h5py.File(command[command.index("--out") + 1], "w") as f:
            f["observables/contacts/value"] = [7.0]
            f.create_group("grains").attrs.update({"wall_seconds": wall, "particle_steps_per_second": steps * particles / wall,
                                                   "pair_loop_build": b"test"})
        return ""
    monkeypatch.setattr(child_runs, "run_grains", fake_grains)
    rate, contacts, build = bench_cohesive.grains_rate("grains", tmp_path / "s.toml", 300, 1, tmp_path, particles)
    assert sorted(set(asked)) == [bench_cohesive.WARMUP, bench_cohesive.WARMUP + 300] and bench_cohesive.WARMUP == 1000
    assert rate == pytest.approx(particles / 1e-3) and contacts == 7 and build == "test"
