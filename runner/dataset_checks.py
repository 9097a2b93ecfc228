"""Checks of the datasets in a grains output that its readers (plot.py, stage_traces.py, density_correlations.py)
make before they use them: a value of the wrong kind or shape, rows that do not match their steps, steps that do not
increase end in a FramesError naming the file and the dataset instead of a traceback."""


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
