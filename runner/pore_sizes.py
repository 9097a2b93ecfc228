"""The pores of a 2D disk packing and their mass-averaged radius of gyration xi' (physics.md section 9; the
consolidation paper, section IV: "the (mass) averaged radius of gyration of pores", an alternative blob size,
xi' ~ xi at P* = 0.01 and below xi under higher pressures).

A pore is a connected region of the space the disks leave free, in the periodic cell. On a grid of spacing h
(a / points_per_diameter, a the largest diameter) a point is solid when its centre lies within R + h / 4 of a
disk's centre (disk_grid.py's field of the disks grown by h / 4): the quarter cell seals every contact (two
touching disks leave a cusp of free space at their contact point, and a grid point there joined the pores on
either side), and closes gaps narrower than h / 2 and, as the grid falls, some up to about h. Free points are joined to their four neighbours, across the cell's edges
too. Each pore's radius of gyration Rg is taken about its own centre of mass, its points unwrapped across the
edges; xi' = sum(A Rg) / sum(A) over the pores, A a pore's area. A pore that joins itself across the cell (the
free space percolates, as in a loose gas) has no centre and no size: it is left out of xi' and its share of
the free area reported.
"""
import math
import pathlib
import sys

import numpy as np
from scipy import ndimage

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent))
from disk_grid import density_field  # noqa: E402


def free_space(positions, radii, edges, spacing):
    """The grid's free points (True where no disk grown by the seal, a quarter of `spacing`, covers the point's
    centre), n_x by n_y, and the grid's actual spacings (L / n per axis, at most `spacing`)."""
    solid, h = density_field(positions, np.asarray(radii, float) + 0.25 * spacing, edges, spacing)
    return ~solid, h


def periodic_pores(free):
    """Labels of the free points' pores on the periodic grid (0: solid), each point's image shift (in cells, per
    axis) that unwraps its pore, and the set of labels of pores that join themselves across the cell."""
    labels, count = ndimage.label(free)   # four neighbours, within the grid
    parent = np.arange(count + 1)
    shift = np.zeros((count + 1, 2), dtype=np.int64)   # a label's frame, in its parent's frame
    percolating_roots = set()

    def find(a):   # root of a, and a's frame in the root's frame
        total = np.zeros(2, dtype=np.int64)
        while parent[a] != a:
            total += shift[a]
            a = parent[a]
        return a, total

    def join(a, b, offset):   # label b's frame is label a's plus offset (cells)
        ra, sa = find(a)
        rb, sb = find(b)
        if ra == rb:
            if np.any(sb - sa != offset):   # met itself in another image: it wraps around the cell
                percolating_roots.add(ra)
            return
        parent[rb] = ra
        shift[rb] = sa + offset - sb
        if rb in percolating_roots:
            percolating_roots.discard(rb)
            percolating_roots.add(ra)

    n_x, n_y = free.shape
    # point (n_x - 1, j) sits next to (0, j) of the next image along x: label there = this frame + (1, 0)
    for j in np.nonzero(free[-1, :] & free[0, :])[0]:
        join(labels[-1, j], labels[0, j], np.array([1, 0]))
    for i in np.nonzero(free[:, -1] & free[:, 0])[0]:
        join(labels[i, -1], labels[i, 0], np.array([0, 1]))
    roots, frames = np.zeros(count + 1, dtype=np.int64), np.zeros((count + 1, 2), dtype=np.int64)
    for label in range(1, count + 1):
        roots[label], frames[label] = find(label)
    percolating = {int(r) for r in percolating_roots}
    return roots[labels], frames[labels], percolating


def pore_sizes(positions, radii, edges, points_per_diameter=16):
    """The pores of one configuration: their areas and radii of gyration (enclosed pores only), xi' (area-weighted
    mean radius of gyration, NaN without an enclosed pore) and the share of the free area in pores that join
    themselves across the cell."""
    a = 2 * float(np.max(radii))
    free, h = free_space(positions, radii, edges, a / points_per_diameter)
    pore, frame, percolating = periodic_pores(free)
    where = np.nonzero(free)
    ids = pore[where]
    n = np.array(free.shape)
    # unwrapped point centres: grid position plus the pore's image shift
    x = (where[0] + 0.5 + frame[where][:, 0] * n[0]) * h[0]
    y = (where[1] + 0.5 + frame[where][:, 1] * n[1]) * h[1]
    order = np.unique(ids)
    index = np.searchsorted(order, ids)
    points = np.bincount(index).astype(float)
    mean_x, mean_y = np.bincount(index, x) / points, np.bincount(index, y) / points
    spread = np.bincount(index, (x - mean_x[index]) ** 2 + (y - mean_y[index]) ** 2) / points
    enclosed = np.array([int(p) not in percolating for p in order], dtype=bool)   # (empty: no free space at all)
    area = points * h[0] * h[1]
    gyration = np.sqrt(spread)
    free_area = float(area.sum())
    xi_prime = float(np.sum(area[enclosed] * gyration[enclosed]) / area[enclosed].sum()) if enclosed.any() else math.nan
    return {"xi_prime": xi_prime, "areas": area[enclosed], "radii_of_gyration": gyration[enclosed],
            "pores": int(enclosed.sum()), "percolating_share": float(area[~enclosed].sum()) / free_area if free_area else 0.0,
            "a": a}
