"""Summarise the collision event log of a grains run (scenes with analysis.collision_log = true).

    python runner/collisions.py RUN.h5

Reads /grains/collisions (columns i, j, start, end, impact_speed, rebound_speed, adhesive) and prints
the completed and open events, the adhesive count and fraction, and the realised normal restitution
(rebound / impact speed) and impact speeds as mean and quartiles. Exits with code 2 and a message
when the file or the table is missing, an adhesive flag is other than 0 or 1, or a completed event's speeds are
not finite and >= 0 or its end comes before its start.
"""
import argparse
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import run_files  # noqa: E402
import tool_exits  # noqa: E402


def fail(message):
    print(f"collisions.py: {message}", file=sys.stderr)
    sys.exit(2)


def summary(table):
    done = table[~np.isnan(table[:, 3])]
    n, adhesive = len(done), int(done[:, 6].sum()) if len(done) else 0
    lines = [f"completed collisions   {n}", f"open at the end        {len(table) - n}",
             f"adhesive               {adhesive}" + (f"  ({100 * adhesive / n:.2f} %)" if n else "")]
    hit = done[done[:, 4] > 0]
    if len(hit):
        e = hit[:, 5] / hit[:, 4]
        q = np.percentile(e, [25, 50, 75])
        v = np.percentile(hit[:, 4], [25, 50, 75])
        lines.append(f"realised restitution   mean {e.mean():.3f}, quartiles {q[0]:.3f} {q[1]:.3f} {q[2]:.3f}")
        lines.append(f"impact speed           mean {hit[:, 4].mean():.4g}, quartiles {v[0]:.4g} {v[1]:.4g} {v[2]:.4g}")
    return "\n".join(lines)


def main(argv=None):
    parser = argparse.ArgumentParser(description="Summarise the collision event log of a grains run.")
    parser.add_argument("run", help="the run's .h5 file")
    args = parser.parse_args(argv)
    import h5py

    if problem := run_files.not_a_run_file(args.run):
        fail(f"run file '{args.run}' {problem}")
    try:
        f = h5py.File(args.run, "r")
    except OSError as e:
        fail(f"cannot open '{args.run}' as HDF5: {e}")
    with f:
        if "grains/collisions" not in f:
            fail(f"'{args.run}' has no /grains/collisions table (run the scene with analysis.collision_log = true)")
        table = f["grains/collisions"]
        # seven numeric columns, as grains writes it (a group, or a table of another shape, ended in a traceback)
        if not (hasattr(table, "shape") and len(table.shape) == 2 and table.shape[1] == 7 and table.dtype.kind == "f"):
            shape = f"a dataset of shape {table.shape} and type {table.dtype}" if hasattr(table, "shape") else "a group"
            fail(f"'{args.run}': /grains/collisions is {shape}, not grains' table of 7 numeric columns (i, j, start, end, "
                 "impact_speed, rebound_speed, adhesive)")
        table = table[()]
        # a flag other than 0 or 1 was summed as it stood ("adhesive 8 (200.00 %)")
        if bad := np.flatnonzero((table[:, 6] != 0) & (table[:, 6] != 1)).tolist():
            fail(f"'{args.run}': /grains/collisions column 'adhesive' (the 7th) holds {table[bad[0], 6]:g} at row "
                 f"{bad[0]}" + (f" and {len(bad) - 1} more row(s)" if len(bad) > 1 else "") + ": the flag is 0 or 1")
        # a completed event's speeds are grains' |v_n| (>= 0, finite) and it ends no earlier than it starts: a NaN
        # or negative speed would go into the restitution's mean and quartiles as it stood
        done = np.flatnonzero(~np.isnan(table[:, 3]))
        speeds = table[done][:, 4:6]
        if bad := np.flatnonzero(~(np.isfinite(speeds) & (speeds >= 0)).all(axis=1)).tolist():
            row = int(done[bad[0]])
            fail(f"'{args.run}': /grains/collisions row {row} (a completed event) has impact_speed {table[row, 4]:g} "
                 f"and rebound_speed {table[row, 5]:g}: the speeds are finite and >= 0")
        if bad := np.flatnonzero(~(table[done, 3] >= table[done, 2])).tolist():
            row = int(done[bad[0]])
            fail(f"'{args.run}': /grains/collisions row {row} ends at {table[row, 3]:g} before it starts "
                 f"({table[row, 2]:g}): an event ends at or after its start")
        print(summary(table))
    return 0


if __name__ == "__main__":
    sys.exit(tool_exits.run_read_only(main, "collisions.py"))
