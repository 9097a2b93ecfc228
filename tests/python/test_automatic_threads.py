"""run.threads = 0 takes its thread count from the processors the process may use (omp_get_num_procs: the
machine, its affinity mask, a container's CPU set), and the bits follow the thread count: the same scene gives
other bits where fewer processors are allowed. A checkpoint records the count, so `grains resume` keeps the
unbroken run's count whatever processors it is given. (README, "Threads" and "Across processors".)"""
import os
import re
import subprocess

import h5py
import numpy as np
import pytest

from interrupt import interrupted, run

# The frictional gas: 17,576 spheres, so that the automatic count may take two threads (one per 2000 particles).
SETS = ["--set", "output.observables_every=20", "--set", "output.snapshots_every=100"]

pytestmark = pytest.mark.skipif(not hasattr(os, "sched_getaffinity") or len(os.sched_getaffinity(0)) < 2,
                                reason="needs two processors in the affinity mask")


def on_one_processor():
    cpu = min(os.sched_getaffinity(0))
    return lambda: os.sched_setaffinity(0, {cpu})


def threads_used(stdout):
    return int(re.search(r"(\d+) thread\(s\)", stdout).group(1))


def frames(path):
    with h5py.File(path) as f:
        return {k: f[f"particles/all/{k}/value"][()] for k in ("position", "velocity")}


def test_automatic_thread_count_follows_the_processors_allowed(grains_bin, root, tmp_path):

    scene = root / "models" / "gas-friction.toml"
    SHORT = SETS + ["--set", "time.steps=100"]
    both = run(grains_bin, "run", scene, *SHORT, "--out", tmp_path / "both.h5")
    assert both.returncode == 0, both.stderr
    one = subprocess.run([grains_bin, "run", scene, *SHORT, "--out", tmp_path / "one.h5"], capture_output=True,
                         text=True, preexec_fn=on_one_processor())
    assert one.returncode == 0, one.stderr
    assert threads_used(both.stdout) == 2 and threads_used(one.stdout) == 1
    with h5py.File(tmp_path / "one.h5") as f:   # the file keeps the scene's 0; the checkpoint, the count used
        assert f["parameters/scene.toml"][()].decode().count("threads = 0") == 1


def test_resume_keeps_the_checkpoints_thread_count_on_fewer_processors(grains_bin, root, tmp_path):

    scene = root / "models" / "gas-friction.toml"
    longer = SETS + ["--set", "time.steps=3000"]
    whole, stopped = tmp_path / "whole.h5", tmp_path / "stopped.h5"
    assert run(grains_bin, "run", scene, *longer, "--out", whole).returncode == 0
    code, _, err = interrupted([grains_bin, "run", scene, *longer, "--out", stopped], stopped, after=0.3)
    if code == 0:
        pytest.skip("the run ended before SIGINT reached it")
    assert code == 130, err
    resumed = subprocess.run([grains_bin, "resume", stopped], capture_output=True, text=True,
                             preexec_fn=on_one_processor())
    assert resumed.returncode == 0, resumed.stderr
    assert threads_used(resumed.stdout) == 2
    a, b = frames(whole), frames(stopped)
    for k in a:
        assert np.array_equal(a[k], b[k]), k
