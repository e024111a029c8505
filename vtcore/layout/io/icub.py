"""iCub skinGui positions text: ``name``, ``spatial_sampling``, ``taxel2Repr ( ... )``, ``[calibration]`` rows.

Lossless: the reader keeps the header lines, ``name``, ``spatial_sampling`` and
``taxel2Repr`` as read (``taxel2Repr`` is never regenerated for a file that has one; where
it disagrees with the rows the reader warns), the text of every calibration row, the
file's length unit and a digest of each taxel row (:func:`~.common.row_digests`). The
writer writes a row's text as read while its taxel is unchanged, so import then export
gives back the file's number tables byte for byte: normals as written (zero normals stay
zero; ``estimate_normals=True`` writes the estimates, see ``Layout.normals_estimated``),
non-unit normals unnormalised, empty slots as they were. Moved or new taxels are written
afresh (shortest exact decimal, in the file's unit).
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field

import numpy as np

from ..._io import atomic_write
from ...errors import FormatError, InputError
from ...inputs import decode, read_bytes
from ..model import Layout
from .checks import text_problem
from .common import (ImportReport, check_repeats, clean_normals, finish, number, parse_number, row_digests,
                     unchanged_rows, units_scale)

NAME = "icub"
SUFFIXES = (".txt", ".ini", "")
#: Most calibration rows (12 per triangle) a file is written with: 5,461 triangles, far past a whole
#: iCub (about 4,000 taxels); a taxel id of 2**40 under the iCub scheme would ask for a file of 2**40 rows.
MAX_ROWS = 1 << 16


_I64 = np.iinfo(np.int64)
_T2R = re.compile(r"taxel2Repr\s*\((.*?)\)", re.S)


def read(path, units: str | None = None) -> Layout:
    """Read an iCub skinGui positions file. Every calibration row is read (the
    reference reader drops the last one); rows of six zeros are empty slots."""
    report = ImportReport(path)
    raw = decode(read_bytes(path, "layout file"), path)  # UTF-8 (BOM ok), else the byte offset
    text = raw.replace("\r\n", "\n").replace("\r", "\n")
    t2r = _taxel2repr(text, report)
    table = _scan(text.split("\n"), path, report)
    if not table.rows:
        raise FormatError("no [calibration] rows found", file=path)
    data = np.asarray(table.rows, dtype=np.float64)
    table.header.update(_name_and_frame(table.names, report))
    _check_counts(len(data), t2r, report)
    empty = np.all(data == 0.0, axis=1)
    keep = np.flatnonzero(~empty)
    if len(keep) == 0:
        raise FormatError("every calibration row is zero (no taxel)", file=path)
    pos = data[keep, :3]
    scale = units_scale(pos, units, report)
    nrm, estimated = clean_normals(data[keep, 3:], pos, report)
    check_repeats(pos, report)
    roles = _roles(t2r, empty, keep, report)
    layout = Layout(pos * scale, nrm, keep, keep // 12, roles=roles,
                    frame=table.header.get("frame") or "end_effector", meta=_meta(table, t2r, len(data), scale),
                    normals_estimated=estimated)
    layout.meta["icub_digests"] = row_digests(layout)
    return finish(layout, report, path, "icub")


@dataclass
class _Table:
    """What :func:`_scan` read from a positions file, in file order."""

    header: dict = field(default_factory=dict)          # key -> value of the header lines, "groups": [...]
    names: list = field(default_factory=list)           # the value of every 'name' line
    rows: list = field(default_factory=list)            # (R,) of [x, y, z, nx, ny, nz] floats
    row_lines: list = field(default_factory=list)       # (R,) line number of each row
    row_text: list = field(default_factory=list)        # (R,) each row's text, comments cut off
    header_lines: list = field(default_factory=list)    # the lines up to the first row, right-stripped


def _scan(lines: list[str], path, report: ImportReport) -> _Table:
    """Every line of the file: header keys and 'name' lines up to the calibration table (a
    ``[calibration]`` line, or the first line of numbers without one), then its rows."""
    table = _Table()
    in_cal = False
    for ln, line in enumerate(lines, start=1):
        s = _comment_free(line)
        if not in_cal and not table.row_text:
            table.header_lines.append(line.rstrip())  # trimmed to the lines before the table by _meta
        if not s:
            continue
        if s.startswith("["):
            in_cal = s.lower().startswith("[calibration")
            if not in_cal:
                table.header.setdefault("groups", []).append(s)
            continue
        if not in_cal:
            in_cal = _read_header_line(s, ln, table, report)
            if not in_cal:
                continue
        table.rows.append(_calibration_row(s, ln, path, report))
        table.row_lines.append(ln)
        table.row_text.append(s)
    return table


def _read_header_line(s: str, ln: int, table: _Table, report: ImportReport) -> bool:
    """Line ``s`` (number ``ln``, comment cut off) before the table into ``table``; True when it is
    a calibration row already (numbers outside the group: a file without the [calibration] header)."""
    key = s.partition(" ")[0].split("\t")[0]
    val = s[len(key):].strip()
    if key == "name":
        table.names.append(val)
    elif key == "taxel2Repr":
        pass  # read by _taxel2repr: its list can span several lines
    elif key.startswith(("0", "1", "2", "3", "4", "5", "6", "7", "8", "9", "-", "+", ".")):
        report.warn("calibration rows without a [calibration] header", line=ln)
        return True
    else:
        table.header[key] = val
    return False


def _calibration_row(s: str, ln: int, path, report: ImportReport) -> list[float]:
    """``[x, y, z, nx, ny, nz]`` of calibration row ``s`` (line ``ln``); values past six are warned."""
    toks = s.split()
    if len(toks) < 6:
        raise FormatError(f"calibration row has {len(toks)} values, needs 6 (x y z nx ny nz)",
                          file=path, line=ln)
    if len(toks) > 6:
        report.warn(f"calibration row has {len(toks)} values; used the first 6", line=ln)
    return [parse_number(tok, path, ln, "calibration value") for tok in toks[:6]]


def _check_counts(nrows: int, t2r: np.ndarray | None, report: ImportReport) -> None:
    """Warn where the row count is not whole triangles (12 slots) or taxel2Repr has another length."""
    if nrows % 12:
        report.warn(f"{nrows} calibration rows is not a multiple of 12 (slots per triangle)")
    if t2r is not None and len(t2r) != nrows:
        report.warn(f"taxel2Repr has {len(t2r)} entries for {nrows} calibration rows; "
                    f"used the first {min(len(t2r), nrows)}")


def _meta(table: _Table, t2r: np.ndarray | None, nrows: int, scale: float) -> dict:
    """The layout's ``meta``: what the writer needs to give the file back as read (header keys and
    lines, names, taxel2Repr, each row's text, the length unit: ``scale`` 1e-3 is mm)."""
    # the header: every line before the [calibration] line (or before the first row without one)
    header_lines = table.header_lines[: table.row_lines[0] - 1]
    cal = [i for i, h in enumerate(header_lines) if h.strip().lower().startswith("[calibration")]
    header_lines = header_lines[: cal[0]] if cal else header_lines
    header = table.header
    return {"name": header.get("name", ""), "spatial_sampling": header.get("spatial_sampling", "taxel"),
            "icub_rows": int(nrows), "id_scheme": "icub",
            "taxel2Repr": None if t2r is None else t2r.tolist(),
            "icub_header": {k: v for k, v in header.items() if k not in ("name", "spatial_sampling", "frame")},
            "icub_names": table.names, "icub_header_lines": header_lines, "icub_row_text": table.row_text,
            "icub_units": "mm" if scale == 1e-3 else "m"}


def _taxel2repr(text: str, report: ImportReport) -> np.ndarray | None:
    """(K,) int64 of the file's ``taxel2Repr ( ... )`` list (it can span lines), or None without one."""
    m = _T2R.search(text)
    if not m:
        return None
    toks = m.group(1).split()
    # read exactly: int(float(tok)) rounded 2**63 - 1 up past int64 (OverflowError on what the writer wrote)
    ints = [int(tok.partition(".")[0]) for tok in toks if re.fullmatch(r"[-+]?\d+(\.0*)?", tok)]
    t2r = np.array([v for v in ints if _I64.min <= v <= _I64.max], dtype=np.int64)
    if len(t2r) != len(toks):
        report.warn("taxel2Repr has entries that are not 64-bit integers; ignored them")
    return t2r


def _name_and_frame(names: list[str], report: ImportReport) -> dict:
    """``{"name": ..., "frame": ...}`` from the file's 'name' lines (the second, if any, was probably
    meant as 'frame'). A name holding a control character cannot be written into the layout's formats
    (the JSON reader refuses it: fields.py), so it is not kept: the layout is one without that name."""
    out = {}
    usable = [n if text_problem(n) is None else None for n in names]
    if names:
        if usable[0] is None:
            report.warn(f"the 'name' line {text_problem(names[0])}: the layout keeps no name")
        else:
            out["name"] = names[0]
    if len(names) > 1:
        if usable[1] is not None:
            out["frame"] = names[1]
            kept = "the second kept as 'frame' (a 'frame' line was probably meant)"
        else:
            kept = f"the second {text_problem(names[1])}, so it is not kept as 'frame'"
        report.warn(f"{len(names)} 'name' lines ({', '.join(map(repr, names))}); the first is the name, {kept}")
    return out


def _roles(t2r: np.ndarray | None, empty: np.ndarray, keep: np.ndarray, report: ImportReport) -> np.ndarray:
    """(len(keep),) roles of the kept rows: "thermal" where taxel2Repr says -2, else "pressure".
    ``empty`` (R,) bool marks the all-zero rows; taxel2Repr is kept as read, and where it contradicts
    the rows that is said."""
    nrows = len(empty)
    roles = np.full(len(keep), "pressure", dtype=object)
    if t2r is None:
        return roles
    t = np.full(nrows, -3, dtype=np.int64)
    t[: min(len(t2r), nrows)] = t2r[:nrows]
    roles[t[keep] == -2] = "thermal"
    has = ~empty[: len(t2r)]
    known = t[: len(has)]
    odd = np.flatnonzero((has & (known == -1)) | (~has & (known >= 0)))
    if len(odd):
        k = int(odd[0])
        report.warn(f"taxel2Repr disagrees with the calibration rows at {len(odd)} slots (e.g. slot {k}: "
                    f"{int(known[k])}, but the row {'has a taxel' if has[k] else 'is empty'}); kept as read")
    return roles


def _comment_free(line: str) -> str:
    return line.split("//")[0].split("#")[0].strip()


def header_line_problem(line: str) -> str | None:
    """Why ``line`` cannot be a header line of a positions file (the reader would read it as
    something else), or None."""
    if "\n" in line or "\r" in line:
        return "holds a line break; each entry is one line of the file"
    s = _comment_free(line)
    if s.lower().startswith("[calibration") or s[:1] in tuple("0123456789-+."):
        return f"would be read as the calibration table, not the header: {s[:40]!r}"
    return None


def row_problem(row: str) -> str | None:
    """Why ``row`` cannot be a calibration row's text as read (6 finite numbers first), or None."""
    if "\n" in row or "\r" in row:
        return "holds a line break; each entry is one line of the file"
    toks = _comment_free(row).split()
    if len(toks) < 6:
        return f"must start with 6 numbers (x y z nx ny nz), got {len(toks)} values"
    for t in toks[:6]:
        try:
            v = float(t)
        except ValueError:
            return f"{t[:40]!r} is not a number"
        if not math.isfinite(v):
            return f"{t[:40]!r} is not a finite number"
    return None


def _text_says(row: str, position, normal, estimated: bool) -> bool:
    """Whether a row's text as read still says this taxel's position (the file's unit) and normal.

    The digests say the taxel's values are those read; the text is checked too because a JSON
    layout carries ``meta.icub_row_text`` apart from the values (edited, or fuzzed: a row whose x
    read 1e308 was written back for a taxel at 3.5e-18 m)."""
    try:
        v = np.array([float(t) for t in _comment_free(row).split()[:6]])
    except ValueError:
        return False
    if len(v) < 6 or not np.isfinite(v).all() or not np.allclose(v[:3], position, rtol=1e-9, atol=1e-12):
        return False
    with np.errstate(over="ignore"):
        n = float(np.linalg.norm(v[3:]))
    if n == 0.0:
        return bool(estimated)      # the file had no normal; ours was estimated
    return bool(np.isfinite(n) and np.allclose(v[3:] / n, normal, atol=1e-9))


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


def _header(layout: Layout, t2r: np.ndarray) -> list[str]:
    """The header lines: as read where their values are unchanged, else written afresh."""
    meta = layout.meta
    name = str(meta.get("name") or layout.frame)
    spatial = str(meta.get("spatial_sampling", "taxel"))
    t2r_line = "taxel2Repr ( " + " ".join(map(str, t2r.tolist())) + " )"
    lines = meta.get("icub_header_lines")
    if not lines:
        return [f"name {name}", f"spatial_sampling {spatial}", t2r_line, ""]
    names = list(meta.get("icub_names") or [])
    want_names = [name] + ([layout.frame] if len(names) > 1 else []) + names[2:]
    out, seen_names, in_t2r, wrote = [], 0, False, set()
    raw_t2r = []
    for line in lines:
        s = line.split("//")[0].split("#")[0].strip()
        key = s.split(None, 1)[0] if s else ""
        if in_t2r or key == "taxel2Repr":
            raw_t2r.append(line)
            in_t2r = ")" not in s
            if not in_t2r:
                m = _T2R.search("\n".join(raw_t2r))
                toks = m.group(1).split() if m else []
                same = [str(v) for v in t2r.tolist()] == toks
                out += raw_t2r if same else [t2r_line]
                wrote.add("taxel2Repr")
            continue
        if key == "name":
            want = want_names[seen_names] if seen_names < len(want_names) else None
            seen_names += 1
            out.append(line if want == s[len(key):].strip() else f"name {want}" if want is not None else line)
            wrote.add("name")
        elif key == "spatial_sampling":
            out.append(line if spatial == s[len(key):].strip() else f"spatial_sampling {spatial}")
            wrote.add("spatial_sampling")
        else:
            out.append(line)
    first = [f"name {name}"] if "name" not in wrote else []
    first += [f"spatial_sampling {spatial}"] if "spatial_sampling" not in wrote else []
    return first + out + ([t2r_line] if "taxel2Repr" not in wrote else [])


def write(layout: Layout, path, *, estimate_normals: bool = False) -> None:
    """Write the iCub positions text.

    estimate_normals : write the estimated normals (``layout.normals_estimated``) instead
    of the zeros the file had.
    """
    slots = _icub_slots(layout)
    meta = layout.meta
    ours = "icub_row_text" in meta  # read from an iCub file (perhaps through our JSON)
    known_rows = int(meta.get("icub_rows", 0) or 0) if ours else 0
    nrows = int(max(slots.max() + 1, known_rows))
    if nrows > MAX_ROWS:
        raise InputError(f"an iCub positions file of these taxel ids would have {nrows} rows, more than the "
                         f"{MAX_ROWS} written; taxel ids under the iCub scheme are file rows", key="taxel_ids")
    if not known_rows:
        nrows = int(math.ceil(nrows / 12) * 12)
    scale = 1e-3 if (ours and meta.get("icub_units") == "mm") else 1.0
    t2r = meta.get("taxel2Repr") if ours else None
    if t2r is not None:
        t2r = np.asarray(t2r, dtype=np.int64)
    else:
        t2r = np.full(nrows, -1, dtype=np.int64)
        t2r[slots] = (slots // 12) * 12 + 3
        t2r[slots[layout.roles == "thermal"]] = -2
    raw = list(meta.get("icub_row_text") or []) if ours else []
    same = unchanged_rows(layout, meta.get("icub_digests")) if ours else np.zeros(len(layout), bool)
    est = layout.normals_estimated if layout.normals_estimated is not None else np.zeros(len(layout), bool)
    rows = [raw[s] if s < len(raw) and not any(float(t) for t in raw[s].split()[:6]) else "0 0 0 0 0 0"
            for s in range(nrows)]  # empty slots: as read
    for k, s in enumerate(slots.tolist()):
        if same[k] and s < len(raw) and (not est[k] or not estimate_normals) and \
                _text_says(raw[s], layout.positions[k] / scale, layout.normals[k], est[k]):
            rows[s] = raw[s]
            continue
        n = layout.normals[k] if (estimate_normals or not est[k]) else np.zeros(3)
        rows[s] = " ".join(number(v) for v in np.concatenate([layout.positions[k] / scale, n]))
    out = _header(layout, t2r) + ["[calibration]"] + rows
    with atomic_write(path, "w", encoding="utf-8", newline="\n") as fh:
        fh.write("\n".join(out) + "\n")
