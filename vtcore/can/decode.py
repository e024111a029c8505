"""From CAN frames to taxel time series ``(T, N)`` with a mask, streamed in bounded memory.

How frames become rows (periods)
--------------------------------
Every stream (one kind of frame, e.g. an iCub triangle's 0x40 frame) is sent
once per period. A stream's frames are chained: the row of a frame is the row
of the previous frame of the same stream plus ``round(dt / period)``, so a
missing frame leaves a masked sample (the next one lands two rows later)
instead of shifting the row, and a slightly wrong period never accumulates
drift. A stream seen for the first time is placed by the nearest reference
(a frame of a known stream, or a pending row) in time. A row's timestamp is
the earliest frame placed in it (rows without any frame get the previous
row's timestamp plus the period).

What is rejected, and counted (``Summary.rejected``)
----------------------------------------------------
``unknown_id``, ``short_dlc``, ``bad_header`` (from the codec),
``out_of_order`` (earlier than an earlier-read frame of the same stream),
``clock_jump`` (more than ``window`` periods after the median time of the 7 frames
around it in file order: a lone forward outlier, or a run of up to 3, whose
neighbours continue the old clock; see :meth:`StreamDecoder._clock_jumps`. Without
this, its stream's later frames would all be out of order and every other stream's
late. After a genuine gap the following frames continue the new clock and win the
vote, so the gap becomes masked rows),
``duplicate`` (a second frame of a stream in one row: the first read wins),
``late`` (its row was already emitted; rows stay open for ``window`` periods
after the newest row seen). A frame whose triangle reports an error keeps its
values in ``frames`` but all samples of that triangle in that row are masked.
Results do not depend on how the input is cut into chunks.

Memory: the decoder holds one chunk of frames plus ``window`` rows; rows are
returned as soon as they are closed (:meth:`StreamDecoder.feed`).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..errors import InputError
from ..inputs import need_memory
from .codecs import Codec
from .frames import REASONS, FrameBatch, Summary
from .rows import (chain_rows, clock_jumps, fill_empty_times, out_of_order, stream_runs, unique_ints,
                   unit_error_cells)

_CLOCK_JUMP = REASONS.index("clock_jump")


@dataclass
class Block:
    """Closed rows: ``timestamps (T,)`` s, ``frames (T, N)`` wire values, ``mask (T, N)`` bool
    (True = a sample was received), ``taxel_ids (N,)``, ``row0`` index of the first row,
    ``errors (E, 3)`` int64 rows of ``(row, unit, code)`` for nonzero diagnostic codes."""

    timestamps: np.ndarray
    frames: np.ndarray
    mask: np.ndarray
    taxel_ids: np.ndarray
    row0: int
    errors: np.ndarray


@dataclass
class DecodeResult:
    """A whole decoded log. ``frames (T, N)`` wire values; masked entries are meaningless (0)."""

    timestamps: np.ndarray
    frames: np.ndarray
    mask: np.ndarray
    taxel_ids: np.ndarray
    errors: np.ndarray
    summary: Summary
    codec: str = ""
    extra: dict = field(default_factory=dict)

    def arrays(self) -> dict:
        """The arrays of FRAMES.npz (results contract names)."""
        return {"timestamps": self.timestamps, "frames": self.frames, "mask": self.mask,
                "taxel_ids": self.taxel_ids, "unit_errors": self.errors, **self.extra}


def estimate_period(timestamps, keys, default: float) -> float:
    """Median spacing of consecutive frames of the same stream (s); ``default`` if none."""
    t = np.asarray(timestamps, np.float64)
    k = np.asarray(keys)
    if len(t) < 2:
        return default
    o = np.lexsort((t, k))
    t, k = t[o], k[o]
    d = np.diff(t)[np.diff(k) == 0]
    d = d[d > 1e-4]  # drop duplicates and bursts
    return float(np.median(d)) if len(d) else default


class StreamDecoder:
    """Incremental decoder; ``feed(batch)`` returns the rows it closed (or None), ``finish()`` the rest.

    codec : a :class:`~vtcore.can.codecs.Codec`.
    taxel_ids : (N,) int or None. Columns of the output. ``None``: one column per taxel
        channel seen, added as streams appear, sorted by taxel id in :func:`collect`.
        Given (a layout's ids): channels not among them are counted as unmapped.
    period : s, or None to estimate it from the first batch with enough frames.
    window : periods a row stays open for late frames.
    """

    def __init__(self, codec: Codec, taxel_ids=None, period: float | None = None, window: int = 8,
                 summary: Summary | None = None):
        self.codec = codec
        self.dynamic = taxel_ids is None
        self.taxel_ids = np.zeros(0, np.int64) if taxel_ids is None else np.asarray(taxel_ids, np.int64).reshape(-1)
        self.summary = summary if summary is not None else Summary()
        # a layout may give several taxels the same id: decode into one column per distinct id
        # and copy it to every taxel with that id when rows are emitted (``_expand``)
        self.out_ids, self._expand = self.taxel_ids, None   # output columns when ids repeat
        uniq, first, inv = np.unique(self.taxel_ids, return_index=True, return_inverse=True)
        if len(uniq) < len(self.taxel_ids):
            keep = np.sort(first)                      # first occurrences, in layout order
            self.taxel_ids = self.taxel_ids[keep]
            self._expand = np.argsort(np.argsort(first))[inv]
            counts = np.bincount(inv)
            rep = uniq[counts > 1]
            self.summary.shared_taxel_ids = [int(x) for x in rep]
            self.summary.notes.append(
                f"the layout gives {int((counts[counts > 1]).sum())} taxels only {len(rep)} distinct id(s) "
                f"(e.g. {rep[:8].tolist()}): every taxel with a repeated id receives that id's samples")
        self._index_columns()
        self.period = None if period is None else float(period)
        if self.period is not None and not self.period > 0:
            raise ValueError("period must be > 0 s")
        self.window = int(max(window, 1))
        self.summary.id_scheme = codec.name
        c = codec.n_channels
        self._keys = np.zeros(0, np.int64)       # sorted known stream keys
        self._klast_t = np.zeros(0)               # last timestamp per key
        self._klast_row = np.zeros(0, np.int64)   # last row per key
        self._kcols = np.zeros((0, c), np.int64)  # column of each channel, -1 none
        self._kch = np.zeros((0, c), np.int64)    # taxel id of each channel, -1 none
        self._kunit = np.zeros(0, np.int64)
        self._row0 = 0
        self._maxrow = -1
        # pending grids have one extra, last column that collects channels without a column
        # (not in the layout, absent from a short frame): scatters then need no compress step
        self._pv = np.zeros((0, len(self.taxel_ids) + 1), codec.wire_dtype)
        self._pm = np.zeros((0, len(self.taxel_ids) + 1), bool)
        self._lut_lo, self._lut = 0, np.zeros(0, np.int64)
        self._pt = np.zeros(0)
        self._pfill = np.zeros((0, 0), bool)
        self._perr: list[np.ndarray] = []         # pending (row, unit, code) arrays
        self._last_emit: tuple[int, float] | None = None
        self._started = False
        self.max_pending_rows = 0                  # for tests of bounded memory
        self._tail = FrameBatch.empty()            # frames held back as look-ahead
        self._ctx = np.zeros(0)                    # timestamps of the last frames processed

    # -- columns ---------------------------------------------------------
    def _index_columns(self):
        self._order = np.argsort(self.taxel_ids, kind="stable")
        self._sorted = self.taxel_ids[self._order]

    def _columns_of(self, ch: np.ndarray) -> np.ndarray:
        """Column of each taxel id in ``ch`` (any shape), -1 when absent or ch < 0."""
        flat = ch.reshape(-1)
        if len(self._sorted) == 0:
            return np.full(ch.shape, -1, np.int64)
        pos = np.clip(np.searchsorted(self._sorted, flat), 0, len(self._sorted) - 1)
        hit = (self._sorted[pos] == flat) & (flat >= 0)
        return np.where(hit, self._order[pos], -1).reshape(ch.shape)

    def _add_keys(self, new: np.ndarray):
        ch = self.codec.channel_ids(new)
        cols = self._columns_of(ch)
        keys = np.concatenate([self._keys, new])
        o = np.argsort(keys, kind="stable")
        self._keys = keys[o]
        self._klast_t = np.concatenate([self._klast_t, np.full(len(new), -np.inf)])[o]
        self._klast_row = np.concatenate([self._klast_row, np.full(len(new), -1, np.int64)])[o]
        self._kcols = np.concatenate([self._kcols, cols])[o]
        self._kch = np.concatenate([self._kch, ch])[o]
        self._kunit = np.concatenate([self._kunit, self.codec.unit(new)])[o]
        fill = np.zeros((len(self._pfill), len(keys)), bool)
        fill[:, : self._pfill.shape[1]] = self._pfill
        self._pfill = fill[:, o]
        lo, hi = int(self._keys[0]), int(self._keys[-1])
        if hi - lo < (1 << 22):   # dense lookup table: key -> stream index without a search
            self._lut_lo, self._lut = lo, np.full(hi - lo + 1, -1, np.int64)
            self._lut[self._keys - lo] = np.arange(len(self._keys))
        else:
            self._lut = None

    def _add_columns(self, ids: np.ndarray):
        """Dynamic columns: append taxel ids first seen in a frame (present channels only)."""
        ids = np.setdiff1d(ids, self.taxel_ids)
        if not len(ids):
            return
        self._check_grid(len(self._pv), len(self.taxel_ids) + len(ids))
        self.taxel_ids = np.concatenate([self.taxel_ids, ids])
        self._index_columns()
        pad = len(ids)
        # keep the trash column last
        self._pv = np.concatenate([self._pv[:, :-1], np.zeros((len(self._pv), pad + 1), self._pv.dtype)], axis=1)
        self._pm = np.concatenate([self._pm[:, :-1], np.zeros((len(self._pm), pad + 1), bool)], axis=1)
        self._kcols = self._columns_of(self._kch)

    def _index_of(self, k: np.ndarray) -> np.ndarray:
        """Stream index of each key, -1 for keys not seen yet."""
        if len(self._keys) == 0:
            return np.full(len(k), -1, np.int64)
        if self._lut is not None:
            rel = k - self._lut_lo
            inside = (rel >= 0) & (rel < len(self._lut))
            return np.where(inside, self._lut[np.where(inside, rel, 0)], -1)
        pos = np.clip(np.searchsorted(self._keys, k), 0, len(self._keys) - 1)
        return np.where(self._keys[pos] == k, pos, -1)

    # -- feeding ---------------------------------------------------------
    #: frames the period is estimated from (the first ones of the log, whatever the chunking)
    ESTIMATE_FRAMES = 4096
    JUMP_CONTEXT = 3   # frames on each side that vote on a clock jump (runs of up to 3 outliers)
    MAX_GAP_ROWS = 1 << 20   # a gap needing more empty rows than this is an error, not a MemoryError
    #: peak bytes per byte of the pending grid: the grid, its grown copy (concatenate), the emitted
    #: block and the collected result (measured: 596 MB peak for a 176 MB grid of 900,004 x 61)
    GRID_COPIES = 4

    def _check_grid(self, rows: int, cols: int, line: int | None = None) -> None:
        """Refuse, before allocating, a pending grid of ``rows`` x ``cols`` (+ the stream flags) over
        the memory budget. Both sizes come from the file: rows from the time between its frames (a
        frame with a wrong timestamp far after the others), columns from the ids it holds (with no
        layout, one per taxel id seen), so their product is checked (a fuzzed BLF log grew a
        1M-row grid of hundreds of columns and the process to 10 GB)."""
        row_bytes = (cols + 1) * (np.dtype(self.codec.wire_dtype).itemsize + 1) + len(self._keys) + 8
        need_memory(float(self.GRID_COPIES) * rows * row_bytes, key=None, line=line,
                    what=f"decoding {rows} rows ({rows * self.period:.6g} s at {self.period:.6g} s per row) x "
                         f"{cols} taxel columns",
                    remedy="check the log's timestamps (a frame far after the others?) and ids, decode its "
                           "parts separately or with a layout (--layout: only its taxels get columns)")

    def feed(self, batch: FrameBatch) -> Block | None:
        """Decode one chunk of frames; return the rows it closed, or None."""
        if self.period is None:
            # hold input until the estimate can use the same first frames however the log is cut
            self._hold = getattr(self, "_hold", []) + [batch]
            if sum(len(b) for b in self._hold) < self.ESTIMATE_FRAMES:
                return None
            return self._release(final=False)
        return self._feed(batch, final=False)

    def _release(self, final: bool) -> Block | None:
        held = FrameBatch.concat(getattr(self, "_hold", []))
        self._hold = []
        head = held.take(slice(0, self.ESTIMATE_FRAMES))
        keys, reason = self.codec.classify(head)
        ok = reason < 0
        self.period = estimate_period(head.timestamps[ok], keys[ok], self.codec.default_period)
        self.summary.period_s = self.period
        return self._feed(held, final)

    def _feed(self, batch: FrameBatch, final: bool) -> Block | None:
        """Hold back the last ``JUMP_CONTEXT`` frames (the look-ahead clock-jump detection needs
        the frames after each one), process the rest with the frames before as context."""
        k = self.JUMP_CONTEXT
        if len(self._tail):
            batch = FrameBatch.concat([self._tail, batch])
        cut = len(batch) if final else max(len(batch) - k, 0)
        proc, self._tail = batch.take(slice(0, cut)), batch.take(slice(cut, None))
        if len(proc) == 0:
            return None
        jump = self._clock_jumps(proc.timestamps, None if final else self._tail.timestamps)
        self._ctx = np.r_[self._ctx, proc.timestamps[-k:]][-k:]
        return self._process(proc, jump)

    def _clock_jumps(self, t: np.ndarray, ahead: np.ndarray | None) -> np.ndarray:
        """``(M,) bool``: frames whose timestamp jumped far ahead of the log's clock.

        A frame is a clock jump when it lies more than ``window`` periods after the median
        timestamp of the ``2 k + 1`` frames around it in file order (``k = JUMP_CONTEXT``
        before, itself, ``k`` after; frames of every stream, since all share the logger's
        clock). A lone outlier (or a run of up to ``k``) is outvoted by its neighbours; after a
        genuine gap the frames that follow continue the new clock and carry the median with
        them. At either end of the log the window is shorter (the median of the frames there),
        so a lone outlier on the first or last line is still caught, and a forward step
        followed by fewer than ``k`` frames before the log ends is not confirmed (a jump).
        Only frames within ``k`` of a forward step of more than ``window`` periods can qualify,
        so the median is evaluated at a handful of places (the log's hot path is one ``diff``).
        """
        k = self.JUMP_CONTEXT
        before = np.r_[np.full(k - len(self._ctx), np.nan), self._ctx]
        after = np.zeros(0) if ahead is None else ahead[:k]
        after = np.r_[after, np.full(k - len(after), np.nan)]
        return clock_jumps(t, before, after, self.window * self.period)
        cand = np.unique((fwd[:, None] + np.arange(k)[None, :]).reshape(-1))
        cand = cand[(cand >= 0) & (cand < m)]
        med = np.nanmedian(ext[cand[:, None] + np.arange(2 * k + 1)[None, :]], axis=1)
        jump[cand] = t[cand] - med > limit
        return jump

    def _process(self, batch: FrameBatch, jump: np.ndarray) -> Block | None:
        """One chunk (after the clock-jump vote): reject frames by reason, place the rest in rows,
        scatter their channels into the pending grid, and return the rows that closed."""
        s = self.summary
        s.frames_read += len(batch)
        if len(batch) == 0:
            return None
        keys, acc = self._accept(batch, jump)
        if len(acc) == 0:
            return None
        s.period_s = self.period
        ki = self._stream_indices(keys[acc])
        kept = self._drop_out_of_order(batch, acc, batch.timestamps[acc], ki)
        if kept is None:
            return None
        o, ts, ks = kept
        rows = self._place_rows(ts, ks)
        o, rows, ks, ts = self._drop_late(batch, acc, o, rows, ks, ts)
        if not len(rows):
            return self._emit(final=False)
        self._grow_pending(batch, acc, o, rows)
        o, r, ks, ts = self._drop_duplicates(batch, acc, o, rows - self._row0, ks, ts)
        src = acc[o]
        s.frames_used += len(src)
        self._scatter(batch, src, r, ks, ts)
        self._record_unit_errors(batch, keys, src, r, ks)
        self.max_pending_rows = max(self.max_pending_rows, len(self._pt))
        return self._emit(final=False)

    def _accept(self, batch: FrameBatch, jump: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Classify the frames, count the rejected ones by reason (codec's, then clock jumps);
        return the stream key of every frame ``(M,)`` and the indices of the accepted ones."""
        keys, reason = self.codec.classify(batch)
        reason = np.where((reason < 0) & jump, _CLOCK_JUMP, reason).astype(np.int8)
        for code in np.unique(reason[reason >= 0]):
            sel = reason == code
            self.summary.reject(REASONS[code], int(sel.sum()), batch.lines[sel])
        return keys, np.flatnonzero(reason < 0)

    def _stream_indices(self, k: np.ndarray) -> np.ndarray:
        """Stream index of each key, adding the streams seen for the first time."""
        ki = self._index_of(k)
        unknown = ki < 0
        if unknown.any():
            self._add_keys(unique_ints(k[unknown]))
            ki = self._index_of(k)
        return ki

    def _drop_out_of_order(self, batch: FrameBatch, acc: np.ndarray, t: np.ndarray, ki: np.ndarray):
        """Sort the accepted frames by stream (file order within) and reject those earlier than the
        running maximum of their stream. Returns ``(o, ts, ks)``: the order into ``acc``, times and
        stream indices of the frames kept, or None when none is."""
        # by stream, file order within (16-bit keys get numpy's O(n) radix sort)
        o = np.argsort(ki.astype(np.uint16) if len(self._keys) < 65536 else ki, kind="stable")
        ts, ks = t[o], ki[o]
        ooo = out_of_order(ts, ks, self._klast_t[ks])
        if ooo.any():
            self.summary.reject("out_of_order", int(ooo.sum()), batch.lines[acc[o[ooo]]])
            keep = ~ooo
            o, ts, ks = o[keep], ts[keep], ks[keep]
            if len(o) == 0:
                return None
        return o, ts, ks

    def _place_rows(self, ts: np.ndarray, ks: np.ndarray) -> np.ndarray:
        """Row of every frame (chained per stream) and each stream's state for the next chunk."""
        def references():
            # rows known outside this chunk, for streams new here: pending rows, the last emitted
            ref_t, ref_r = [], []
            if len(self._pt):
                has = np.isfinite(self._pt)
                ref_t.append(self._pt[has])
                ref_r.append(self._row0 + np.flatnonzero(has))
            if self._last_emit is not None:
                ref_t.append(np.array([self._last_emit[1]]))
                ref_r.append(np.array([self._last_emit[0]]))
            return ref_t, ref_r

        rows = chain_rows(ts, ks, self.period, self._klast_row, self._klast_t, references)
        # stream state for the next chunk (last frame of each run)
        start, _ = stream_runs(ks)
        last = np.r_[np.flatnonzero(start)[1:] - 1, len(ts) - 1]
        self._klast_t[ks[last]] = ts[last]
        self._klast_row[ks[last]] = rows[last]
        return rows

    def _drop_late(self, batch: FrameBatch, acc, o, rows, ks, ts):
        """Reject frames whose row was already emitted (or is ``window`` rows behind the newest read
        before them, in file order); refuse a forward gap of more than ``MAX_GAP_ROWS`` rows.
        Returns ``(o, rows, ks, ts)`` of the frames kept."""
        # lateness needs the file order: running max of rows over the frames read before
        rows_f = np.full(len(acc), np.iinfo(np.int64).min // 2, np.int64)
        rows_f[o] = rows
        runmax = np.maximum.accumulate(np.r_[self._maxrow, rows_f])[:-1]
        late_f = (rows_f < runmax - self.window + 1) | (rows_f < self._row0)
        late = late_f[o]
        newest = int(rows.max())
        if newest - max(self._maxrow, self._row0 - 1) > self.MAX_GAP_ROWS:
            # the first frame, in file order, that opens the gap
            gap_f = rows_f - np.maximum(runmax, self._row0 - 1)
            i = int(np.flatnonzero(gap_f > self.MAX_GAP_ROWS)[0])
            line = int(batch.lines[acc[i]])
            gap = int(gap_f[i])
            raise InputError(f"a frame lies {gap} periods ({gap * self.period:.6g} s) after the newest row before "
                             f"it; masking a gap that long needs {gap} rows in memory (limit "
                             f"{self.MAX_GAP_ROWS}). If the log really pauses that long (a second session "
                             "appended?), decode its parts separately", line=line or None)
        self._maxrow = max(self._maxrow, newest)
        if late.any():
            self.summary.reject("late", int(late.sum()), batch.lines[acc[o[late]]])
            ok = ~late
            o, rows, ks, ts = o[ok], rows[ok], ks[ok], ts[ok]
        return o, rows, ks, ts

    def _grow_pending(self, batch: FrameBatch, acc, o, rows) -> None:
        """Extend the pending grid (values, mask, times, stream flags) to the newest row."""
        need = self._maxrow - self._row0 + 1
        have = len(self._pt)
        if need > have:
            self._check_grid(need, len(self.taxel_ids), int(batch.lines[acc[o[int(np.argmax(rows))]]]) or None)
            n = len(self.taxel_ids) + 1
            self._pv = np.concatenate([self._pv, np.zeros((need - have, n), self._pv.dtype)])
            self._pm = np.concatenate([self._pm, np.zeros((need - have, n), bool)])
            self._pt = np.concatenate([self._pt, np.full(need - have, np.inf)])
            self._pfill = np.concatenate([self._pfill, np.zeros((need - have, len(self._keys)), bool)])

    def _drop_duplicates(self, batch: FrameBatch, acc, o, r, ks, ts):
        """Reject a second frame of a stream in one row (the first read wins) and flag the rows
        each stream filled. ``r``: rows relative to the first pending row. Returns ``(o, r, ks, ts)``."""
        # rows never decrease within a stream here (out-of-order frames are gone),
        # so a duplicate is the same row as the previous frame of its stream
        dup = np.r_[False, (ks[1:] == ks[:-1]) & (r[1:] == r[:-1])]
        dup |= self._pfill[r, ks]
        if dup.any():
            self.summary.reject("duplicate", int(dup.sum()), batch.lines[acc[o[dup]]])
            ok = ~dup
            o, r, ks, ts = o[ok], r[ok], ks[ok], ts[ok]
        self._pfill[r, ks] = True
        return o, r, ks, ts

    def _scatter(self, batch: FrameBatch, src, r, ks, ts) -> None:
        """Write the channels of frames ``src`` into rows ``r`` of the pending grid; count the
        channels without a column (unmapped); a row's time is its earliest frame."""
        s = self.summary
        vals = self.codec.values(batch)[src]
        # channel presence and columns depend only on (stream, DLC): work them out once per
        # combination seen (a handful), then gather one (M, C) column table for the frames
        n = len(self.taxel_ids)
        dl = batch.dlc[src].astype(np.int64)
        combo = ks * 9 + dl
        counts = np.bincount(combo, minlength=len(self._keys) * 9)
        nz = np.flatnonzero(counts)
        kc, dc = nz // 9, nz % 9
        pres_c = self.codec.present_dlc(dc, self._keys[kc])                    # (combos, C)
        if self.dynamic:
            new_ids = self._kch[kc][pres_c & (self._kch[kc] >= 0) & (self._kcols[kc] < 0)]
            if len(new_ids):
                self._add_columns(np.unique(new_ids))
                n = len(self.taxel_ids)
        cols_c = np.where(pres_c & (self._kcols[kc] >= 0), self._kcols[kc], n)
        miss_c = pres_c & (self._kch[kc] >= 0) & (self._kcols[kc] < 0)
        if miss_c.any():
            s.unmapped_samples += int((miss_c.sum(axis=1) * counts[nz]).sum())
            s.unmapped_frames += int(counts[nz][miss_c.any(axis=1)].sum())
            s.unmapped_taxel_ids.update(int(x) for x in np.unique(self._kch[kc][miss_c]))
        lut = np.zeros(len(counts), np.int64)
        lut[nz] = np.arange(len(nz))
        cols = cols_c[lut[combo]]
        lin = (r * (n + 1))[:, None] + cols  # one flat index: cheaper than 2-D fancy indexing
        self._pv.reshape(-1)[lin] = vals
        self._pm.reshape(-1)[lin] = True
        np.minimum.at(self._pt, r, ts)

    def _record_unit_errors(self, batch: FrameBatch, keys, src, r, ks) -> None:
        """Count the codec's nonzero diagnostic codes and keep ``(row, unit, code)`` for masking
        the unit's samples when its row is emitted."""
        err, _oor = self.codec.diagnostics(batch, keys)
        err = err[src]
        bad = err > 0
        if bad.any():
            s = self.summary
            codes, counts = np.unique(err[bad], return_counts=True)
            for code, cnt in zip(codes.tolist(), counts.tolist()):
                s.triangle_errors[code] = s.triangle_errors.get(code, 0) + cnt
            self._perr.append(np.column_stack([r[bad] + self._row0, self._kunit[ks[bad]], err[bad]]).astype(np.int64))

    def finish(self) -> Block | None:
        """Close and return every pending row."""
        first = self._release(final=True) if self.period is None else self._feed(FrameBatch.empty(), final=True)
        return _join_blocks(first, self._emit(final=True))

    def _emit(self, final: bool) -> Block | None:
        upto = len(self._pt) if final else max(0, self._maxrow - self.window + 1 - self._row0)
        if upto <= 0:
            return None
        n = len(self.taxel_ids)
        v, msk, tt = self._pv[:upto, :n], self._pm[:upto, :n], self._pt[:upto].copy()
        errs = np.concatenate(self._perr) if self._perr else np.zeros((0, 3), np.int64)
        here = errs[:, 0] < self._row0 + upto
        now, self._perr = errs[here], ([errs[~here]] if (~here).any() else [])
        now = now[np.lexsort((now[:, 1], now[:, 0]))]
        if len(now):
            # mask every sample of an erroring unit (triangle) in that row
            msk = msk.copy()
            msk[unit_error_cells(now, self._kunit, self._kcols, self._row0, n)] = False
        # rows without any frame: previous row's time + period
        empty = ~np.isfinite(tt)
        tt = fill_empty_times(tt, self._row0, self.period, self._last_emit)
        ids = self.taxel_ids
        if self._expand is not None:
            v, msk, ids = v[:, self._expand], msk[:, self._expand], self.out_ids
        block = Block(tt, v, msk, ids.copy(), self._row0, now)
        self.summary.rows += upto
        self.summary.masked_samples += int(msk.size - np.count_nonzero(msk))
        # reference for later empty rows and new streams: the last row that had a frame, so an
        # empty row's time is always (real time + n periods), whatever block it falls in
        real = np.flatnonzero(~empty)
        if len(real):
            self._last_emit = (self._row0 + int(real[-1]), float(tt[real[-1]]))
        elif self._last_emit is None:
            self._last_emit = (self._row0 + upto - 1, float(tt[-1]))
        # the emitted rows are handed out as views: keep copies of the open rows only
        self._pv, self._pm, self._pt = self._pv[upto:].copy(), self._pm[upto:].copy(), self._pt[upto:].copy()
        self._pfill = self._pfill[upto:].copy()
        self._row0 += upto
        return block


def _join_blocks(a: Block | None, b: Block | None) -> Block | None:
    if a is None or b is None:
        return a if b is None else b
    ids = b.taxel_ids  # b's columns are a superset of a's (columns are only ever appended)
    fa = np.zeros((len(a.timestamps), len(ids)), a.frames.dtype)
    ma = np.zeros(fa.shape, bool)
    fa[:, : a.frames.shape[1]] = a.frames
    ma[:, : a.mask.shape[1]] = a.mask
    return Block(np.r_[a.timestamps, b.timestamps], np.vstack([fa, b.frames]), np.vstack([ma, b.mask]), ids,
                 a.row0, np.vstack([a.errors, b.errors]))


def iter_decode(batches, codec: Codec, taxel_ids=None, period=None, window: int = 8,
                summary: Summary | None = None):
    """Yield closed :class:`Block` s while consuming ``batches`` lazily (bounded memory)."""
    dec = StreamDecoder(codec, taxel_ids, period, window, summary)
    for b in batches:
        out = dec.feed(b)
        if out is not None:
            yield out
    out = dec.finish()
    if out is not None:
        yield out


def collect(blocks, codec: Codec, summary: Summary, taxel_ids=None) -> DecodeResult:
    """Concatenate blocks into one :class:`DecodeResult` (columns sorted by taxel id when dynamic)."""
    blocks = [b for b in blocks if b is not None]
    if taxel_ids is None:
        ids = np.unique(np.concatenate([b.taxel_ids for b in blocks])) if blocks else np.zeros(0, np.int64)
    else:
        ids = np.asarray(taxel_ids, np.int64)
    n = len(ids)
    total = sum(len(b.timestamps) for b in blocks)
    # the result beside the blocks it is copied from, and the ~mask of the zeroing below
    need_memory(2.0 * total * n * (np.dtype(codec.wire_dtype).itemsize + 2), key=None,
                what=f"collecting {total} rows x {n} taxel columns",
                remedy="decode the log in parts, or with a layout (--layout: only its taxels get columns)")
    frames = np.zeros((total, n), codec.wire_dtype)
    mask = np.zeros((total, n), bool)
    ts = np.zeros(total)
    i = 0
    order = np.argsort(ids)
    for b in blocks:
        t = len(b.timestamps)
        if np.array_equal(b.taxel_ids, ids):
            pos = np.arange(n)  # the given columns (they may repeat an id)
        else:  # dynamic columns: b's ids are a subset of ids, all distinct
            pos = order[np.searchsorted(ids[order], b.taxel_ids)] if n else np.zeros(0, np.int64)
        if len(pos) == n and np.array_equal(pos, np.arange(n)):
            frames[i:i + t] = b.frames      # same columns: plain copy
            mask[i:i + t] = b.mask
        else:
            frames[i:i + t][:, pos] = b.frames
            mask[i:i + t][:, pos] = b.mask
        ts[i:i + t] = b.timestamps
        i += t
    errors = np.concatenate([b.errors for b in blocks]) if blocks else np.zeros((0, 3), np.int64)
    if not mask.all():
        frames[~mask] = 0
    return DecodeResult(ts, frames, mask, ids, errors.reshape(-1, 3), summary, codec.name)


def decode_batches(batches, codec: Codec, taxel_ids=None, period=None, window: int = 8,
                   summary: Summary | None = None) -> DecodeResult:
    """Decode an iterable of :class:`FrameBatch` (or one batch) into a :class:`DecodeResult`."""
    if isinstance(batches, FrameBatch):
        batches = [batches]
    summary = summary if summary is not None else Summary()
    blocks = iter_decode(batches, codec, taxel_ids, period, window, summary)
    return collect(blocks, codec, summary, taxel_ids)
