"""Sending a run Ctrl-C once it has started writing: shared by the tests of stopping and resuming."""
import signal
import subprocess
import time

import pytest


def interrupted(cmd, out, after, within=60):
    """Starts cmd, sends it SIGINT `after` seconds after its output file appears, and fails the test unless it
    ends within `within` seconds of the signal; returns (code, stdout, stderr)."""
    p = subprocess.Popen([str(c) for c in cmd], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    deadline = time.monotonic() + 60
    while not out.exists() and time.monotonic() < deadline and p.poll() is None:
        time.sleep(0.05)
    time.sleep(after)
    p.send_signal(signal.SIGINT)
    try:
        stdout, stderr = p.communicate(timeout=within)
    except subprocess.TimeoutExpired:
        p.kill()
        p.communicate()
        pytest.fail(f"{cmd[1]} did not stop within {within} s of SIGINT")
    return p.returncode, stdout, stderr
