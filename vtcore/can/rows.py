"""Placing a chunk's frames in rows (periods): the pure steps of :class:`~vtcore.can.decode.StreamDecoder`.

Frames arrive sorted by stream (file order within a stream). A stream's frames are chained,
row of a frame = row of the previous frame of the stream + ``round(dt / period)``; a stream
seen for the first time is placed by the nearest reference in time (module docstring of
:mod:`vtcore.can.decode`). Every function here takes arrays and returns arrays; the decoder
keeps the state between chunks.
"""

from __future__ import annotations

import numpy as np


def stream_runs(ks: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``start (M,) bool``: first frame of each stream's run; ``seg (M,) int``: the run's index.

    ks : (M,) int, stream index of each frame, sorted (runs of equal values).
    """
    start = np.r_[True, ks[1:] != ks[:-1]]
    return start, np.cumsum(start) - 1


def out_of_order(ts: np.ndarray, ks: np.ndarray, carry: np.ndarray) -> np.ndarray:
    """``(M,) bool``: frames earlier than an earlier-read frame of their stream.

    ts : (M,) s, timestamps sorted by stream, file order within.
    ks : (M,) int, stream index (runs of equal values).
    carry : (M,) s, the last timestamp of each frame's stream in earlier chunks (-inf: none).

    A segmented running maximum in one pass: each stream's run is offset by ``span`` above
    the one before, so one ``maximum.accumulate`` never carries a maximum across streams.
    """
    start, seg = stream_runs(ks)
    base = min(ts.min(), carry[np.isfinite(carry)].min() if np.isfinite(carry).any() else ts.min())
    a = ts - base
    c = np.where(np.isfinite(carry), carry - base, -1.0)
    span = max(a.max(), c.max()) + 2.0
    off = seg * span
    cm = np.maximum.accumulate(a + off)
    prev = np.maximum(c + off, np.r_[-np.inf, cm[:-1]])
    return (a + off) < prev


def nearest_rows(ref_t: np.ndarray, ref_r: np.ndarray, tf: np.ndarray, period: float) -> np.ndarray:
    """``(F,) int64``: the row of each time ``tf`` (s) counted from the reference nearest it in time.

    ref_t : (R,) s and ref_r : (R,) int, rows known at those times (any order; R may be 0, then
    the earliest of ``tf`` is row 0).
    """
    if len(ref_t) == 0:
        # very first frames: row 0 at the earliest of them
        ref_t, ref_r = np.array([tf.min()]), np.array([0])
    ro = np.argsort(ref_t, kind="stable")
    ref_t, ref_r = ref_t[ro], ref_r[ro]
    j = np.clip(np.searchsorted(ref_t, tf), 1, max(len(ref_t) - 1, 1))
    j0 = np.clip(j - 1, 0, len(ref_t) - 1)
    j1 = np.clip(j, 0, len(ref_t) - 1)
    near = np.where(np.abs(ref_t[j1] - tf) < np.abs(tf - ref_t[j0]), j1, j0)
    return ref_r[near] + np.rint((tf - ref_t[near]) / period).astype(np.int64)


def chain_rows(ts: np.ndarray, ks: np.ndarray, period: float, last_row: np.ndarray, last_t: np.ndarray,
               references) -> np.ndarray:
    """``(M,) int64``: the row of every frame, chained along its stream.

    ts, ks : (M,) s and stream index, sorted by stream, file order within, no out-of-order frame.
    period : s per row.
    last_row, last_t : (K,) per-stream row and time of its last frame in earlier chunks
        (row -1: the stream is new).
    references : ``() -> (list of (R_i,) s arrays, list of (R_i,) int arrays)``, rows known
        outside this chunk (pending and emitted rows); called only when a stream is new here.
    """
    start, seg = stream_runs(ks)
    first = np.flatnonzero(start)
    prev_t = np.r_[ts[0], ts[:-1]]
    inc = np.rint((ts - prev_t) / period).astype(np.int64)
    known_first = last_row[ks[first]] >= 0
    inc[first] = 0
    first_row = np.zeros(len(first), np.int64)
    kf = first[known_first]
    first_row[known_first] = last_row[ks[kf]] + np.rint((ts[kf] - last_t[ks[kf]]) / period).astype(np.int64)
    csum = np.cumsum(inc)
    rows = np.empty(len(ts), np.int64)
    # rows of known streams first: they are references for new ones
    rel = csum - csum[first][seg]
    known_el = known_first[seg]
    rows[known_el] = first_row[seg[known_el]] + rel[known_el]
    if (~known_first).any():
        more_t, more_r = references()
        ref_t = np.concatenate([ts[known_el], *more_t])
        ref_r = np.concatenate([rows[known_el], *more_r])
        nf = first[~known_first]
        first_row[~known_first] = nearest_rows(ref_t, ref_r, ts[nf], period)
        new_el = ~known_el
        rows[new_el] = first_row[seg[new_el]] + rel[new_el]
    return rows


def clock_jumps(t: np.ndarray, before: np.ndarray, after: np.ndarray, limit: float) -> np.ndarray:
    """``(M,) bool``: frames more than ``limit`` s after the median time of the frames around them.

    t : (M,) s, timestamps in file order.
    before, after : (k,) s, the ``k`` frames before and after ``t`` in the log (nan where the log
        has none), so that the vote does not depend on how the log is cut into chunks.
    limit : s (``window`` periods).

    Only frames within ``k`` of a forward step of more than ``limit`` can qualify, so the
    median of the ``2 k + 1`` frames around a frame is evaluated at a handful of places
    (:meth:`vtcore.can.decode.StreamDecoder._clock_jumps` says why this is the rule).
    """
    k = len(before)
    m = len(t)
    ext = np.r_[before, t, after]                    # t[i] is ext[k + i]
    jump = np.zeros(m, bool)
    # forward steps, over the context frames too: a step just before this chunk still
    # makes the next k frames candidates (results must not depend on the chunking)
    prev, cur = ext[:k + m - 1], ext[1:k + m]
    with np.errstate(invalid="ignore"):
        step = (np.isnan(prev) & ~np.isnan(cur)) | (cur - prev > limit)   # nan: the log's first frame
    fwd = np.flatnonzero(step) + 1 - k                                      # index into t of the step
    if len(fwd) == 0:
        return jump
    cand = np.unique((fwd[:, None] + np.arange(k)[None, :]).reshape(-1))
    cand = cand[(cand >= 0) & (cand < m)]
    med = np.nanmedian(ext[cand[:, None] + np.arange(2 * k + 1)[None, :]], axis=1)
    jump[cand] = t[cand] - med > limit
    return jump


def fill_empty_times(tt: np.ndarray, row0: int, period: float, last_emit: tuple[int, float] | None) -> np.ndarray:
    """``(T,)`` s: row times with the rows that got no frame (inf) set to the time of the last row
    before them that had one plus the rows between times ``period``.

    tt : (T,) s, earliest frame time of rows ``row0 .. row0 + T - 1``, inf where none.
    last_emit : (row, time) of the last emitted row that had a frame, or None; with None, the
        first row with a frame here counts back to ``row0 - 1``.
    """
    empty = ~np.isfinite(tt)
    if not empty.any():
        return tt
    upto = len(tt)
    idx = np.arange(upto)
    has = np.where(~empty, idx, -1)
    lastgood = np.maximum.accumulate(has)
    if last_emit is not None:
        ref_row, ref_t = last_emit
    else:
        ref_row, ref_t = row0 - 1, (tt[~empty][0] - period * (np.flatnonzero(~empty)[0] + 1)
                                    if (~empty).any() else 0.0)
    base_t = np.where(lastgood >= 0, tt[np.maximum(lastgood, 0)], ref_t)
    base_r = np.where(lastgood >= 0, lastgood + row0, ref_row)
    return np.where(empty, base_t + (idx + row0 - base_r) * period, tt)


def unit_error_cells(errors: np.ndarray, unit: np.ndarray, columns: np.ndarray, row0: int, n: int):
    """``(rows, cols)`` int arrays: every grid cell of a unit (triangle) in a row where it reported
    an error, to be masked.

    errors : (E, 3) int, ``(row, unit, code)``.
    unit : (K,) int, the unit of each stream; columns : (K, C) int, each stream channel's column
        (-1 none); row0 : row of the grid's first row; n : columns of the grid.
    """
    # the streams of each error's unit by a search in the units' sort order: an (errors x
    # streams) comparison table is a product of two sizes a log sets (64k x 64k in a chunk)
    by_unit = np.argsort(unit, kind="stable")
    lo = np.searchsorted(unit[by_unit], errors[:, 1], "left")
    cnt = np.searchsorted(unit[by_unit], errors[:, 1], "right") - lo
    e_i = np.repeat(np.arange(len(errors)), cnt)                     # pairs (error, stream)
    k_i = by_unit[np.repeat(lo - (np.cumsum(cnt) - cnt), cnt) + np.arange(int(cnt.sum()))]
    cols = columns[k_i]                                              # (pairs, C)
    rws = np.broadcast_to((errors[e_i, 0] - row0)[:, None], cols.shape)
    good = (cols >= 0) & (cols < n)
    return rws[good], cols[good]


def unique_ints(k: np.ndarray) -> np.ndarray:
    """Sorted unique values of an int array; a bincount when the range is small (no sort)."""
    if len(k) == 0:
        return k
    lo, hi = int(k.min()), int(k.max())
    if hi - lo < 4 * len(k) + 65536:
        return np.flatnonzero(np.bincount(k - lo, minlength=hi - lo + 1)) + lo
    return np.unique(k)
