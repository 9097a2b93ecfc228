"""runner/plot.py draws a run that is still going: HDF5 locks a file while grains writes it, and plot.py, which only
reads, had failed on that lock ("unable to lock file") until the run ended."""
import signal
import subprocess
import sys
import time

from conftest import ROOT


def test_plot_of_a_run_still_going(grains_bin, tmp_path):
    out, png = tmp_path / "going.h5", tmp_path / "going.png"
    run = subprocess.Popen([grains_bin, "run", ROOT / "models/collision.toml", "--set", "time.steps=1000000000", "--set",
                            "output.observables_every=10", "--out", out, "--quiet"], stdout=subprocess.DEVNULL,
                           stderr=subprocess.DEVNULL)
    try:
        deadline = time.monotonic() + 60
        while not out.exists() and time.monotonic() < deadline:
            time.sleep(0.05)
        time.sleep(1.5)   # past the first flush of the observables (one a second)
        assert run.poll() is None, "the run ended before it was drawn: make it longer"
        drawn = subprocess.run([sys.executable, ROOT / "runner/plot.py", out, "-o", png], capture_output=True, text=True,
                               timeout=120)
        assert drawn.returncode == 0, drawn.stderr
        assert png.stat().st_size > 0
        assert run.poll() is None
    finally:
        run.send_signal(signal.SIGINT)
        run.wait(timeout=60)
