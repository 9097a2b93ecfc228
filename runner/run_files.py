"""What the tools read of a grains run's HDF5 file before its data: what the path holds (a FIFO or a folder is named,
not opened), the run's status (whether it ended), the scene it ran, and a read that works while the run still writes
the file."""
import os
import stat
import time
import tomllib
from pathlib import Path


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
    socket, which grains refuses only when the run gets there (and a tool must not delete a FIFO there). `whose`
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
