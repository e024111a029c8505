"""CySkin text recordings (end of ``formats/cyskin_calibration.md``) joined to a layout by UID.

Line 1: N taxel UIDs (``module << 4 | sensor``; sensor 0 is a temperature channel);
then one line per sample: ``row_index time_s v1 ... vN`` (baseline-subtracted counts, >= 0).
Columns are joined to the layout by UID, never by column order.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..errors import FormatError, InputError
from ..inputs import clean, int_array, read_text
from ..layout.uids import cyskin_sensors


@dataclass
class Recording:
    """A recording in layout order.

    timestamps : (T,) s. frames : (T, N) uint16 counts (cyskin16 wire range) in the layout's
    taxel order. mask : (T, N) True where the taxel was recorded. taxel_ids : (N,) the layout's.
    row_index : (T,) the file's own row numbers. report : what did not match, by reason.
    """

    timestamps: np.ndarray
    frames: np.ndarray
    mask: np.ndarray
    taxel_ids: np.ndarray
    row_index: np.ndarray
    report: dict = field(default_factory=dict)

    def arrays(self) -> dict:
        return {"timestamps": self.timestamps, "frames": self.frames, "mask": self.mask,
                "taxel_ids": self.taxel_ids, "row_index": self.row_index}


def read_cyskin_txt(path, layout=None, taxel_ids=None) -> Recording:
    """Read a CySkin text recording and order its columns like ``layout`` (or ``taxel_ids``).

    Rejected lines (wrong number of fields, not numbers) are reported with their line
    numbers, never silently dropped. Values above 65535 are clipped and counted; negative
    values (the format says clipped at 0) are kept at 0 and counted.
    Report keys: ``unmatched_uids`` (recorded pressure taxels the layout lacks),
    ``temperature_uids`` (sensor-0 channels, not taxels), ``unrecorded_taxels`` (layout
    taxels the file lacks, masked), ``duplicate_uids`` (UIDs the file repeats: the first column
    is used), ``shared_layout_uids`` (UIDs the layout gives to several taxels: each of them
    gets the column), ``rejected_lines``, ``time_backwards``, ``clipped_high``, ``clipped_low``.
    """
    path = Path(path)
    text = read_text(path, "recording").splitlines()
    while text and not text[0].strip():
        text = text[1:]
    uids = _header_uids(text, path)
    n = len(uids)
    if layout is not None:
        taxel_ids = layout.taxel_ids
    ids = np.asarray(taxel_ids if taxel_ids is not None else np.unique(uids[cyskin_sensors(uids) != 0]), np.int64)
    rows, rejected = _sample_rows(text, n)
    t = rows[:, 1]
    vals = rows[:, 2:]
    clipped_high = int((vals > 65535).sum())
    clipped_low = int((vals < 0).sum())
    vals = np.clip(np.rint(vals), 0, 65535).astype(np.uint16)
    frames, mask, report = _join_by_uid(uids, ids, vals)
    report.update({
        "rejected_lines": [{"line": i, "reason": r} for i, r in rejected],
        "time_backwards": int((t[1:] < t[:-1]).sum()),  # not np.diff: 1e308 - -1e308 overflows
        "clipped_high": clipped_high,
        "clipped_low": clipped_low,
        "rows": int(len(t)),
        "layout_taxels": int(len(ids)),
    })
    return Recording(t, frames, mask, ids, rows[:, 0].astype(np.int64), report)


def _header_uids(text: list[str], path: Path) -> np.ndarray:
    """``(n,) int64``: the taxel UIDs of line 1 (the first non-blank line ``text[0]``)."""
    if not text:
        raise FormatError("empty recording: line 1 must list the taxel UIDs", file=path, line=1)
    try:
        # UIDs are module << 4 | sensor on a 29-bit CAN identifier space: anything past uint32 is not a UID
        uids = int_array([int(x) for x in text[0].split()], dtype=np.uint32, file=path, key="UIDs",
                         line=1).astype(np.int64)
    except ValueError as exc:
        if isinstance(exc, InputError):
            raise
        raise FormatError(f"line 1 must list integer taxel UIDs, got {clean(text[0], 60)!r}", file=path,
                          line=1) from None
    if len(uids) == 0:
        raise FormatError("line 1 lists no UIDs", file=path, line=1)
    return uids


def _sample_rows(text: list[str], n: int) -> tuple[np.ndarray, list[tuple[int, str]]]:
    """The sample lines as ``(T, n + 2)`` float rows ``row_index time_s v1 .. vn``, and the
    rejected lines as sorted ``(line, reason)``. All well-formed lines convert at once; only
    when one holds a non-number are they converted one by one to find which."""
    good, rejected = [], []
    for i, line in enumerate(text[1:], start=2):
        parts = line.split()
        if not parts:
            continue
        if len(parts) != n + 2:
            rejected.append((i, f"{len(parts)} fields, expected {n + 2}"))
        else:
            good.append((i, parts))
    rows = np.zeros((0, n + 2))
    kept = [i for i, _ in good]          # the file line of each row of ``rows``
    if good:
        try:
            rows = np.array([p for _, p in good], dtype=np.float64)
        except ValueError:
            keep, kept = [], []
            for i, p in good:  # only when some line has a non-number: find which
                try:
                    keep.append(np.array(p, dtype=np.float64))
                    kept.append(i)
                except ValueError:
                    rejected.append((i, "not numbers"))
            rows = np.array(keep).reshape(-1, n + 2)
    # a row index must be an integer (exactly representable: |i| < 2**53), the other fields finite
    with np.errstate(invalid="ignore"):
        whole = (np.abs(rows[:, 0]) < 2.0 ** 53) & (rows[:, 0] == np.round(rows[:, 0]))
    finite = np.isfinite(rows).all(axis=1)
    ok = finite & whole
    if not ok.all():
        rejected += [(kept[j], "non-finite value" if not finite[j] else "row index is not an integer")
                     for j in np.flatnonzero(~ok)]
        rows = rows[ok]
    rejected.sort()
    return rows, rejected


def _join_by_uid(uids: np.ndarray, ids: np.ndarray, vals: np.ndarray) -> tuple[np.ndarray, np.ndarray, dict]:
    """Columns ``vals (T, n)`` of file UIDs ``uids (n,)`` joined to the layout's ``ids (N,)``:
    ``frames (T, N)`` uint16, ``mask (T, N)`` and the report of what matched.

    Joined from the layout's side: every layout taxel takes the column of its UID (the first
    column when the file repeats a UID), so taxels sharing a UID all get data."""
    n = len(uids)
    uniq, first = np.unique(uids, return_index=True)           # first file column of each UID
    dup = np.setdiff1d(np.arange(n), first)
    is_temp = cyskin_sensors(uids) == 0
    pos = np.clip(np.searchsorted(uniq, ids), 0, len(uniq) - 1)
    got = uniq[pos] == ids                                       # (N,) layout taxel recorded
    src = first[pos[got]]
    frames = np.zeros((len(vals), len(ids)), np.uint16)
    mask = np.zeros((len(vals), len(ids)), bool)
    frames[:, got] = vals[:, src]
    mask[:, got] = True
    used = np.isin(uids, ids) & np.isin(np.arange(n), first)     # file columns that reached the layout
    lid, lcount = np.unique(ids, return_counts=True)
    report = {
        "recorded_uids": int(n),
        "matched_uids": int(used.sum()),
        "unmatched_uids": sorted(int(u) for u in uids[~used & ~is_temp & np.isin(np.arange(n), first)]),
        "temperature_uids": sorted(int(u) for u in uids[is_temp & ~np.isin(uids, ids)]),
        "unrecorded_taxels": sorted(int(u) for u in np.setdiff1d(ids, uids)),
        "duplicate_uids": sorted(int(u) for u in uids[dup]),
        "shared_layout_uids": [int(u) for u in lid[lcount > 1]],
    }
    return frames, mask, report


def mismatch_lines(recording_only, layout_only, layout_size: int) -> list[str]:
    """The mismatch report in words (CLI summary, the add-on's panel): one finding a line."""
    rec, lay = sorted(int(x) for x in recording_only), sorted(int(x) for x in layout_only)
    out = []
    if rec:
        out.append(f"{len(rec)} recorded taxel(s) the layout lacks (e.g. {rec[:6]})")
    if lay:
        out.append(f"{len(lay)} of {layout_size} layout taxel(s) never in the recording (e.g. {lay[:6]})")
    if not out:
        out.append(f"every recorded taxel is on the layout, all {layout_size} layout taxels recorded")
    return out


def report_text(report: dict) -> str:
    """A few lines for the CLI."""
    out = [f"{report['rows']} rows, {report['matched_uids']} of {report['recorded_uids']} recorded UIDs "
           f"matched to the layout"]
    if "layout_taxels" in report:  # the mismatch both ways, in words (also the add-on's Replay panel)
        out += ["  " + line for line in mismatch_lines(report["unmatched_uids"], report["unrecorded_taxels"],
                                                        report["layout_taxels"])]
    for key in ("unmatched_uids", "temperature_uids", "unrecorded_taxels", "duplicate_uids", "shared_layout_uids"):
        v = report.get(key, [])
        if v:
            out.append(f"  {key}: {len(v)} (e.g. {v[:8]})")
    if report["rejected_lines"]:
        ex = ", ".join(f"line {r['line']}: {r['reason']}" for r in report["rejected_lines"][:5])
        out.append(f"  rejected_lines: {len(report['rejected_lines'])} ({ex})")
    for key in ("time_backwards", "clipped_high", "clipped_low"):
        if report[key]:
            out.append(f"  {key}: {report[key]}")
    return "\n".join(out)
