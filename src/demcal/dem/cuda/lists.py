"""Neighbour lists rebuilt on the device: the CPU search's rows, the same lists.

:class:`DeviceLists` builds, from the spheres on the device, exactly the lists
:class:`demcal.dem.lists.ListBuilder` builds on the host: the cell grid of
``neighbours.build_cells`` (bounds by exact atomic min/max, a counting sort into cells,
each cell then sorted by sphere index), one thread per sphere running the CPU's own
``pair_rows``, ``pack_rows``, ``carry_history`` and ``wall_rows`` (:mod:`.compile`),
each row's touching slots put last as ``touching_last`` does, and the transposed half
list the pair kernel gathers reactions from (:mod:`.kernels`). Counts are summed with
integer atomics and prefix sums, which are exact in any order, and every list is
sorted into the CPU's order, so the lists are the same on every run.

The host reads back three small things per rebuild: the bounds (to size the grid, as
the CPU does), the longest row (to widen the scratch table) and the list sizes (to grow
the arrays, 1.5x as on the CPU).
"""

from __future__ import annotations

import functools
import math

import numpy as np
from numba import cuda

from .. import neighbours as _nl
from ..contact.registry import H_FLAG, HIST_WIDTH
from ..forces import OUT_WIDTH, PAIR_OUT_WIDTH
from .layout import SLOT_OUT_WIDTH
from .compile import device_function
from .kernels import BLOCK, block_max, block_min, blocks

#: Elements per thread in the first and last pass of a prefix sum.
CHUNK = 256


@functools.lru_cache(maxsize=None)
def list_kernels():
    pair_rows = device_function(_nl.pair_rows)
    pack_rows = device_function(_nl.pack_rows)
    carry = device_function(_nl.carry_history)
    wall_rows = device_function(_nl.wall_rows)

    @cuda.jit
    def k_bounds(spos, srad, box):
        # per block first, then one atomic per block and value (exact in any order)
        i = cuda.grid(1)
        inside = i < spos.shape[0]
        for k in range(3):
            lo = block_min(spos[i, k] if inside else math.inf)
            hi = block_max(spos[i, k] if inside else -math.inf)
            if cuda.threadIdx.x == 0:
                cuda.atomic.min(box, k, lo)
                cuda.atomic.max(box, 3 + k, hi)
        r = block_max(srad[i] if inside else 0.0)
        if cuda.threadIdx.x == 0:
            cuda.atomic.max(box, 6, r)

    @cuda.jit
    def k_cells(spos, lo, h, dims, cell_of, counts):
        # neighbours.build_cells: the cell of each sphere, counted
        i = cuda.grid(1)
        if i >= spos.shape[0]:
            return
        cx = min(int((spos[i, 0] - lo[0]) / h), dims[0] - 1)
        cy = min(int((spos[i, 1] - lo[1]) / h), dims[1] - 1)
        cz = min(int((spos[i, 2] - lo[2]) / h), dims[2] - 1)
        c = cx + dims[0] * (cy + dims[1] * cz)
        cell_of[i] = c
        cuda.atomic.add(counts, c + 1, 1)

    @cuda.jit
    def k_fill(cell_of, cursor, order):
        i = cuda.grid(1)
        if i >= cell_of.shape[0]:
            return
        order[cuda.atomic.add(cursor, cell_of[i], 1)] = i

    @cuda.jit
    def k_sort(start, keys, vals):
        # each segment [start[c], start[c + 1]) ascending by key (insertion sort; the
        # segments are short), ``vals`` moved along (unless it has no entries)
        c = cuda.grid(1)
        if c >= start.shape[0] - 1:
            return
        a = start[c]
        b = start[c + 1]
        with_vals = vals.shape[0] > 0
        for p in range(a + 1, b):
            key = keys[p]
            val = vals[p] if with_vals else 0
            q = p - 1
            while q >= a and keys[q] > key:
                keys[q + 1] = keys[q]
                if with_vals:
                    vals[q + 1] = vals[q]
                q -= 1
            keys[q + 1] = key
            if with_vals:
                vals[q + 1] = val

    @cuda.jit
    def k_pair_rows(spos, srad, sbody, skin, lo, h, dims, rmax, cell_start, cell_order,
                    tmp, counts):
        i = cuda.grid(1)
        if i >= spos.shape[0]:
            return
        pair_rows(spos, srad, sbody, skin, lo, h, dims, rmax, cell_start, cell_order, tmp,
                  counts, i, i + 1)

    @cuda.jit
    def k_wall_rows(spos, srad, skin, wkind, wparams, waabb, tmp, counts):
        i = cuda.grid(1)
        if i >= spos.shape[0]:
            return
        wall_rows(spos, srad, skin, wkind, wparams, waabb, tmp, counts, i, i + 1)

    @cuda.jit
    def k_longest(counts, out):
        i = cuda.grid(1)
        n = block_max(float(counts[i]) if i < counts.shape[0] else 0.0)
        if cuda.threadIdx.x == 0:
            cuda.atomic.max(out, 0, int(n))

    @cuda.jit
    def k_pack(tmp, start, nbr, new_hist, old_start, old_nbr, old_hist, old_of_new, remap):
        i = cuda.grid(1)
        if i >= start.shape[0] - 1:
            return
        pack_rows(tmp, start, nbr, i, i + 1)
        carry(start, nbr, new_hist, old_start, old_nbr, old_hist, old_of_new, remap, i, i + 1)

    @cuda.jit
    def k_touching_last(start, nbr, hist, act):
        # neighbours.touching_last, in place: a stable partition of the row (slots not
        # touching first, then the touching ones, each group in neighbour order)
        i = cuda.grid(1)
        if i >= start.shape[0] - 1:
            return
        a = start[i]
        b = start[i + 1]
        m = a       # next place for a slot that does not touch
        for p in range(a, b):
            if hist[p, H_FLAG] != 0.0:
                continue
            if p != m:
                # slot p goes to m; the touching block [m, p) moves up by one
                j = nbr[p]
                for q in range(p, m, -1):
                    nbr[q] = nbr[q - 1]
                nbr[m] = j
                for c in range(HIST_WIDTH):
                    v = hist[p, c]
                    for q in range(p, m, -1):
                        hist[q, c] = hist[q - 1, c]
                    hist[m, c] = v
            m += 1
        for p in range(a, b):
            act[p] = hist[p, H_FLAG] != 0.0

    @cuda.jit
    def k_flags(start, hist, act):
        i = cuda.grid(1)
        if i >= start.shape[0] - 1:
            return
        for p in range(start[i], start[i + 1]):
            act[p] = hist[p, H_FLAG] != 0.0

    @cuda.jit
    def k_outside(spos, lo, hi, out):
        # stepping.rebuild drops the particles that left the domain: the host must
        i = cuda.grid(1)
        if i >= spos.shape[0]:
            return
        for k in range(3):
            if spos[i, k] < lo[k] or spos[i, k] > hi[k]:
                out[0] = 1

    @cuda.jit
    def k_clear(act, n):
        # slots past the list's end are not touching (the CPU builder's act[n:] = False)
        p = cuda.grid(1) + n
        if p < act.shape[0]:
            act[p] = False

    @cuda.jit
    def k_count_j(start, nbr, counts):
        i = cuda.grid(1)
        if i >= start.shape[0] - 1:
            return
        for p in range(start[i], start[i + 1]):
            cuda.atomic.add(counts, nbr[p] + 1, 1)

    @cuda.jit
    def k_fill_j(start, nbr, cursor, tslot, srow):
        i = cuda.grid(1)
        if i >= start.shape[0] - 1:
            return
        for p in range(start[i], start[i + 1]):
            tslot[cuda.atomic.add(cursor, nbr[p], 1)] = p
            srow[p] = i

    @cuda.jit
    def k_scan_chunks(a, partial):
        t = cuda.grid(1)
        lo = t * CHUNK
        if lo >= a.shape[0]:
            return
        hi = min(lo + CHUNK, a.shape[0])
        s = 0
        for k in range(lo, hi):
            s += a[k]
            a[k] = s
        partial[t] = s

    @cuda.jit
    def k_scan_partial(partial):
        if cuda.grid(1) != 0:
            return
        s = 0
        for t in range(partial.shape[0]):
            v = partial[t]
            partial[t] = s
            s += v

    @cuda.jit
    def k_scan_add(a, partial):
        t = cuda.grid(1)
        lo = t * CHUNK
        if lo >= a.shape[0] or t == 0:
            return
        off = partial[t]
        for k in range(lo, min(lo + CHUNK, a.shape[0])):
            a[k] += off

    return dict(bounds=k_bounds, cells=k_cells, fill=k_fill, sort=k_sort,
                pair_rows=k_pair_rows, wall_rows=k_wall_rows, longest=k_longest,
                pack=k_pack, touching_last=k_touching_last, flags=k_flags,
                outside=k_outside, clear=k_clear, count_j=k_count_j, fill_j=k_fill_j, scan_chunks=k_scan_chunks,
                scan_partial=k_scan_partial, scan_add=k_scan_add)


def _launch(kernel, n, *args):
    kernel[blocks(n), BLOCK](*args)


class DeviceLists:
    """Rebuilds the contact lists of a device store (:class:`.backend._Device`)."""

    def __init__(self, row_width: int = 16, wall_width: int = 4):
        self.k = list_kernels()
        self.row_width = row_width
        self.wall_width = wall_width
        self._none = cuda.to_device(np.zeros(0, np.int64))
        self._spare = {}

    def prefix_sum(self, a) -> int:
        """``a[k] = a[0] + ... + a[k]`` in place (``a[0]`` is 0, as ``neighbours.prefix_sum``
        expects); returns the total."""
        n = a.shape[0]
        nchunks = (n + CHUNK - 1) // CHUNK
        partial = cuda.device_array(nchunks, np.int64)
        _launch(self.k["scan_chunks"], nchunks, a, partial)
        self.k["scan_partial"][1, 1](partial)
        _launch(self.k["scan_add"], nchunks, a, partial)
        return int(a[n - 1:n].copy_to_host()[0])

    def _search(self, kernel, width_attr, ns, start, *args):
        """A one-pass row search into a scratch table, widened and searched again when a
        row did not fit (``ListBuilder._search``); the counts end in ``start[1:]``."""
        counts = start[1:]
        while True:
            width = getattr(self, width_attr)
            tmp = cuda.device_array((ns, width), np.int64)
            _launch(kernel, ns, *args, tmp, counts)
            out = cuda.to_device(np.zeros(1, np.int64))
            _launch(self.k["longest"], ns, counts, out)
            longest = int(out.copy_to_host()[0])
            if longest <= width:
                return tmp
            setattr(self, width_attr, int(1.25 * longest) + 1)

    def _cells(self, spos, srad, skin):
        """``neighbours.build_cells`` on the device."""
        ns = spos.shape[0]
        box = cuda.to_device(np.array([np.inf] * 3 + [-np.inf] * 3 + [0.0]))
        _launch(self.k["bounds"], ns, spos, srad, box)
        bx = box.copy_to_host()
        lo, hi, rmax = bx[:3], bx[3:6], float(bx[6])
        max_cells = max(8 * ns, 1000)
        h = 2.0 * rmax + skin
        dims = np.empty(3, np.int64)
        while True:
            total = 1
            for k in range(3):
                dims[k] = int((hi[k] - lo[k]) / h) + 1
                total *= int(dims[k])
            if total <= max_cells:
                break
            h *= 1.01 * (total / max_cells) ** (1.0 / 3.0)
        ncell = int(dims[0] * dims[1] * dims[2])
        d_lo, d_dims = cuda.to_device(lo), cuda.to_device(dims)
        cell_of = cuda.device_array(ns, np.int64)
        cell_start = cuda.to_device(np.zeros(ncell + 1, np.int64))
        _launch(self.k["cells"], ns, spos, d_lo, h, d_dims, cell_of, cell_start)
        self.prefix_sum(cell_start)
        cursor = cuda.device_array(ncell, np.int64)
        cursor.copy_to_device(cell_start[:ncell])
        order = cuda.device_array(ns, np.int64)
        _launch(self.k["fill"], ns, cell_of, cursor, order)
        _launch(self.k["sort"], ncell, cell_start, order, self._none)
        return d_lo, h, d_dims, rmax, cell_start, order

    def _list(self, which, old, start, n, out_width):
        """Arrays for a new list of ``n`` entries: the list before last when it is large
        enough (``ListBuilder``'s spare), else new ones of the old capacity, grown 1.5x
        when short (``neighbours.grown``). The old list becomes the next spare."""
        cap = old["other"].shape[0]
        if n > cap:
            cap = _nl.grown(cap, n)
        spare = self._spare.get(which)
        self._spare[which] = old
        if spare is not None and spare["other"].shape[0] >= cap:
            return dict(spare, start=start)
        return {"start": start, "other": cuda.device_array(cap, np.int64),
                "hist": cuda.device_array((cap, HIST_WIDTH)),
                "out": cuda.to_device(np.zeros((cap, out_width))),
                "act": cuda.to_device(np.zeros(cap, np.bool_))}

    def left_domain(self, dev, domain) -> bool:
        """Whether a sphere lies outside ``domain`` ((lo, hi) [m]; None: no domain), which
        only the host's rebuild handles (it drops the particle)."""
        if domain is None:
            return False
        out = cuda.to_device(np.zeros(1, np.int64))
        lo, hi = (cuda.to_device(np.asarray(v, np.float64)) for v in domain)
        _launch(self.k["outside"], dev.s["pos"].shape[0], dev.s["pos"], lo, hi, out)
        return bool(out.copy_to_host()[0])

    def rebuild(self, dev, skin: float) -> None:
        """New pair and wall lists for the device store ``dev``, history carried."""
        k = self.k
        s, w = dev.s, dev.w
        ns = s["pos"].shape[0]
        old_p, old_q = dev.p, dev.q
        ident = cuda.to_device(np.arange(ns, dtype=np.int64))
        # pairs
        lo, h, dims, rmax, cell_start, order = self._cells(s["pos"], s["radius"], skin)
        start = cuda.to_device(np.zeros(ns + 1, np.int64))
        tmp = self._search(k["pair_rows"], "row_width", ns, start, s["pos"], s["radius"],
                           s["body"], skin, lo, h, dims, rmax, cell_start, order)
        npair = self.prefix_sum(start)
        new_p = self._list("pairs", old_p, start, npair, PAIR_OUT_WIDTH)
        _launch(k["pack"], ns, tmp, start, new_p["other"], new_p["hist"], old_p["start"],
                old_p["other"], old_p["hist"], ident, True)
        _launch(k["touching_last"], ns, start, new_p["other"], new_p["hist"], new_p["act"])
        _launch(k["clear"], new_p["act"].shape[0] - npair, new_p["act"], npair)
        # walls
        wstart = cuda.to_device(np.zeros(ns + 1, np.int64))
        wtmp = self._search(k["wall_rows"], "wall_width", ns, wstart, s["pos"], s["radius"],
                            skin, w["kind"], w["params"], w["aabb"])
        nq = self.prefix_sum(wstart)
        new_q = self._list("walls", old_q, wstart, nq, OUT_WIDTH)
        _launch(k["pack"], ns, wtmp, wstart, new_q["other"], new_q["hist"], old_q["start"],
                old_q["other"], old_q["hist"], ident, False)
        _launch(k["flags"], ns, wstart, new_q["hist"], new_q["act"])
        _launch(k["clear"], new_q["act"].shape[0] - nq, new_q["act"], nq)
        dev.p, dev.q = new_p, new_q
        s["ref"].copy_to_device(s["pos"])
        dev.index = self.transposed(start, new_p["other"], npair)
        dev.npair = npair
        if dev.slot_out.shape[0] < npair:
            dev.slot_out = cuda.device_array((_nl.grown(dev.slot_out.shape[0], npair),
                                              SLOT_OUT_WIDTH))

    def transposed(self, start, nbr, npair):
        """:func:`.backend.transposed` on the device."""
        k = self.k
        ns = start.shape[0] - 1
        tstart = cuda.to_device(np.zeros(ns + 1, np.int64))
        _launch(k["count_j"], ns, start, nbr, tstart)
        self.prefix_sum(tstart)
        cursor = cuda.device_array(ns, np.int64)
        cursor.copy_to_device(tstart[:ns])
        tslot = cuda.device_array(max(npair, 1), np.int64)
        srow = cuda.device_array(max(npair, 1), np.int64)
        _launch(k["fill_j"], ns, start, nbr, cursor, tslot, srow)
        _launch(k["sort"], ns, tstart, tslot, self._none)
        return tstart, tslot, srow

