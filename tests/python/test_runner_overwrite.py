"""`grains run` and `grains consolidate` do not write over an output that `grains resume` could continue, unless
given --overwrite: running a scene again after an interruption replaced its checkpoint without a word (the default
output name is <scene.name>.h5). Any other existing output is replaced as before."""
import hashlib
import os
import pathlib
import re
import signal
import subprocess
import sys
import time

import h5py
import pytest

from h5text import text
from interrupt import interrupted


def run(*args, cwd=None):
    return subprocess.run([str(a) for a in args], capture_output=True, text=True, cwd=cwd, timeout=600)


def status(path):
    with h5py.File(path) as f:
        return text(f["grains"].attrs["status"])


def digest(path):
    return hashlib.sha256(path.read_bytes()).hexdigest()


def last_step(path):
    with h5py.File(path) as f:
        return int(f["observables/kinetic_energy/step"][-1])


def refusal(path, where, source="--out", other="--out"):
    return (f"error: {source}: output file '{path}' holds {where}; not written over: continue it with `grains resume "
            f"{path}`, or replace it with --overwrite (or name another file: {other})")


def test_a_run_is_not_written_over_an_interrupted_one_unless_told_to(grains_bin, root, tmp_path):
    """The issue's repro: the aggregation scene stopped by Ctrl-C, then run again with other settings. Refused under
    the default name and under --out, naming the step it stopped at and the run's length, the file untouched;
    --overwrite replaces it; the complete output that leaves, and a file that is no grains output, are replaced as
    before."""
    scene = root / "models/aggregation.toml"
    first = ["--set", "particles.count=600", "--set", "run.threads=1"]
    default = tmp_path / "aggregation.h5"   # <scene.name>.h5 in the folder grains runs in
    code, out, err = interrupted([grains_bin, "run", scene, *first], default, 0.3, cwd=tmp_path)
    assert code == 130, "the run ended before the signal: make it longer\n" + err
    stopped_at = int(re.fullmatch(r"interrupted at step (\d+)", status(default)).group(1))
    check = run(grains_bin, "check", scene, *first)
    total = int(re.search(r"`grains run` takes (\d+) steps", check.stdout).group(1))
    assert 0 < stopped_at < total
    before = digest(default), digest(default.with_suffix(".xdmf"))

    where = f"a run interrupted at step {stopped_at} of {total}"
    again = run(grains_bin, "run", scene, "--set", "time.steps=10", cwd=tmp_path)
    assert again.returncode == 1, again.stderr
    assert refusal("aggregation.h5", where, "scene.name (the default output file <scene.name>.h5)") in again.stderr
    named = run(grains_bin, "run", scene, "--set", "time.steps=10", "--out", default)
    assert named.returncode == 1 and refusal(default, where) in named.stderr, named.stderr
    checked = run(grains_bin, "check", scene, "--set", "time.steps=10", cwd=tmp_path)   # warns, as run would refuse
    assert checked.returncode == 0 and "warning: grains run would refuse its output file: scene.name" in checked.stderr
    assert (digest(default), digest(default.with_suffix(".xdmf"))) == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["aggregation.h5", "aggregation.xdmf"]   # no .part left

    replaced = run(grains_bin, "run", scene, "--set", "time.steps=10", "--out", default, "--overwrite", "--quiet")
    assert replaced.returncode == 0, replaced.stderr
    assert status(default) == "complete" and last_step(default) == 10
    # A complete output, and a file that is not a grains output, are written over without --overwrite.
    rerun = run(grains_bin, "run", scene, "--set", "time.steps=20", "--out", default, "--quiet")
    assert rerun.returncode == 0 and status(default) == "complete" and last_step(default) == 20, rerun.stderr
    foreign = tmp_path / "notes.h5"
    foreign.write_text("not HDF5\n")
    assert run(grains_bin, "run", scene, "--set", "time.steps=10", "--out", foreign, "--quiet").returncode == 0
    assert status(foreign) == "complete"


def test_a_killed_run_with_a_checkpoint_is_not_written_over(grains_bin, root, tmp_path):
    """A run killed outright (status still 'running') that left a checkpoint (output.checkpoint_every) is as
    resumable as an interrupted one: refused, naming its status and its newest checkpoint's step."""
    gas = [root / "models/gas.toml", "--set", "particles.count=512", "--set", "time.steps=700000",
           "--set", "output.checkpoint_every=500", "--set", "run.threads=1", "--quiet"]
    out = tmp_path / "killed.h5"
    p = subprocess.Popen([str(grains_bin), "run", *map(str, gas[:1]), "--out", str(out), *gas[1:]],
                         stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    deadline = time.monotonic() + 60
    while not out.exists() and time.monotonic() < deadline and p.poll() is None:
        time.sleep(0.05)
    time.sleep(1.0)
    p.send_signal(signal.SIGKILL)
    p.wait(timeout=60)
    assert p.returncode == -signal.SIGKILL and status(out) == "running"
    with h5py.File(out) as f:
        steps = [int(f[f"grains/checkpoint_{k}"].attrs["step"]) for k in (0, 1)
                 if f"grains/checkpoint_{k}" in f and f[f"grains/checkpoint_{k}"].attrs["valid"] == 1]
    assert steps, "killed before its first checkpoint: wait longer"
    before = digest(out)
    again = run(grains_bin, "run", *gas, "--out", out)
    assert again.returncode == 1, again.stderr
    where = f"a run that did not finish (status 'running'), with a checkpoint at step {max(steps)} of 700000"
    assert refusal(out, where) in again.stderr and digest(out) == before


def test_consolidate_is_not_written_over_an_interrupted_programme_unless_told_to(grains_bin, root, tmp_path):
    """`grains consolidate` (and `grains run` into the same file) refuse an interrupted programme's output, naming
    its step and how many of its stages had finished; --overwrite replaces it."""
    scene = root / "models/consolidation.toml"
    small = ["--set", "particles.count=200", "--set", "programme.top_pressure=0.02", "--set",
             "programme.stage_budget=20000", "--set", "run.threads=1", "--quiet"]
    stopped, table = tmp_path / "stopped.h5", tmp_path / "stopped.csv"
    code, out, err = interrupted([grains_bin, "consolidate", scene, "--out", stopped, "--table", table, *small],
                                 stopped, 0.5)
    assert code == 130, "the programme ended before the signal\n" + err
    step = int(re.fullmatch(r"interrupted in stage 0 at step (\d+)", status(stopped)).group(1))
    stages = int(re.search(r"stages +0 of (\d+) finished", out).group(1))
    before = digest(stopped), table.read_text()

    where = f"a consolidation programme interrupted at step {step}, 0 stage(s) of its {stages} finished"
    again = run(grains_bin, "consolidate", scene, "--out", stopped, "--table", tmp_path / "other.csv", *small)
    assert again.returncode == 1, again.stderr
    assert refusal(stopped, where, other="--out and --table") in again.stderr
    plain = run(grains_bin, "run", root / "models/gas.toml", "--set", "time.steps=10", "--out", stopped)
    assert plain.returncode == 1 and refusal(stopped, where) in plain.stderr, plain.stderr
    assert (digest(stopped), table.read_text()) == before and not (tmp_path / "other.csv").exists()

    type1 = ["--set", "particles.count=60", "--set", "programme.load=false", "--set", "programme.unload=false",
             "--set", "programme.stage_budget=2000", "--quiet"]
    replaced = run(grains_bin, "consolidate", root / "models/consolidation-type1.toml", "--out", stopped, "--table",
                   table, "--overwrite", *type1)
    assert replaced.returncode == 0, replaced.stderr
    assert status(stopped).startswith("complete")


def test_main_sh_run_again_resumes_its_interrupted_run(grains_bin, root, tmp_path, monkeypatch):
    """The README's main command run again after Ctrl-C goes on with the run it left (grains resume) when the
    scene and the --set overrides are those of that run; with others, grains run refuses, and --overwrite (passed
    through) starts afresh. Before, the second command replaced the interrupted run."""
    # This build and this environment, for main.sh's setup (it builds and installs what is missing).
    monkeypatch.setenv("GRAINS_BUILD", str(pathlib.Path(grains_bin).parents[1]))
    monkeypatch.setenv("GRAINS_VENV", str(pathlib.Path(sys.executable).parents[1]))
    if not (pathlib.Path(os.environ["GRAINS_VENV"]) / "bin" / "python").exists():
        pytest.skip("not run from the project's virtual environment")
    out = tmp_path / "m.h5"
    scene = root / "models" / "aggregation.toml"
    main = ["bash", root / "runner" / "main.sh", scene, "--out", out, "--set", "particles.count=600",
            "--set=run.threads=1"]

    def main_sh(*extra):
        return subprocess.run([str(a) for a in main + list(extra)], capture_output=True, text=True, timeout=600)

    code, _, err = interrupted(main + ["--quiet"], out, 0.3, group=True)
    assert code == 130 and status(out).startswith("interrupted at step "), err
    step = int(status(out).split()[-1])
    check = run(grains_bin, "check", scene, "--set", "particles.count=600")
    total = int(re.search(r"`grains run` takes (\d+) steps", check.stdout).group(1))
    before = digest(out)
    other = main_sh("--set", "time.steps=10", "--quiet")
    assert other.returncode == 1, other.stderr
    assert refusal(out, f"a run interrupted at step {step} of {total}") in other.stderr
    assert digest(out) == before and not out.with_suffix(".png").exists()
    # An argument main.sh does not read (a misspelt option, a scene after the options) goes to grains run, which
    # refuses it: a resume passed over it and went on with the run.
    for unread in (["--quite"], [scene]):
        typo = main_sh(*unread)
        assert typo.returncode != 0 and "resuming it" not in typo.stderr, typo.stderr
        assert "not expected" in typo.stderr and str(unread[0]) in typo.stderr, typo.stderr
        assert digest(out) == before
    again = main_sh()
    assert again.returncode == 0, again.stderr
    assert "resuming it" in again.stderr and f"resumed      at step {step}" in again.stdout
    assert status(out) == "complete" and out.with_suffix(".png").stat().st_size > 1000
    fresh = main_sh("--set", "time.steps=10", "--overwrite", "--quiet")
    assert fresh.returncode == 0 and last_step(out) == 10, fresh.stderr
