"""iCub skinGui positions text: ``name``, ``spatial_sampling``, ``taxel2Repr ( ... )``, ``[calibration]`` rows."""

from __future__ import annotations

import math
import re
from pathlib import Path

import numpy as np

from ..._io import atomic_write
from ...errors import FormatError, InputError
from ..model import Layout
from .common import ImportReport, check_repeats, clean_normals, finish, parse_number, units_scale

NAME = "icub"
SUFFIXES = (".txt", ".ini", "")


_T2R = re.compile(r"taxel2Repr\s*\((.*?)\)", re.S)


def read(path, units: str | None = None) -> Layout:
    """Read an iCub skinGui positions file. Every calibration row is read (the
    reference reader drops the last one); rows of six zeros are empty slots."""
    report = ImportReport(path)
    raw = Path(path).read_bytes().decode("utf-8", errors="replace")
    text = raw.replace("\r\n", "\n").replace("\r", "\n")
    lines = text.split("\n")
    header: dict = {}
    t2r = None
    m = _T2R.search(text)
    if m:
        toks = m.group(1).split()
        t2r = np.array([int(float(tok)) for tok in toks if re.fullmatch(r"[-+]?\d+(\.0*)?", tok)], dtype=np.int64)
        if len(t2r) != len(toks):
            report.warn("taxel2Repr has entries that are not integers; ignored them")
    rows, row_lines = [], []
    in_cal = False
    names = []
    for ln, line in enumerate(lines, start=1):
        s = line.split("//")[0].split("#")[0].strip()
        if not s:
            continue
        if s.startswith("["):
            in_cal = s.lower().startswith("[calibration")
            if not in_cal:
                header.setdefault("groups", []).append(s)
            continue
        if not in_cal:
            key, _, val = s.partition(" ")
            key = key.split("\t")[0]
            val = s[len(key):].strip()
            if key == "name":
                names.append(val)
            elif key == "taxel2Repr":
                pass  # read above by _T2R: its list can span several lines
            elif key.startswith(("0", "1", "2", "3", "4", "5", "6", "7", "8", "9", "-", "+", ".")):
                # numbers outside the group: a file without the [calibration] header
                in_cal = True
                report.warn("calibration rows without a [calibration] header", line=ln)
            else:
                header[key] = val
            if not in_cal:
                continue
        toks = s.split()
        if len(toks) < 6:
            raise FormatError(f"calibration row has {len(toks)} values, needs 6 (x y z nx ny nz)",
                              file=path, line=ln)
        if len(toks) > 6:
            report.warn(f"calibration row has {len(toks)} values; used the first 6", line=ln)
        rows.append([parse_number(tok, path, ln, "calibration value") for tok in toks[:6]])
        row_lines.append(ln)
    if not rows:
        raise FormatError("no [calibration] rows found", file=path)
    data = np.asarray(rows, dtype=np.float64)
    if names:
        header["name"] = names[0]
    if len(names) > 1:
        report.warn(f"{len(names)} 'name' lines ({', '.join(names)}); the first is the name, the others "
                    "kept as 'frame' (a 'frame' line was probably meant)")
        header["frame"] = names[1]
    nrows = len(data)
    if nrows % 12:
        report.warn(f"{nrows} calibration rows is not a multiple of 12 (slots per triangle)")
    if t2r is not None and len(t2r) != nrows:
        report.warn(f"taxel2Repr has {len(t2r)} entries for {nrows} calibration rows; "
                    f"used the first {min(len(t2r), nrows)}")
    empty = np.all(data == 0.0, axis=1)
    keep = np.flatnonzero(~empty)
    if len(keep) == 0:
        raise FormatError("every calibration row is zero (no taxel)", file=path)
    pos = data[keep, :3]
    scale = units_scale(pos, units, report)
    nrm = clean_normals(data[keep, 3:], pos, report)
    check_repeats(pos, report)
    roles = np.full(len(keep), "pressure", dtype=object)
    if t2r is not None:
        t = np.full(nrows, -3, dtype=np.int64)
        t[: min(len(t2r), nrows)] = t2r[:nrows]
        roles[t[keep] == -2] = "thermal"
    meta = {"name": header.get("name", ""), "spatial_sampling": header.get("spatial_sampling", "taxel"),
            "icub_rows": int(nrows), "id_scheme": "icub",
            "taxel2Repr": None if t2r is None else t2r.tolist(),
            "icub_header": {k: v for k, v in header.items() if k not in ("name", "spatial_sampling", "frame")}}
    layout = Layout(pos * scale, nrm, keep, keep // 12, roles=roles,
                    frame=header.get("frame", "end_effector"), meta=meta)
    return finish(layout, report, path, "icub")


def _icub_slots(layout: Layout) -> np.ndarray:
    """Row of each taxel in an iCub positions file: its id under the iCub scheme, else its
    module's triangle (module order) times 12 plus its rank inside the module."""
    if layout.meta.get("id_scheme") == "icub" or layout.meta.get("module_type") == "icub12":
        ids = layout.taxel_ids
        if np.all(ids >= 0) and len(np.unique(ids)) == len(ids):
            return ids
    mods, inv = np.unique(layout.module_ids, return_inverse=True)
    order = np.lexsort((layout.taxel_ids, inv))
    rank = np.empty(len(layout), np.int64)
    counts = np.bincount(inv)
    if counts.max() > 12:
        raise InputError(f"a module has {counts.max()} taxels; an iCub triangle has 12 slots", key="module_ids")
    starts = np.concatenate([[0], np.cumsum(counts)[:-1]])
    rank[order] = np.arange(len(layout)) - np.repeat(starts, counts)
    return inv * 12 + rank


def write(layout: Layout, path) -> None:
    slots = _icub_slots(layout)
    nrows = int(max(slots.max() + 1, layout.meta.get("icub_rows", 0) or 0))
    nrows = int(math.ceil(nrows / 12) * 12)
    data = np.zeros((nrows, 6))
    data[slots, :3] = layout.positions
    data[slots, 3:] = layout.normals
    t2r = np.full(nrows, -1, dtype=np.int64)
    t2r[slots] = (slots // 12) * 12 + 3
    t2r[slots[layout.roles == "thermal"]] = -2
    out = [f"name {layout.meta.get('name') or layout.frame}",
           f"spatial_sampling {layout.meta.get('spatial_sampling', 'taxel')}",
           "taxel2Repr ( " + " ".join(map(str, t2r.tolist())) + " )", "", "[calibration]"]
    fmt = lambda v: format(float(v), ".12g")  # noqa: E731 - 12 digits: well below 1e-9 m
    out += [" ".join(fmt(v) for v in row) for row in data]
    with atomic_write(path, "w", encoding="utf-8", newline="\n") as fh:
        fh.write("\n".join(out) + "\n")


