"""Checks of the tools' command-line arguments that end in an argparse error before anything runs: counts of at least
1, the grains program, the --out folder, and --set keys the tool sets itself."""
import os
from pathlib import Path

import run_files


def require_counts(ap, **counts):
    """Exits with an argparse error naming the first option (keyword: its name with _ for -) below 1."""
    for name, value in counts.items():
        if value is not None and value < 1:
            ap.error(f"--{name.replace('_', '-')} = {value}: must be at least 1")


def require_binary(ap, option, path):
    """Exits with an argparse error when `path`, given by `option`, is no executable file (a folder named as one)."""
    if kind := run_files.not_a_regular_file(path):
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


def refuse_controlled(ap, overrides, controlled):
    """Exits with an argparse error when a --set names a key the tool itself sets for each run (`controlled`: key
    -> the option that sets it): the tool's setting came first and the --set after it silently won (every sample
    of a campaign ran one seed)."""
    for o in overrides:
        key = o.split("=", 1)[0].strip()
        if key in controlled:
            ap.error(f"--set {o}: {key} is set by this tool for each run ({controlled[key]}); drop the --set")
