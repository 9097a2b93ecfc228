"""Plot the observables of a grains run.

    python runner/plot.py RUN.h5 [-o OUT.png] [--observables a,b,c]

Reads observables/<name>/{time,value} from an H5MD file and draws each observable in its own
subplot over a shared time axis (all of them by default, at most 6). Prints the PNG path.
Exits with code 2 and a message naming the file when it is missing or holds no observables.
"""
import argparse
import sys
from pathlib import Path

MAX_PANELS = 6


def fail(message):
    print(f"plot.py: {message}", file=sys.stderr)
    sys.exit(2)


def read_observables(path, wanted):
    """Returns {name: (time, value)} in file order, or the requested order when names are given."""
    import h5py  # imported late so --help works without it

    try:
        f = h5py.File(path, "r")
    except OSError as e:
        fail(f"cannot open '{path}' as HDF5: {e}")
    with f:
        group = f.get("observables")
        available = list(group.keys()) if isinstance(group, h5py.Group) else []
        if not available:
            fail(f"'{path}' has no observables")
        names = wanted or available[:MAX_PANELS]
        missing = [n for n in names if n not in available]
        if missing:
            fail(f"'{path}' has no observable {', '.join(missing)} (available: {', '.join(available)})")
        return {n: (group[n]["time"][()], group[n]["value"][()]) for n in names}


def plot(series, out):
    import matplotlib

    matplotlib.use("Agg")  # no display needed
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(len(series), 1, sharex=True, squeeze=False, figsize=(7, 2.2 * len(series) + 0.6))
    for ax, (name, (t, v)) in zip(axes[:, 0], series.items()):
        # Vector observables ([frames, k]) get one line per component.
        ax.plot(t, v, lw=1)
        ax.set_title(name)
        ax.grid(alpha=0.3)
    axes[-1, 0].set_xlabel("time")
    fig.tight_layout()
    fig.savefig(out, dpi=120)
    plt.close(fig)


def main(argv=None):
    parser = argparse.ArgumentParser(description="Plot observables from a grains H5MD run file.")
    parser.add_argument("run", help="the run's .h5 file")
    parser.add_argument("-o", "--out", help="PNG to write (default: RUN with .png)")
    parser.add_argument("--observables", help="comma-separated names (default: all, up to 6)")
    args = parser.parse_args(argv)

    path = Path(args.run)
    if not path.is_file():
        fail(f"run file '{path}' does not exist")
    wanted = [n.strip() for n in args.observables.split(",") if n.strip()] if args.observables else None
    series = read_observables(path, wanted)
    out = Path(args.out) if args.out else path.with_suffix(".png")
    plot(series, out)
    print(out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
