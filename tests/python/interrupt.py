"""Running the grains command from the tests: to its end (run), or sending it Ctrl-C once it has started
writing (interrupted, shared by the tests of stopping and resuming)."""
import os
import signal
import subprocess
import time

import pytest


def run(grains_bin, *args, cwd=None):
    """Runs grains with `args` to its end, its output captured as text; `cwd`: the folder it runs in."""
    return subprocess.run([grains_bin, *map(str, args)], capture_output=True, text=True, cwd=cwd)


def interrupted(cmd, out, after, within=60, group=False, cwd=None):
    """Starts cmd, sends it SIGINT `after` seconds after its output file appears, and fails the test unless it
    ends within `within` seconds of the signal; returns (code, stdout, stderr). With `group`, cmd runs in a
    process group of its own and the signal goes to the whole group, as Ctrl-C in a terminal does (to a tool
    and the runs it started). `cwd`: the folder cmd runs in (where a default output name lands)."""
    p = subprocess.Popen([str(c) for c in cmd], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                         start_new_session=group, cwd=cwd)
    deadline = time.monotonic() + 60
    while not out.exists() and time.monotonic() < deadline and p.poll() is None:
        time.sleep(0.05)
    time.sleep(after)
    if group:
        os.killpg(p.pid, signal.SIGINT)
    else:
        p.send_signal(signal.SIGINT)
    try:
        stdout, stderr = p.communicate(timeout=within)
    except subprocess.TimeoutExpired:
        p.kill()
        p.communicate()
        pytest.fail(f"{cmd[1]} did not stop within {within} s of SIGINT")
    return p.returncode, stdout, stderr
