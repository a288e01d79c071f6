"""The pair list's derived structures: each row's touching pairs last, and the halo
slots that a split between threads evaluates twice."""

import numpy as np

from demcal.dem.contact.kernel import HIST_WIDTH
from demcal.dem.neighbours import halo_index, touching_last


def _random_rows(ns, seed, most=6):
    """A half list of ns spheres: row i holds some j > i, ascending."""
    rng = np.random.default_rng(seed)
    rows = [np.sort(rng.choice(np.arange(i + 1, ns), size=min(ns - i - 1, rng.integers(0, most)),
                               replace=False)) for i in range(ns)]
    start = np.concatenate([[0], np.cumsum([len(r) for r in rows])]).astype(np.int64)
    return start, np.concatenate(rows).astype(np.int64)


def test_touching_pairs_go_last_with_their_history():
    start, nbr = _random_rows(150, 5, most=140)   # rows with more than 64 touching
    rng = np.random.default_rng(6)
    hist = rng.normal(size=(nbr.shape[0], HIST_WIDTH))
    hist[:, 7] = rng.random(nbr.shape[0]) < 0.9
    before = {(i, j): hist[p].copy() for i in range(150)
              for p, j in zip(range(start[i], start[i + 1]), nbr[start[i]:start[i + 1]])}
    touching = hist[:, 7].copy()
    nbr2, hist2 = nbr.copy(), hist.copy()
    touching_last(start, nbr2, hist2, 0, 150)
    for i in range(150):
        row = slice(start[i], start[i + 1])
        flags = hist2[row, 7] != 0.0
        assert np.all(np.diff(flags.astype(int)) >= 0)           # open ones, then touching
        assert np.all(np.diff(nbr2[row][~flags]) > 0)             # each group ascending j
        assert np.all(np.diff(nbr2[row][flags]) > 0)
        assert sorted(nbr2[row]) == sorted(nbr[row])
        for p in range(start[i], start[i + 1]):
            assert np.array_equal(hist2[p], before[(i, nbr2[p])])
    assert hist2[:, 7].sum() == touching.sum()


def test_halo_index_lists_every_slot_that_crosses_a_chunk():
    ns = 60
    start, nbr = _random_rows(ns, 3)
    bounds = np.array([0, 7, 7, 30, 41, 60], np.int64)   # an empty chunk too
    chunk = np.searchsorted(bounds, np.arange(ns), side="right") - 1
    halo_rows, halo_row, halo_slots, halo_slot, deferred, deferred_start = halo_index(
        start, nbr, bounds)
    row_of = np.repeat(np.arange(ns), np.diff(start))
    crossing = np.flatnonzero(chunk[row_of] != chunk[nbr])   # in slot order
    for c in range(len(bounds) - 1):
        want = crossing[chunk[nbr[crossing]] == c]
        got = []
        for r in range(halo_rows[c], halo_rows[c + 1]):
            slots = halo_slot[halo_slots[r]:halo_slots[r + 1]]
            assert np.all(row_of[slots] == halo_row[r])
            got.extend(slots)
        assert np.array_equal(got, want)
        assert np.all(np.diff(halo_row[halo_rows[c]:halo_rows[c + 1]]) > 0)
        # the owner of a row numbers its crossing slots from deferred_start, in slot order
        mine = crossing[chunk[row_of[crossing]] == c]
        assert deferred_start[c + 1] - deferred_start[c] == len(mine)
    position = {p: k for k, p in enumerate(crossing)}
    assert [position[p] for p in halo_slot] == list(deferred)


def test_cell_search_finds_every_pair_within_reach_once():
    from demcal.dem.neighbours import build_cells, pair_rows

    rng = np.random.default_rng(8)
    ns = 400
    pos = rng.uniform(0.0, 0.05, size=(ns, 3))
    rad = rng.uniform(0.001, 0.003, size=ns)          # 3:1 radii
    body = np.repeat(np.arange(ns // 2), 2)            # pairs of spheres share a body
    skin = 0.001
    lo, h, dims, rmax, cell_start, cell_order = build_cells(pos, rad, skin, 8 * ns)
    tmp = np.empty((ns, 64), np.int64)
    counts = np.empty(ns, np.int64)
    pair_rows(pos, rad, body, skin, lo, h, dims, rmax, cell_start, cell_order, tmp, counts,
              0, ns)
    assert counts.max() <= 64
    for i in range(ns):
        d = np.linalg.norm(pos - pos[i], axis=1)
        want = np.flatnonzero((d < rad + rad[i] + skin) & (np.arange(ns) > i)
                              & (body != body[i]))
        assert np.array_equal(tmp[i, :counts[i]], want)   # ascending j, each once
