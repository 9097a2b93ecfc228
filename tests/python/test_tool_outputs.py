"""The Python tools name an output path in a missing folder, or an unreadable input, in one line instead
of a traceback after their work (plot.py, consolidation_fit.py, density_correlations.py)."""
import os
import shutil
import subprocess
import sys

import numpy as np
import pytest

from conftest import ROOT


def tool(name, *args, cwd=None):
    return subprocess.run([sys.executable, str(ROOT / "runner" / name), *map(str, args)], capture_output=True, text=True,
                          cwd=cwd)


@pytest.fixture
def stage_table(tmp_path):
    path = tmp_path / "stages.csv"
    path.write_text("P_star,phi,branch\n" + "".join(f"{p},{0.5 + 0.02 * i},loading\n"
                                                    for i, p in enumerate([0.01, 0.02, 0.04, 0.08, 0.16, 0.5, 1])))
    return path


def refused(r, *words):
    assert r.returncode == 2, (r.returncode, r.stderr)
    assert "Traceback" not in r.stderr, r.stderr
    assert all(w in r.stderr for w in words), r.stderr


def test_plot_into_a_missing_folder(grains_bin, tmp_path):
    run = tmp_path / "c.h5"
    r = subprocess.run([grains_bin, "run", str(ROOT / "models" / "collision.toml"), "--out", str(run), "--quiet",
                        "--set", "time.duration=0.1"], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    refused(tool("plot.py", run, "-o", tmp_path / "missing" / "c.png"), "--out", str(tmp_path / "missing"), "does not exist")


def test_consolidation_fit_into_a_missing_folder(stage_table, tmp_path):
    refused(tool("consolidation_fit.py", stage_table, "-o", tmp_path / "missing" / "fit.png"), "--out",
            str(tmp_path / "missing"), "does not exist")
    assert tool("consolidation_fit.py", stage_table, "-o", tmp_path / "fit.png").returncode == 0


def test_consolidation_fit_of_a_table_with_ragged_rows(tmp_path):
    """A file whose rows have more fields than its first line (markdown, a log): named, not a TypeError."""
    odd = tmp_path / "notes.md"
    odd.write_text("Notes\nfirst, second\n")
    refused(tool("consolidation_fit.py", odd), "needs a header with columns P_star")


@pytest.mark.parametrize("option", ["-o", "--table"])
def test_density_correlations_into_a_missing_folder(tmp_path, option):
    data = tmp_path / "stages.h5"
    data.write_bytes(b"")   # the output folder is checked before the input is read
    refused(tool("density_correlations.py", data, option, tmp_path / "missing" / "x.out"), option,
            str(tmp_path / "missing"), "does not exist")


@pytest.mark.parametrize("script", ["consolidation_campaign.py", "initial_states.py", "aggregation_sweep.py"])
def test_report_of_a_missing_folder_says_so_and_creates_nothing(tmp_path, script):
    """--report only reads: a folder that is not there is named, not created empty."""
    missing = tmp_path / "no-such-campaign"
    refused(tool(script, "--report", "--out", missing), "--report: no folder", str(missing))
    assert not missing.exists()


def test_plot_to_an_unsupported_format(grains_bin, tmp_path):
    """-o with an extension matplotlib cannot write: the option and the formats named, before any work."""
    run = tmp_path / "c.h5"
    r = subprocess.run([grains_bin, "run", str(ROOT / "models" / "collision.toml"), "--out", str(run), "--quiet",
                        "--set", "time.duration=0.1"], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    refused(tool("plot.py", run, "-o", tmp_path / "c.h5x"), "-o/--out", "c.h5x", ".png", ".pdf", ".svg")
    assert not (tmp_path / "c.h5x").exists()


def test_plot_never_writes_over_its_run_file_or_into_a_folder(grains_bin, tmp_path):
    """A run file named RUN.png must not be replaced by its own plot (the default image is RUN with .png), nor a
    folder at the image's name meet matplotlib's IsADirectoryError after the figure is drawn; an --observables of
    commas alone must not fall back to the default panels."""
    run = tmp_path / "c.png"
    r = subprocess.run([grains_bin, "run", str(ROOT / "models" / "collision.toml"), "--out", str(run), "--quiet",
                        "--set", "time.duration=0.1", "--set", "output.xdmf=false"], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    before = run.read_bytes()
    refused(tool("plot.py", run), "the image", "is the run file itself", "-o")
    refused(tool("plot.py", run, "-o", run), "is the run file itself")
    assert run.read_bytes() == before
    (tmp_path / "folder.png").mkdir()
    refused(tool("plot.py", run, "-o", tmp_path / "folder.png"), "-o/--out", "folder.png' is a folder")
    refused(tool("plot.py", run, "-o", tmp_path / "c-plot.png", "--observables", ",,"), "--observables ',,': no name in it")


@pytest.mark.parametrize("script", ["consolidation_campaign.py", "initial_states.py", "aggregation_sweep.py"])
def test_campaign_tools_name_bad_arguments_in_a_line(grains_bin, tmp_path, script):
    """An override the engine refuses (its message), --out naming a file, --grains naming a file that is not
    executable: exit status 2 and a message, no traceback, nothing run."""
    afile = tmp_path / "afile"
    afile.write_text("")
    refused(tool(script, "--grains", grains_bin, "--out", afile), "--out", str(afile), "not a folder")
    refused(tool(script, "--grains", afile, "--out", tmp_path / "a"), "--grains", str(afile), "not executable")
    refused(tool(script, "--grains", grains_bin, "--out", tmp_path / "b", "--set", "particles.cont=3"),
            "unknown key 'particles.cont'")
    assert not (tmp_path / "b").exists() or not any((tmp_path / "b").iterdir())


@pytest.mark.parametrize("name, args, words", [
    ("bench.py", ["--steps", "0", "--no-lammps"], ["--steps = 0", "at least 1"]),
    ("bench.py", ["--repeat", "0", "--no-lammps"], ["--repeat = 0"]),   # a table of NaN, exit 0, before
    ("bench_cohesive.py", ["--cells", "0"], ["--cells = 0"]),
    ("bench_consolidation.py", ["settings", "--seeds", "0"], ["--seeds = 0"]),
    ("bench_fmu.py", ["--build", "nosuch"], ["--build nosuch", "no fmus folder"]),
    ("compare_lammps.py", ["--steps", "0"], ["--steps = 0"]),   # "predicts nan", exit 0, before
    ("compare_lammps_rolling.py", ["--seeds", "0"], ["--seeds = 0"]),
    ("compare_lammps_rolling.py", ["--steps", "2100"], ["--steps = 2100", "multiple of 500"]),
    ("compare_lammps_gravity.py", ["--free-fall-times", "0"], ["--free-fall-times 0.0", "> 0"]),
    ("compare_lammps_gravity.py", ["--free-fall-times", "nan"], ["--free-fall-times nan", "finite"]),
    ("compare_lammps_gravity.py", ["--seeds", "1", "1"], ["--seeds 1 1", "each seed once"]),
    ("compare_lammps_gravity.py", ["--binary", "nosuch"], ["--binary", "nosuch", "no such file"]),
])
def test_benchmarks_name_bad_counts_and_paths_in_a_line(tmp_path, name, args, words):
    refused(tool(name, *args, cwd=tmp_path), *words)
    assert not any(tmp_path.iterdir())


@pytest.mark.parametrize("name, args, words", [
    ("consolidation_fit.py", ["{table}", "-o", "{tmp}/fit.txt"], ["--out", "supported image format"]),
    ("density_correlations.py", ["{tmp}/none.h5", "-o", "{tmp}/i.txt"], ["-o/--out", "supported image format"]),
    ("collisions.py", ["{tmp}/none.h5"], ["'{tmp}/none.h5' does not exist"]),
    ("aggregation_sweep.py", ["--stiffness", "inf", "--out", "{tmp}/s"], ["--stiffness", "inf", "finite"]),
    ("bench_cohesive.py", ["--binary", "{tmp}/none"], ["--binary", "no such file"]),
    ("bench.py", ["--binary", "{tmp}/none"], ["--binary", "no such file"]),
    ("bench_consolidation.py", ["throughput", "--grains", "{tmp}/none"], ["--grains", "no such file"]),
    ("bench_fmu.py", ["--threads", "-1"], ["--threads = -1", "at least 1"]),
])
def test_bad_arguments_end_in_one_line_naming_the_option(tmp_path, stage_table, name, args, words):
    """A review's findings: tracebacks, or an error that blamed another option (density_correlations.py's -o)."""
    fill = lambda text: text.format(table=stage_table, tmp=tmp_path)
    r = tool(name, *map(fill, args))
    assert r.returncode in (1, 2) and "Traceback" not in r.stderr, r.stderr
    assert all(fill(w) in r.stderr for w in words), r.stderr


@pytest.mark.parametrize("name, args, lead", [
    ("plot.py", ["{run}"], "run file '{run}'"),
    ("collisions.py", ["{run}"], "run file '{run}'"),
    ("stage_traces.py", ["{run}", "-o", "{tmp}/f.png"], "'{run}'"),
    ("density_correlations.py", ["{run}", "-o", "{tmp}/d.png"], "h5: '{run}'"),
])
@pytest.mark.parametrize("kind", ["folder", "FIFO (named pipe)"])
def test_a_run_file_that_is_not_a_regular_file_is_named_as_what_it_is(tmp_path, name, args, lead, kind):
    """A folder or a FIFO given as the run's file was said not to exist (runner/run_files.py's not_a_run_file, in the
    words of `grains resume`)."""
    run = tmp_path / "run.h5"
    run.mkdir() if kind == "folder" else os.mkfifo(run)
    fill = lambda text: text.format(run=run, tmp=tmp_path)
    r = subprocess.run([sys.executable, str(ROOT / "runner" / name), *map(fill, args)], capture_output=True, text=True,
                       timeout=60)
    refused(r, f"{fill(lead)} is a {kind}: name a regular file, the HDF5 file grains wrote")


def test_collisions_names_a_table_of_another_shape(tmp_path):
    """A /grains/collisions that is not grains' table (a group, a 1-D dataset) is named, not a traceback."""
    import h5py
    for name, make in (("flat", lambda f: f.create_dataset("grains/collisions", data=[1, 2, 3])),
                       ("group", lambda f: f.create_group("grains/collisions"))):
        path = tmp_path / f"{name}.h5"
        with h5py.File(path, "w") as f:
            make(f)
        r = tool("collisions.py", path)
        refused(r, "/grains/collisions is", "not grains' table of 7 numeric columns")


@pytest.mark.parametrize("script, peer", [("bench.py", "gas.lmp"), ("bench_cohesive.py", "disks2d.lmp")])
def test_a_benchmark_refuses_a_peers_folder_given_without_its_input(tmp_path, script, peer):
    """A --peers the user gave without the LAMMPS input would run grains alone, print NaN ratios and exit 0; only the
    default folder may lack it."""
    r = tool(script, "--peers", tmp_path, "--steps", "10")
    refused(r, f"--peers {tmp_path}: no {peer} there")


def test_the_shell_entry_points_answer_help_and_a_missing_script_before_any_setup(tmp_path):
    """main.sh --help must not run the setup and the build, then grains run's help, then plot an old output;
    with_lammps.sh without a script must not fail on an unbound variable after installing LAMMPS."""
    tools = tmp_path / "bin"   # only what the answers need: any setup step (cmake, apt, python) would fail
    tools.mkdir()
    for name in ("cat", "dirname", "ls", "tr"):
        (tools / name).symlink_to(shutil.which(name))
    env = dict(os.environ, PATH=str(tools))
    shell = "/bin/bash"
    helped = subprocess.run([shell, ROOT / "runner/main.sh", "--help"], capture_output=True, text=True, env=env, cwd=tmp_path)
    assert helped.returncode == 0 and helped.stdout.startswith("usage: bash runner/main.sh"), helped.stderr
    for args in ([], ["nope.py"]):
        r = subprocess.run([shell, ROOT / "runner/with_lammps.sh", *args], capture_output=True, text=True, env=env)
        assert r.returncode == 2 and "usage: bash runner/with_lammps.sh SCRIPT.py" in r.stderr, r.stderr


def test_collisions_refuses_an_adhesive_flag_other_than_0_or_1(tmp_path):
    """An adhesive column of 2s summed as it stands would give "adhesive 8 (200.00 %)", exit 0."""
    import h5py
    table = np.array([[0, 1, 0.1, 0.2, 1.0, 0.5, 0], [1, 2, 0.3, 0.4, 1.0, 0.5, 2], [2, 3, 0.5, np.nan, 1.0, 0.0, 0]])
    path = tmp_path / "coll.h5"
    with h5py.File(path, "w") as f:
        f["grains/collisions"] = table
    r = tool("collisions.py", path)
    refused(r, str(path), "/grains/collisions", "adhesive", "row 1", "2", "0 or 1")
    table[1, 6] = 1
    with h5py.File(path, "w") as f:
        f["grains/collisions"] = table
    r = tool("collisions.py", path)
    assert r.returncode == 0 and "adhesive               1  (50.00 %)" in r.stdout, (r.stdout, r.stderr)


@pytest.mark.parametrize("row, words", [([0, 1, 0.1, 0.2, np.nan, 0.5, 0], ["row 0", "impact_speed nan", ">= 0"]),
                                         ([0, 1, 0.1, 0.2, 1.0, -0.5, 0], ["row 0", "rebound_speed -0.5", ">= 0"]),
                                         ([0, 1, 0.3, 0.2, 1.0, 0.5, 0], ["row 0", "ends at 0.2 before it starts (0.3)"])],
                         ids=["nan-impact", "negative-rebound", "ends-first"])
def test_collisions_refuses_a_completed_event_that_grains_cannot_have_written(tmp_path, row, words):
    """A NaN or negative speed must not go into the restitution's mean and quartiles as it stands."""
    import h5py
    path = tmp_path / "coll.h5"
    with h5py.File(path, "w") as f:   # the open event (end NaN, rebound 0) is grains' own and passes
        f["grains/collisions"] = np.array([row, [2, 3, 0.5, np.nan, 1.0, 0.0, 0]])
    refused(tool("collisions.py", path), str(path), "/grains/collisions", *words)


def test_plot_names_an_observable_that_holds_no_numbers(tmp_path):
    """A string-typed observable ended in matplotlib's AttributeError ("only works with the ScalarFormatter")."""
    import h5py
    path = tmp_path / "run.h5"
    with h5py.File(path, "w") as f:
        for name, value in (("kinetic_energy", np.array([b"a"] * 3)), ("pressure", np.arange(3.0))):
            f[f"observables/{name}/step"] = np.arange(3)
            f[f"observables/{name}/time"] = np.arange(3.0)
            f[f"observables/{name}/value"] = value
    r = tool("plot.py", path, "--observables", "kinetic_energy,pressure", "-o", tmp_path / "p.png")
    refused(r, f"'{path}'", "observables/kinetic_energy/value", "|S1", "numbers")
    assert r.stderr.count("\n") == 1 and not (tmp_path / "p.png").exists()
    r = tool("plot.py", path, "--observables", "pressure", "-o", tmp_path / "p.png")
    assert r.returncode == 0, r.stderr
