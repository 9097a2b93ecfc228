"""Whether a campaign tool may take a run's output as made with the settings asked for now: the scene the
run ran (its HDF5 file's parameters/scene.toml) against the scene and overrides as `grains check` resolves
them. Shared by runner/consolidation_campaign.py, runner/initial_states.py and runner/aggregation_sweep.py;
the benchmarks take from it the words for a missing LAMMPS peer, and the tools that read a run's file the checks of
its datasets (FramesError, numbers, increasing, one_per_step)."""
import os
import shutil
import signal
import stat
import subprocess
import sys
import threading
import time
import tomllib
from pathlib import Path

# How many threads ran a run is not what it ran: a campaign resumed with other --jobs or --threads reuses it.
IGNORED = {"run.threads"}
INTERRUPTED = 130   # the exit status of a run stopped by Ctrl-C, and then of the tool that ran it


class SceneError(Exception):
    """The engine refused the scene or an override; the message is the engine's."""


class Stale(Exception):
    """A finished run that ran other settings than those asked for now."""


class Interrupted(Exception):
    """A run ended by Ctrl-C (exit status 130)."""


class RunFailed(Exception):
    """A run that grains ended with an error; the message names the run and its log."""


def failed(prog, error):
    """After a failed run: one line naming it and its log instead of a traceback; returns the exit status, 1."""
    print(f"{prog}: error: {error} (finished runs are kept: run the same command again once it is fixed)", file=sys.stderr)
    return 1


def interrupted(prog, kept):
    """After Ctrl-C: says how to go on (`kept`: what a rerun keeps); returns the exit status, 130."""
    print(f"{prog}: interrupted; run the same command again to resume ({kept})", file=sys.stderr)
    return INTERRUPTED


def run_read_only(main, prog):
    """Runs a tool that only reads its inputs (a report, a plot, a fit): Ctrl-C ends it with one line, not a traceback,
    and status 130; there is nothing to resume."""
    try:
        return main()
    except KeyboardInterrupt:
        print(f"{prog}: interrupted; its inputs are unchanged (an output it was writing may be incomplete)", file=sys.stderr)
        return INTERRUPTED


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
    as Ctrl-C (a checkpoint, exit status 130), and the tool ends saying how to go on. Its runs used to go on alone
    after the tool had gone, their tables left half-written."""
    def stop(signum, frame):
        with _children_lock:
            for child in _children:
                child.send_signal(signal.SIGTERM)
        raise KeyboardInterrupt
    for sig in (signal.SIGTERM, signal.SIGHUP):
        if signal.getsignal(sig) is not signal.SIG_IGN:
            signal.signal(sig, stop)


def require_counts(ap, **counts):
    """Exits with an argparse error naming the first option (keyword: its name with _ for -) below 1."""
    for name, value in counts.items():
        if value is not None and value < 1:
            ap.error(f"--{name.replace('_', '-')} = {value}: must be at least 1")


def require_binary(ap, option, path):
    """Exits with an argparse error when `path`, given by `option`, is no executable file (a folder named as one)."""
    import os
    if kind := not_a_regular_file(path):
        ap.error(f"{option} {path} is {kind}, not the grains program (build it: cmake --build build)")
    if not os.path.isfile(path):
        ap.error(f"{option} {path}: no such file (build first: cmake --build build)")
    if not os.access(path, os.X_OK):
        ap.error(f"{option} {path}: not executable")


def check_out(ap, out, report):
    """Refuses an --out that names a file, or, with --report, a folder that is not there (nothing to summarise; an
    empty folder is not left behind)."""
    if report and not Path(out).is_dir():
        ap.error(f"--report: no folder {out}")
    if Path(out).exists() and not Path(out).is_dir():
        ap.error(f"--out {out}: not a folder")


def make_out(ap, out):
    """Makes the --out folder, once nothing is left to refuse (a refused --set left an empty folder behind)."""
    try:
        Path(out).mkdir(parents=True, exist_ok=True)
    except OSError as error:
        ap.error(f"--out {out}: cannot make the folder ({error.strerror})")


def engine_refusal(error):
    """A SceneError's message in one line: the engine's problems without its heading, numbers of more than 16 digits
    shortened (bench_fmu's --duration 1e300 asked for a time.steps of 304 digits)."""
    import re
    lines = str(error).splitlines()   # the engine's heading, then its problems, one a line
    reason = "; ".join(line.strip(" -") for line in lines[1:] or lines)
    return re.sub(r"\d{17,}", lambda m: f"{int(m.group()):.3g}", reason)


def run_grains(prog, command):
    """Runs a grains command and returns what it printed; a failure ends the tool with grains' own reason (one line,
    no traceback)."""
    done = subprocess.run([str(c) for c in command], capture_output=True, text=True)
    if done.returncode != 0:   # grains' stderr may hold warnings and a heading before its reason: one line of all
        said = "; ".join(line.strip(" -") for line in done.stderr.splitlines() if line.strip())
        sys.exit(f"{prog}: grains {command[1]} ended with status {done.returncode}: {said or 'it said nothing'}")
    return done.stdout


def not_a_regular_file(path):
    """What `path` names, its links followed, when that is something other than a regular file ("a folder", "a FIFO
    (named pipe)", "a character device", ...), in the words of grains' own check (engine/io/file_kind.hpp); None for
    a regular file, and for a name that holds nothing or cannot be looked at (opening it then says why)."""
    try:
        mode = os.stat(path).st_mode
    except OSError:
        return None
    if stat.S_ISREG(mode):
        return None
    return ("a folder" if stat.S_ISDIR(mode) else "a FIFO (named pipe)" if stat.S_ISFIFO(mode)
            else "a character device" if stat.S_ISCHR(mode) else "a block device" if stat.S_ISBLK(mode)
            else "a socket" if stat.S_ISSOCK(mode) else "something other than a file")


def not_a_file_to_write(path, whose, to_run):
    """Why a tool cannot write a run's output at `path`, or None: the name holds a folder, a FIFO, a device or a
    socket, which grains refuses only when the run gets there (the tools once deleted a FIFO there). `whose`
    ("a run's", "a sample's") names the file, `to_run` what would run there."""
    kind = not_a_regular_file(path)
    return (f"{path} is {kind}, not {whose} HDF5 file: move it out of the way (or give another --out) to run {to_run}"
            if kind else None)


def not_a_run_file(path):
    """Why `path` is no file to read a grains run from, said after its name, or None for a regular file: "does not
    exist", or what it names when that is not a regular file ("is a FIFO (named pipe): ..."). h5py waits on a FIFO
    until something writes into it."""
    try:
        os.stat(path)
    except (FileNotFoundError, NotADirectoryError):
        return "does not exist"
    except OSError as err:
        return f"cannot be looked at ({err.strerror})"
    kind = not_a_regular_file(path)
    return f"is {kind}: name a regular file, the HDF5 file grains wrote" if kind else None


def ended(h5):
    """Whether grains wrote the file to its end: status 'complete' (a run), or 'complete; ...' (a programme with
    stages short of equilibrium); False for a file that is missing, not a regular file, unreadable, running or
    interrupted."""
    return (run_status(h5) or "").startswith("complete")


def ended_in(f):
    """ended() of a file already open (h5py.File)."""
    return (status_in(f) or "").startswith("complete")


def run_status(h5):
    """The run's status in the file at h5 (status_in), or None where it is no grains output h5py can read (missing,
    not a regular file, unreadable)."""
    import h5py
    if not_a_run_file(h5):
        return None
    try:
        with h5py.File(h5, "r") as f:
            return status_in(f)
    except (OSError, KeyError):
        return None


def status_in(f):
    """The /grains status attribute of a file already open (h5py.File): 'complete...', 'running', 'interrupted at
    step ...', 'failed...'; None without a /grains group."""
    if "grains" not in f:
        return None
    status = f["grains"].attrs.get("status", b"")
    return status.decode() if isinstance(status, bytes) else str(status)


class FramesError(ValueError):
    """A grains output that cannot be read as it stands: the message names the file, the dataset, the value and what
    is allowed (a NaN position, a cell edge of 0, a string observable ended in tracebacks). Raised by the readers of
    frames (density_correlations.read_frames) and of observables (plot.py, stage_traces.py)."""


def numbers(f, path, name, ndim=None):
    """The dataset `name` of the open file f as an array of numbers (of `ndim` dimensions if given: a number, or a
    tuple of those allowed); FramesError else."""
    item = f.get(name)
    if item is None:
        raise FramesError(f"{path}: {name} is missing; need a dataset of numbers")
    if not hasattr(item, "dtype"):
        raise FramesError(f"{path}: {name} is a group; need a dataset of numbers")
    if item.dtype.kind not in "fiu":
        raise FramesError(f"{path}: {name} holds values of type {item.dtype}; need numbers")
    allowed = (ndim,) if isinstance(ndim, int) else ndim
    if allowed is not None and item.ndim not in allowed:
        raise FramesError(f"{path}: {name} has shape {item.shape}; need {' or '.join(map(str, allowed))} dimension(s)")
    return item[()]


def one_per_step(path, name, steps, part, data, why=""):
    """FramesError unless the part `part` (time, value) of the H5MD element `name` holds as many rows as its step;
    `why` is said after (why the rows must match in this file)."""
    if len(data) != len(steps):
        raise FramesError(f"{path}: {name}/{part} holds {len(data)} row(s), {name}/step {len(steps)}; need one per "
                          f"step{why}")


def increasing(path, name, steps):
    """FramesError unless the steps are strictly increasing: frames and observables are matched by their step and
    stages by their order (rotated steps had a tool take stage 1's state for P* = 0.01)."""
    import numpy as np
    if (down := np.flatnonzero(np.diff(steps) <= 0)).size:
        i = int(down[0])
        raise FramesError(f"{path}: {name} is not strictly increasing ({steps[i]} at record {i}, then {steps[i + 1]}); "
                          "grains writes each record at a later step than the one before")


def refuse_controlled(ap, overrides, controlled):
    """Exits with an argparse error when a --set names a key the tool itself sets for each run (`controlled`: key
    -> the option that sets it): the tool's setting came first and the --set after it silently won (every sample
    of a campaign ran one seed)."""
    for o in overrides:
        key = o.split("=", 1)[0].strip()
        if key in controlled:
            ap.error(f"--set {o}: {key} is set by this tool for each run ({controlled[key]}); drop the --set")


def resolve(grains, scene_file, overrides):
    """The scene with the overrides (KEY=VALUE strings) as the engine resolves them, as a dict."""
    cmd = [str(grains), "check", str(scene_file)] + [a for o in overrides for a in ("--set", o)]
    done = subprocess.run(cmd, capture_output=True, text=True)
    if done.returncode != 0:
        raise SceneError(done.stderr.strip() or f"grains check {scene_file} exited with {done.returncode}")
    return tomllib.loads(done.stdout)   # the derived values after the scene are comments


def read_unlocked(h5, read, tries=20):
    """read(file) on h5 opened without HDF5's lock, which the run writing it holds, so that a run still going can be
    read (its scene, written when the file is made; what it has flushed since). Read while that run writes, the
    file may not open ("truncated file") or a read may fail for a moment: tried again, 0.1 s apart; the last
    OSError is raised, at once for a path that is not a regular file."""
    import h5py  # imported late so the tools' --help works without it
    if kind := not_a_regular_file(h5):   # h5py would wait on a FIFO until something writes into it
        raise OSError(f"'{h5}' is {kind}, not an HDF5 file grains wrote")
    for attempt in range(tries):
        try:
            with h5py.File(h5, "r", locking=False) as f:
                return read(f)
        except OSError:
            if attempt == tries - 1:
                raise
            time.sleep(0.1)


def stored(h5):
    """The scene the run in h5 ran, as a dict, also while that run still writes the file (a campaign's --report
    beside the campaign); None when the file is missing, unreadable or holds none."""
    if not Path(h5).is_file():
        return None
    try:
        text = read_unlocked(h5, lambda f: f["parameters/scene.toml"][()])
        return tomllib.loads(text.decode() if isinstance(text, bytes) else str(text))
    except (OSError, KeyError, tomllib.TOMLDecodeError):
        return None


def flat(scene):
    return {f"{section}.{key}": value for section, table in scene.items() for key, value in table.items()}


def difference(now, h5):
    """None when the run in h5 ran the scene `now` (run.threads aside), else what differs, e.g.
    "particles.count = 80 there, 200 now"."""
    then = stored(h5)
    if then is None:
        kind = not_a_regular_file(h5)
        return (f"{h5} is {kind}, not an HDF5 file grains wrote" if kind
                else f"{h5} is missing or holds no scene (parameters/scene.toml)")
    then, now = flat(then), flat(now)
    shown = lambda scene, key: repr(scene[key]) if key in scene else "unset"
    differs = [f"{key} = {shown(then, key)} there, {shown(now, key)} now" for key in sorted(then.keys() | now.keys())
               if key not in IGNORED and repr(then.get(key)) != repr(now.get(key))]   # repr: NaN equals NaN
    if not differs:
        return None
    return "; ".join(differs[:4]) + (f" and {len(differs) - 4} more" if len(differs) > 4 else "")


def peers_folder(ap, given, name, default):
    """The LAMMPS peer inputs' folder: a --peers the user gave must hold `name` (a wrong one ran grains alone, with a
    table of NaN ratios, and exit status 0); the default may lack it (then grains runs alone, with a note)."""
    if given is not None and not (given / name).is_file():
        ap.error(f"--peers {given}: no {name} there (the LAMMPS peer input); give the folder that holds it")
    return given if given is not None else default


def peer_missing(peers, name):
    """What keeps a benchmark from running LAMMPS beside grains, in words: the program or the peer input (the
    LAMMPS inputs live beside the repository, in the workspace's shared/peers, not in it)."""
    if not shutil.which("lmp"):
        return "LAMMPS is not installed (`lmp`: Debian package lammps, or run through runner/with_lammps.sh)"
    return f"no peer input {peers / name} (the LAMMPS inputs are not in the repository: give --peers DIR)"
