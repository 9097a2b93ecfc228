"""Disks on a periodic grid: the density field chi that the scattering intensity (density_correlations.py) and the
pores (pore_sizes.py) are taken from."""
import math

import numpy as np


def density_field(positions, radii, edges, spacing):
    """chi on a periodic grid covering the cell [0, L_x) x [0, L_y): 1 where a grid point's centre
    lies inside a disk. Returns chi (n_x by n_y) and the grid's actual spacings (L / n per axis)."""
    edges = np.asarray(edges, float)
    n = np.maximum(np.ceil(edges / spacing).astype(int), 1)
    h = edges / n
    chi = np.zeros(n, dtype=bool)
    wrapped = np.mod(positions, edges)
    for (x, y), r in zip(wrapped, radii):
        ix = np.arange(math.floor((x - r) / h[0] - 0.5), math.ceil((x + r) / h[0] - 0.5) + 1)
        iy = np.arange(math.floor((y - r) / h[1] - 0.5), math.ceil((y + r) / h[1] - 0.5) + 1)
        dx = (ix + 0.5) * h[0] - x
        dy = (iy + 0.5) * h[1] - y
        inside = dx[:, None] ** 2 + dy[None, :] ** 2 <= r * r
        where = np.ix_(np.mod(ix, n[0]), np.mod(iy, n[1]))
        if len(ix) > n[0] or len(iy) > n[1]:   # a disk reaching round the cell onto itself: |= kept one write a point
            np.logical_or.at(chi, where, inside)
        else:
            chi[where] |= inside
    return chi, h
