"""Plot the observables of a grains run.

    python runner/plot.py RUN.h5 [-o OUT.png] [--observables a,b,c] [--x NAME]

Reads observables/<name>/{time,value} from an H5MD file and draws each observable in its own
subplot over a shared time axis (all of them by default, at most 6), or over another observable
recorded at the same times (`--x time_over_free_fall`: against t / t_ff). Prints the PNG path.
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


def plot(series, out, x_name=None, x_values=None):
    import matplotlib

    matplotlib.use("Agg")  # no display needed
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(len(series), 1, sharex=True, squeeze=False, figsize=(7, 2.2 * len(series) + 0.6))
    for ax, (name, (t, v)) in zip(axes[:, 0], series.items()):
        # Vector observables ([frames, k]) get one line per component.
        ax.plot(t if x_values is None else x_values, v, lw=1)
        ax.set_title(name)
        ax.grid(alpha=0.3)
    axes[-1, 0].set_xlabel(x_name or "time")
    fig.tight_layout()
    fig.savefig(out, dpi=120)
    plt.close(fig)


def main(argv=None):
    parser = argparse.ArgumentParser(description="Plot observables from a grains H5MD run file.")
    parser.add_argument("run", help="the run's .h5 file")
    parser.add_argument("-o", "--out", help="PNG to write (default: RUN with .png)")
    parser.add_argument("--observables", help="comma-separated names (default: all, up to 6)")
    parser.add_argument("--x", help="observable for the horizontal axis (default: time)")
    args = parser.parse_args(argv)

    path = Path(args.run)
    if not path.is_file():
        fail(f"run file '{path}' does not exist")
    wanted = [n.strip() for n in args.observables.split(",") if n.strip()] if args.observables else None
    series = read_observables(path, wanted)
    x_values = None
    if args.x:
        x_time, x_values = read_observables(path, [args.x])[args.x]
        for name, (t, _) in series.items():
            if len(t) != len(x_time) or (t != x_time).any():
                fail(f"'{name}' and the x-axis '{args.x}' are not recorded at the same times")
    out = Path(args.out) if args.out else path.with_suffix(".png")
    plot(series, out, args.x, x_values)
    print(out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
