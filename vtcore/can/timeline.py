"""Recordings on a timeline: a CAN log or a CySkin text recording as per-frame taxel values.

What a viewer (the Blender add-on's *Replay*, the ``replay`` scene task) needs from a
recording, computed once at load and vectorised over frames x taxels:

- the decoded counts in the layout's taxel order (joined by UID / CAN address, never by
  column order), lost samples (``mask`` False) holding the taxel's last good value;
- a per-taxel baseline (median of the first N received samples, or of the quietest
  window of N rows: iCub's skinManager compensates drift the first way) and the response
  above it;
- the seed-002 edge filter on every shown frame (one batched call, not per redraw);
- which recorded row each scene frame shows: at the scene's frame rate (the last row at or
  before the frame's time) or one frame per row (the recording's own rate);
- the mismatch report: taxels in the recording the layout lacks, layout taxels the
  recording never mentions.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..errors import InputError
from ..inputs import need_memory
from .recording import mismatch_lines

#: recording kinds :func:`load_recording` reads: the two CAN codecs and the CySkin text format
KINDS = ("cyskin16", "icub", "cyskin-txt")
RATES = ("scene", "recording")
BASELINES = ("first", "quiet")
# float64 copies of a (T, N) array alive at once while a recording is prepared (counts,
# held counts, response, the filter's input and output, the sampled frames)
_COPIES = 6


def hold(values: np.ndarray, mask: np.ndarray) -> np.ndarray:
    """Forward-fill masked samples with the taxel's previous received value (0 before any).

    values, mask : (T, N). Returns (T, N) float64.
    """
    values = np.asarray(values, dtype=np.float64)
    t, n = values.shape
    idx = np.where(mask, np.arange(t)[:, None], -1)
    np.maximum.accumulate(idx, axis=0, out=idx)
    out = values[np.maximum(idx, 0), np.arange(n)[None, :]]
    return np.where(idx >= 0, out, 0.0)


def baseline_first(counts: np.ndarray, mask: np.ndarray, rows: int) -> np.ndarray:
    """Per-taxel median of the first ``rows`` received samples (0 for a taxel never received).

    counts, mask : (T, N). Returns (N,) in the unit of ``counts``.
    """
    rank = np.cumsum(mask, axis=0)
    use = mask & (rank <= rows)
    vals = np.where(use, counts, np.nan)
    with warnings.catch_warnings(), np.errstate(all="ignore"):
        warnings.simplefilter("ignore", RuntimeWarning)  # all-NaN columns: taxels never received
        base = np.nanmedian(vals, axis=0) if len(vals) else np.zeros(counts.shape[1])
    return np.nan_to_num(base, nan=0.0)


def quiet_window(held: np.ndarray, rows: int) -> int:
    """First row of the ``rows`` consecutive rows of ``held`` (T, N) whose summed per-taxel
    variance is smallest (the stretch with least going on). Running sums: O(T N)."""
    t = len(held)
    rows = max(1, min(int(rows), t))
    c1 = np.vstack([np.zeros((1, held.shape[1])), np.cumsum(held, axis=0)])
    c2 = np.vstack([np.zeros((1, held.shape[1])), np.cumsum(held * held, axis=0)])
    s1 = c1[rows:] - c1[:-rows]
    s2 = c2[rows:] - c2[:-rows]
    var = (s2 - s1 * s1 / rows).sum(axis=1)  # (T - rows + 1,) rows x summed variance
    return int(np.argmin(var))


def frame_rows(timestamps, fps: float | None) -> np.ndarray:
    """Row of the recording each frame shows. ``fps`` None: one frame per row (the
    recording's own rate). Otherwise frame k is at ``t0 + k / fps`` and shows the last row
    at or before that time (rows whose time went backwards count at their running maximum).

    timestamps : (T,) s. Returns (F,) int64.
    """
    t = np.asarray(timestamps, dtype=np.float64)
    if len(t) == 0:
        return np.zeros(0, np.int64)
    if fps is None:
        return np.arange(len(t), dtype=np.int64)
    if not np.isfinite(fps) or fps <= 0:
        raise InputError(f"must be a frame rate > 0, got {fps}", key="fps")
    run = np.maximum.accumulate(t)
    span = float(run[-1] - run[0])
    n = int(np.floor(span * fps + 1e-9)) + 1
    return np.searchsorted(run, run[0] + np.arange(n) / fps + 1e-12, side="right").astype(np.int64) - 1


@dataclass
class Replay:
    """A recording prepared for playback, in the layout's taxel order.

    timestamps : (T,) s of the recorded rows. rows : (F,) row shown by each frame.
    counts : (F, N) float32 decoded counts (lost samples hold the last good value).
    response : (F, N) float32 counts above the per-taxel ``baseline`` (N,), >= 0.
    edge_response : (F, N) float32 Eq. 6 of seed 002 on ``response``. edge : (F, N) bool.
    held : (F, N) bool, True where the frame shows a held (lost) sample.
    recording_only : ids in the recording the layout lacks. layout_only : layout taxel ids
    the recording never mentions. lost_rows / lost_samples : recorded rows with a lost sample
    of a recorded taxel, and how many samples. lost_frames : frames that show one.
    rate_hz : the recording's own row rate. summary : the decoder's or reader's account.
    """

    timestamps: np.ndarray
    rows: np.ndarray
    counts: np.ndarray
    response: np.ndarray
    edge_response: np.ndarray
    edge: np.ndarray
    held: np.ndarray
    baseline: np.ndarray
    recording_only: list
    layout_only: list
    lost_rows: int
    lost_samples: int
    lost_frames: int
    rate_hz: float
    summary: str = ""
    meta: dict = field(default_factory=dict)

    def mismatch(self) -> list[str]:
        return mismatch_lines(self.recording_only, self.layout_only, self.counts.shape[1])


def _read(path, layout, kind, boards, period, window):
    """(timestamps (T,), counts (T, N) float64, mask (T, N), recording-only ids, layout-only ids,
    summary text) of the recording at ``path`` in ``layout``'s order."""
    from .api import decode_log
    from .codecs import icub_wire_to_counts
    from .recording import read_cyskin_txt, report_text

    if kind == "cyskin-txt":
        if boards is not None and len(boards):
            raise InputError("board addresses apply to the icub codec only", key="boards")
        rec = read_cyskin_txt(path, layout=layout)
        r = rec.report
        return (rec.timestamps, rec.frames.astype(np.float64), rec.mask, r["unmatched_uids"],
                r["unrecorded_taxels"], report_text(r))
    res = decode_log(path, kind, layout=layout, period=period, window=window, boards=boards)
    wire, mask = res.frames, res.mask
    counts = icub_wire_to_counts(wire) if kind == "icub" else np.asarray(wire, np.float64)
    ids = np.asarray(layout.taxel_ids, np.int64)  # the layout's own ids: what the designer sees
    never = ids[~mask.any(axis=0)] if len(mask) else ids
    return (res.timestamps, np.where(mask, counts, 0.0), mask, sorted(res.summary.unmapped_taxel_ids),
            sorted(set(int(x) for x in never)), res.summary.text())


def load_recording(path, layout, triangles=None, *, kind: str = "cyskin16", boards=None, fps: float | None = 24.0,
                   baseline: str = "first", baseline_rows: int = 5, edge_fraction: float = 0.3,
                   min_response: float = 0.0, period: float | None = None, window: int = 8) -> Replay:
    """Read a recording and prepare it for playback on ``layout``.

    path : a python-can log (kind ``cyskin16`` or ``icub``) or a CySkin text recording
    (``cyskin-txt``). layout : the skin (its ``taxel_ids`` are CySkin UIDs; iCub addresses
    come from ``boards`` / ``can_ids`` as in :func:`vtcore.can.layout_taxel_ids`).
    triangles : (F, 3) skin mesh for the edge filter (None: ``vtcore.layout.skin_mesh``).
    fps : frames per second of the timeline, None for one frame per recorded row.
    baseline : ``first`` (median of each taxel's first ``baseline_rows`` received samples)
    or ``quiet`` (median over the ``baseline_rows`` consecutive rows with the least variance).
    edge_fraction : edge threshold as a fraction of each frame's strongest filter response;
    min_response : counts below which a frame's strongest response means no contact (no edges).

    Raises InputError (naming the file) when the recording mentions none of the layout's
    taxels (wrong codec, wrong skin, wrong boards) or is too large for the memory budget.
    """
    from ..filters import edge_filter, relative_threshold, threshold
    from ..layout import mesh_from_triangles, skin_mesh

    if kind not in KINDS:
        raise InputError(f"unknown recording kind {kind!r}; valid: {', '.join(KINDS)}", key="codec")
    if baseline not in BASELINES:
        raise InputError(f"unknown baseline {baseline!r}; valid: {', '.join(BASELINES)}", key="baseline")
    if int(baseline_rows) < 1:
        raise InputError(f"must be >= 1, got {baseline_rows}", key="baseline_rows")
    n = len(layout)
    if n == 0:
        raise InputError("the skin has no taxels", key="layout")
    path = Path(path)
    ts, counts, mask, rec_only, lay_only, summary = _read(path, layout, kind, boards, period, window)
    t = len(ts)
    if t == 0 or not mask.any():
        raise InputError(f"no sample of the recording reached any of the skin's {n} taxels (read as {kind}; "
                         f"{summary.splitlines()[0] if summary else 'nothing read'}): is it the right codec, "
                         "skin or board address?", file=path, key="codec")
    need_memory(8.0 * _COPIES * t * n, key="recording", what=f"replaying {t} rows x {n} taxels", file=path)
    rows = frame_rows(ts, fps)
    need_memory(8.0 * _COPIES * len(rows) * n, key="fps",
                what=f"{len(rows)} frames x {n} taxels (a {ts.max() - ts.min():.4g} s recording at {fps} fps)",
                file=path)
    held = hold(counts, mask)
    if baseline == "first":
        base = baseline_first(counts, mask, int(baseline_rows))
    else:
        s = quiet_window(held, int(baseline_rows))
        base = np.median(held[s:s + int(baseline_rows)], axis=0)
    ever = np.maximum.accumulate(mask, axis=0)  # received at least once by this row
    response = np.where(ever, np.clip(held - base, 0.0, None), 0.0)
    recorded = mask.any(axis=0)  # taxels the recording mentions
    lost = ~mask & recorded[None, :]
    lost_per_row = lost.sum(axis=1)

    c, r, held_f = held[rows], response[rows], lost[rows]
    tri = None if triangles is None else np.asarray(triangles, np.int64).reshape(-1, 3)
    if tri is not None and len(tri) == 0:
        er = np.zeros_like(r)
    else:
        mesh = skin_mesh(layout) if tri is None else mesh_from_triangles(layout.positions, layout.normals, tri)
        er = edge_filter(mesh, r)
    edge = threshold(er, relative_threshold(er, edge_fraction, floor=1e-9))
    edge &= (r.max(axis=1, initial=0.0) >= min_response)[:, None]
    dt = np.diff(ts)
    dt = dt[np.isfinite(dt) & (dt > 0)]
    return Replay(timestamps=np.asarray(ts, np.float64), rows=rows, counts=c.astype(np.float32),
                  response=r.astype(np.float32), edge_response=er.astype(np.float32), edge=edge,
                  held=held_f, baseline=base, recording_only=list(rec_only), layout_only=list(lay_only),
                  lost_rows=int((lost_per_row > 0).sum()), lost_samples=int(lost_per_row.sum()),
                  lost_frames=int((lost_per_row[rows] > 0).sum()),
                  rate_hz=float(1.0 / np.median(dt)) if len(dt) else 0.0, summary=summary,
                  meta={"kind": kind, "path": str(path), "fps": fps, "baseline": baseline,
                        "baseline_rows": int(baseline_rows)})
