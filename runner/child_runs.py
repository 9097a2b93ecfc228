"""Running grains from a tool: its runs as child processes that a SIGTERM or SIGHUP to the tool reaches (each gets
SIGTERM, which grains takes as Ctrl-C), the exceptions for a run interrupted or failed, and a grains command whose
failure ends the tool in one line."""
import signal
import subprocess
import sys
import threading


INTERRUPTED = 130   # the exit status of a run stopped by Ctrl-C, and then of the tool that ran it


class Interrupted(Exception):
    """A run ended by Ctrl-C (exit status 130)."""


class RunFailed(Exception):
    """A run that grains ended with an error; the message names the run and its log."""


_children = set()   # the grains runs under way (run_child), for stop_children_on_term
_children_lock = threading.Lock()


def run_child(command, **kwargs):
    """subprocess.run(command, **kwargs).returncode for a tool's grains runs, which a SIGTERM to the tool reaches."""
    with subprocess.Popen([str(c) for c in command], **kwargs) as child:
        with _children_lock:
            _children.add(child)
        try:
            return child.wait()
        finally:
            with _children_lock:
                _children.discard(child)


def stop_children_on_term():
    """SIGTERM and SIGHUP (unless ignored) stop the tool as Ctrl-C does: its grains runs get SIGTERM, which they take
    as Ctrl-C (a checkpoint, exit status 130), and the tool ends saying how to go on, rather than leave its runs
    going on alone after it, their tables left half-written."""
    def stop(signum, frame):
        with _children_lock:
            for child in _children:
                child.send_signal(signal.SIGTERM)
        raise KeyboardInterrupt
    for sig in (signal.SIGTERM, signal.SIGHUP):
        if signal.getsignal(sig) is not signal.SIG_IGN:
            signal.signal(sig, stop)


def run_grains(prog, command):
    """Runs a grains command and returns what it printed; a failure ends the tool with grains' own reason (one line,
    no traceback)."""
    done = subprocess.run([str(c) for c in command], capture_output=True, text=True)
    if done.returncode != 0:   # grains' stderr may hold warnings and a heading before its reason: one line of all
        said = "; ".join(line.strip(" -") for line in done.stderr.splitlines() if line.strip())
        sys.exit(f"{prog}: grains {command[1]} ended with status {done.returncode}: {said or 'it said nothing'}")
    return done.stdout
