"""Where the benchmarks find the LAMMPS peer inputs (--peers), and the words for what keeps them from running LAMMPS
beside grains."""
import shutil


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
