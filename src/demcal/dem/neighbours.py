"""Linked-cell neighbour search with a skin, half lists in CSR form.

A pair (i, j), i < j, of spheres of different bodies is listed when
``|x_i - x_j| < r_i + r_j + skin``. Cells are cubes of side ``h >= 2 r_max + skin`` over
the bounding box of the spheres (enlarged if there would be more than ``max_cells``
cells), so any ratio of radii works (3:1 and beyond; large ratios only cost more pairs
per cell). The list is rebuilt when some sphere has moved more than ``skin / 2`` since
the last build (or a wall has travelled that far).

Building is one search pass into a fixed-width scratch table (one row per sphere, kept
sorted by neighbour index), then the host takes the prefix sum of the counts,
reallocates the CSR arrays when the capacity is too small (growth 1.5x) and packs the
rows (``pack_rows``); a row wider than the table makes the host widen it and search
again (rare: the width follows the longest row seen). Every row is written by one
thread in a fixed order, so the list is identical for any thread count. Contact history
is carried over a rebuild by matching pairs (``carry_history``); then each row puts its
touching pairs last (``touching_last``), both groups in neighbour order.

Wall candidates use the same CSR layout per sphere: wall rows whose distance (from
``demcal.geometry.kernels.wall_distance``) is below ``r + skin``.
"""

import math

import numpy as np
from numba import njit

from demcal.geometry.kernels import wall_distance

from .contact.registry import H_FLAG, VECTOR_COLUMNS


@njit(cache=True, error_model="numpy")
def build_cells(spos, srad, skin, max_cells):
    """Cell grid and a counting sort of the spheres into cells.

    Returns ``(lo, h, dims, rmax, cell_start, cell_order)`` (``rmax`` the largest radius).
    """
    ns = spos.shape[0]
    lo = np.empty(3)
    hi = np.empty(3)
    for k in range(3):
        lo[k] = np.inf
        hi[k] = -np.inf
    rmax = 0.0
    for i in range(ns):
        for k in range(3):
            v = spos[i, k]
            if v < lo[k]:
                lo[k] = v
            if v > hi[k]:
                hi[k] = v
        if srad[i] > rmax:
            rmax = srad[i]
    h = 2.0 * rmax + skin
    dims = np.empty(3, dtype=np.int64)
    while True:
        total = 1
        for k in range(3):
            dims[k] = int((hi[k] - lo[k]) / h) + 1
            total *= dims[k]
        if total <= max_cells:
            break
        h *= 1.01 * (total / max_cells) ** (1.0 / 3.0)
    ncell = dims[0] * dims[1] * dims[2]
    cell_of = np.empty(ns, dtype=np.int64)
    counts = np.zeros(ncell + 1, dtype=np.int64)
    for i in range(ns):
        cx = min(int((spos[i, 0] - lo[0]) / h), dims[0] - 1)
        cy = min(int((spos[i, 1] - lo[1]) / h), dims[1] - 1)
        cz = min(int((spos[i, 2] - lo[2]) / h), dims[2] - 1)
        c = cx + dims[0] * (cy + dims[1] * cz)
        cell_of[i] = c
        counts[c + 1] += 1
    for c in range(ncell):
        counts[c + 1] += counts[c]
    cell_start = counts.copy()
    cursor = counts[:-1].copy()
    cell_order = np.empty(ns, dtype=np.int64)
    for i in range(ns):
        c = cell_of[i]
        cell_order[cursor[c]] = i
        cursor[c] += 1
    return lo, h, dims, rmax, cell_start, cell_order


@njit(cache=True, nogil=True, error_model="numpy")
def pair_rows(spos, srad, sbody, skin, lo_corner, h, dims, rmax, cell_start, cell_order,
              tmp, counts, lo, hi):
    """One pass of the cell search: row i's neighbours j > i (other bodies, within
    ``r_i + r_j + skin``) go to ``tmp[i, :]`` sorted by j, their number to ``counts[i]``.
    A row longer than ``tmp.shape[1]`` is counted in full but stored only up to that
    width; the host then widens ``tmp`` and searches again.

    Sphere i scans the cells that meet the box of half-width ``r_i + r_max + skin``
    around it (its reach to the largest sphere), not always the 27 around its cell:
    a small sphere among large ones scans fewer. Each cell's spheres are listed in
    ascending order (``build_cells``), so the scan of a cell stops at i."""
    d0 = dims[0]
    d1 = dims[1]
    d2 = dims[2]
    width = tmp.shape[1]
    for i in range(lo, hi):
        xi = spos[i, 0]
        yi = spos[i, 1]
        zi = spos[i, 2]
        ri = srad[i] + skin
        reach = ri + rmax
        # the cells of x - reach and x + reach, as build_cells places a sphere there
        x0 = max(int((xi - reach - lo_corner[0]) / h), 0)
        x1 = min(int((xi + reach - lo_corner[0]) / h), d0 - 1)
        y0 = max(int((yi - reach - lo_corner[1]) / h), 0)
        y1 = min(int((yi + reach - lo_corner[1]) / h), d1 - 1)
        z0 = max(int((zi - reach - lo_corner[2]) / h), 0)
        z1 = min(int((zi + reach - lo_corner[2]) / h), d2 - 1)
        bi = sbody[i]
        n = 0
        for z in range(z0, z1 + 1):
            for y in range(y0, y1 + 1):
                for x in range(x0, x1 + 1):
                    cc = x + d0 * (y + d1 * z)
                    # a cell lists its spheres in ascending order: walk it down to i
                    for k in range(cell_start[cc + 1] - 1, cell_start[cc] - 1, -1):
                        j = cell_order[k]
                        if j <= i:
                            break
                        if sbody[j] == bi:
                            continue
                        ddx = spos[j, 0] - xi
                        ddy = spos[j, 1] - yi
                        ddz = spos[j, 2] - zi
                        cut = ri + srad[j]
                        if ddx * ddx + ddy * ddy + ddz * ddz < cut * cut:
                            if n < width:
                                # insertion into the sorted row (rows are short)
                                q = n - 1
                                while q >= 0 and tmp[i, q] > j:
                                    tmp[i, q + 1] = tmp[i, q]
                                    q -= 1
                                tmp[i, q + 1] = j
                            n += 1
        counts[i] = n


@njit(cache=True, nogil=True, error_model="numpy")
def pack_rows(tmp, row_start, nbr, lo, hi):
    """Copy the rows of ``tmp`` into the CSR array ``nbr`` at ``row_start``."""
    for i in range(lo, hi):
        a = row_start[i]
        for k in range(row_start[i + 1] - a):
            nbr[a + k] = tmp[i, k]


@njit(cache=True, nogil=True, error_model="numpy")
def carry_history(new_start, new_nbr, new_hist, old_start, old_nbr, old_hist, old_of_new,
                  remap, lo, hi):
    """Copy each surviving contact's history row from the old list to the new one.

    ``old_of_new[i]`` is the old index of new sphere i (-1 for a new sphere). Pair lists
    (``remap`` true): pair (i, j), i < j, was the pair of the old spheres
    ``oi = old_of_new[i]`` and ``oj = old_of_new[j]``, listed in old row ``min(oi, oj)``.
    When a reordering swapped the two sides (``oi > oj``), the vector entries of the row
    (``VECTOR_COLUMNS``, the fields the sub-models declare as vectors of side i:
    tangential displacement of i against j, rolling spring torque on i), change sign;
    the scalars (residual overlap) and the contact flag do not. Wall lists
    (``remap`` false): the entries are wall rows, matched as they are.
    """
    w = new_hist.shape[1]
    for i in range(lo, hi):
        oi = old_of_new[i]
        for p in range(new_start[i], new_start[i + 1]):
            found = -1
            swapped = False
            if oi >= 0:
                oj = old_of_new[new_nbr[p]] if remap else new_nbr[p]
                if oj >= 0:
                    row = oi
                    other = oj
                    if remap and oj < oi:
                        row = oj
                        other = oi
                        swapped = True
                    for q in range(old_start[row], old_start[row + 1]):
                        if old_nbr[q] == other:
                            found = q
                            break
            if found >= 0:
                for k in range(w):
                    new_hist[p, k] = old_hist[found, k]
                if swapped:
                    for k in VECTOR_COLUMNS:
                        new_hist[p, k] = -new_hist[p, k]
            else:
                for k in range(w):
                    new_hist[p, k] = 0.0


@njit(cache=True, nogil=True, error_model="numpy")
def touching_last(row_start, nbr, hist, lo, hi):
    """Reorder each row of [lo, hi) so that the slots flagged as touching
    (``hist[p, H_FLAG]``) come after the others, each group keeping its order (ascending j);
    the history moves along.

    The pair loop branches on whether a slot touches; grouped, the branch changes
    direction about once per row instead of at random (the pair loop is 11 % faster on
    a settled bed, docs/performance.md). Contacts opening and closing between builds
    only blur the grouping.
    """
    w = hist.shape[1]
    keep = np.empty((64, w))
    keep_j = np.empty(64, np.int64)
    for i in range(lo, hi):
        a = row_start[i]
        b = row_start[i + 1]
        n = 0       # touching slots set aside
        m = a       # next place for a slot that does not touch
        for p in range(a, b):
            if hist[p, H_FLAG] != 0.0:
                if n == keep_j.shape[0]:
                    keep = np.concatenate((keep, np.empty((n, w))))
                    keep_j = np.concatenate((keep_j, np.empty(n, np.int64)))
                keep_j[n] = nbr[p]
                for c in range(w):
                    keep[n, c] = hist[p, c]
                n += 1
            else:
                if m != p:
                    nbr[m] = nbr[p]
                    for c in range(w):
                        hist[m, c] = hist[p, c]
                m += 1
        for t in range(n):
            nbr[m + t] = keep_j[t]
            for c in range(w):
                hist[m + t, c] = keep[t, c]


@njit(cache=True, error_model="numpy")
def halo_index(row_start, nbr, bounds):
    """How the half list crosses the chunks ``[bounds[c], bounds[c + 1])`` of a split.

    A slot whose two spheres lie in different chunks (j in a later chunk, as j > i) is
    a *halo slot* of j's chunk, which evaluates it again for j's reaction
    (``forces.pair_forces``). Returns, with halo slots numbered in slot order within
    each target chunk:

    * ``halo_rows[c]:halo_rows[c + 1]``: chunk c's halo rows (ascending row numbers);
    * ``halo_row[r]``: the row of halo row r, its slots
      ``halo_slot[halo_slots[r]:halo_slots[r + 1]]`` (ascending);
    * ``halo_deferred[t]``: where the row's owner leaves slot ``halo_slot[t]``'s new
      history: all halo slots in slot order, chunk c's rows from ``deferred_start[c]``.
    """
    ns = row_start.shape[0] - 1
    nch = bounds.shape[0] - 1
    chunk = np.empty(ns, np.int64)
    for c in range(nch):
        for i in range(bounds[c], bounds[c + 1]):
            chunk[i] = c
    deferred_start = np.zeros(nch + 1, np.int64)
    target_start = np.zeros(nch + 1, np.int64)
    for i in range(ns):
        ci = chunk[i]
        for p in range(row_start[i], row_start[i + 1]):
            cj = chunk[nbr[p]]
            if cj != ci:
                deferred_start[ci + 1] += 1
                target_start[cj + 1] += 1
    for c in range(nch):
        deferred_start[c + 1] += deferred_start[c]
        target_start[c + 1] += target_start[c]
    nx = target_start[nch]
    halo_slot = np.empty(nx, np.int64)
    slot_row = np.empty(nx, np.int64)
    halo_deferred = np.empty(nx, np.int64)
    cursor = target_start[:-1].copy()
    k = 0
    for i in range(ns):
        ci = chunk[i]
        for p in range(row_start[i], row_start[i + 1]):
            cj = chunk[nbr[p]]
            if cj != ci:
                t = cursor[cj]
                halo_slot[t] = p
                slot_row[t] = i
                halo_deferred[t] = k
                cursor[cj] += 1
                k += 1
    # a halo row starts at each chunk's first slot and wherever the row changes
    halo_rows = np.zeros(nch + 1, np.int64)
    halo_row = np.empty(nx, np.int64)
    halo_slots = np.empty(nx + 1, np.int64)
    r = 0
    for c in range(nch):
        halo_rows[c] = r
        for t in range(target_start[c], target_start[c + 1]):
            if t == target_start[c] or slot_row[t] != slot_row[t - 1]:
                halo_row[r] = slot_row[t]
                halo_slots[r] = t
                r += 1
    halo_rows[nch] = r
    halo_slots[r] = nx
    return (halo_rows, halo_row[:r].copy(), halo_slots[:r + 1].copy(), halo_slot,
            halo_deferred, deferred_start)


@njit(cache=True, nogil=True, error_model="numpy")
def wall_rows(spos, srad, skin, wkind, wparams, waabb, tmp, counts, lo, hi):
    """Per sphere, the wall rows within ``r + skin`` into ``tmp[i, :]`` (in wall order)
    and their number into ``counts[i]`` (stored up to ``tmp.shape[1]``, as
    :func:`pair_rows`)."""
    nw = wkind.shape[0]
    width = tmp.shape[1]
    for i in range(lo, hi):
        x = spos[i, 0]
        y = spos[i, 1]
        z = spos[i, 2]
        reach = srad[i] + skin
        n = 0
        for w in range(nw):
            if (x < waabb[w, 0] - reach or y < waabb[w, 1] - reach or z < waabb[w, 2] - reach
                    or x > waabb[w, 3] + reach or y > waabb[w, 4] + reach
                    or z > waabb[w, 5] + reach):
                continue
            d, nx, ny, nz = wall_distance(wkind[w], wparams[w], x, y, z)
            if d < reach:
                if n < width:
                    tmp[i, n] = w
                n += 1
        counts[i] = n


def prefix_sum(row_start):
    """In-place cumulative sum of counts stored at ``row_start[1:]``; returns the total."""
    row_start[0] = 0
    np.cumsum(row_start[1:], out=row_start[1:])
    return int(row_start[-1])


def grown(capacity: int, needed: int) -> int:
    """New capacity when ``needed`` entries do not fit (1.5x growth)."""
    return max(needed, int(math.ceil(1.5 * max(capacity, 16))))
