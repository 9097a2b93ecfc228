"""Strings as h5py reads them from a grains file: fixed length, as grains writes them, come as bytes; variable length,
as older grains wrote them (and h5py writes a str), as str; datasets of them as arrays."""
import numpy as np


def text(value):
    if isinstance(value, np.ndarray):
        value = value.reshape(-1)[0]
    return value.decode() if isinstance(value, bytes) else str(value)
