"""CSV: one taxel a row under a header line, after ``#`` lines that state units and frame.

Written: ``# units: m``, ``# frame: NAME``, ``# transform: 16 numbers`` (row-major 4x4, the
pose of the frame in its parent) and the normals' convention, then the header
``taxel_id,module_id,x,y,z,nx,ny,nz[,u,v],role[,can_id]``; ``pandas.read_csv(path,
comment="#")`` reads it. Numbers are the shortest decimal that reads back exactly.
Read: ``x,y,z`` required, the others optional; ``x_mm`` style headers or a ``# units:``
line declare the unit.
"""

from __future__ import annotations

import re

import numpy as np

from ..._io import atomic_write
from ...errors import FormatError
from ...inputs import read_text
from ..model import Layout
from ..uids import cyskin_modules
from .common import (ImportReport, check_repeats, clean_normals, finish, number, parse_integer, parse_number,
                     units_scale)

NAME = "csv"
SUFFIXES = (".csv",)


_CSV_COLS = ("taxel_id", "module_id", "x", "y", "z", "nx", "ny", "nz", "u", "v", "role", "can_id")
#: other names a header may give a column (``id`` for ``taxel_id`` ...)
_ALIASES = {"id": "taxel_id", "uid": "taxel_id", "module": "module_id", "type": "role", "can": "can_id"}


def write(layout: Layout, path) -> None:
    cols = ["taxel_id", "module_id", "x", "y", "z", "nx", "ny", "nz"]
    if layout.flat is not None:
        cols += ["u", "v"]
    cols.append("role")
    if layout.can_ids is not None:
        cols.append("can_id")
    fmt = number
    lines = ["# vtcore layout: one taxel a row", "# units: m",
             f"# frame: {layout.frame}",
             *([f"# parent: {layout.parent}"] if layout.parent else []),
             "# transform: " + " ".join(number(v) for v in layout.transform.ravel()),
             "# normals: unit, outward, in the frame" + (
                 f"; {int(layout.normals_estimated.sum())} estimated (the source had none)"
                 if layout.normals_estimated is not None and layout.normals_estimated.any() else ""),
             ",".join(cols)]
    for k in range(len(layout)):
        row = [str(int(layout.taxel_ids[k])), str(int(layout.module_ids[k]))]
        row += [fmt(v) for v in layout.positions[k]] + [fmt(v) for v in layout.normals[k]]
        if layout.flat is not None:
            row += [fmt(v) for v in layout.flat[k]]
        row.append(str(layout.roles[k]))
        if layout.can_ids is not None:
            row.append(str(int(layout.can_ids[k])))
        lines.append(",".join(row))
    with atomic_write(path, "w", encoding="utf-8", newline="\n") as fh:
        fh.write("\n".join(lines) + "\n")


def read(path, units: str | None = None) -> Layout:
    """Read a CSV layout: ``#`` settings, a header, one taxel a row (see the module docstring).

    units : ``"m"`` or ``"mm"`` for the positions, else the file's ``# units:`` line or ``x_mm``
    style headers, else a guess from the taxel spacing (warned).
    """
    report = ImportReport(path)
    text = read_text(path, "layout file").replace("\r\n", "\n").replace("\r", "\n")
    settings, header, header_line, rows = _scan(text.split("\n"), path, report)
    names, declared = _column_names(header, settings["declared"])
    col = _check_columns(header, names, header_line, rows, path, report)
    return finish(_layout(rows, header, col, settings, declared, units, path, report), report, path, "csv")


def _scan(lines: list[str], path, report: ImportReport) -> tuple[dict, list[str], int, list]:
    """The ``#`` settings (:func:`_read_setting`), the header (lower case) and its line number, and
    the taxel rows as ``(line number, tokens cut to the header's width)``, in file order."""
    settings = {"declared": None, "frame": "end_effector", "transform": np.eye(4), "parent": None}
    header = None
    header_line = 0
    rows = []
    for ln, line in enumerate(lines, start=1):
        s = line.strip()
        if not s:
            continue
        if s.startswith("#"):
            _read_setting(s, ln, path, settings)
            continue
        delim = "," if "," in s else (";" if ";" in s else None)
        toks = [t.strip() for t in (s.split(delim) if delim else s.split())]
        if header is None:
            header = [t.lower() for t in toks]
            header_line = ln
            continue
        if len(toks) < len(header):
            raise FormatError(f"row has {len(toks)} values, the header names {len(header)}", file=path, line=ln)
        if len(toks) > len(header):
            report.warn(f"row has {len(toks)} values for {len(header)} columns; extra ignored", line=ln)
        rows.append((ln, toks[: len(header)]))
    if header is None:
        raise FormatError("empty file (no header)", file=path)
    return settings, header, header_line, rows


def _read_setting(s: str, ln: int, path, settings: dict) -> None:
    """One ``#`` line ``s`` (line ``ln``) into ``settings``: the unit (``declared``), ``frame``,
    ``parent`` or ``transform`` (4, 4); any other comment changes nothing."""
    m = re.search(r"units?\s*[:=]\s*(mm|m)\b", s)
    if m:
        settings["declared"] = m.group(1)
    m = re.match(r"#\s*frame\s*:\s*(\S+)", s)
    if m:
        settings["frame"] = m.group(1)
    m = re.match(r"#\s*parent\s*:\s*(\S+)", s)
    if m:
        settings["parent"] = m.group(1)
    m = re.match(r"#\s*transform\s*:(.*)", s)
    if m:
        toks = m.group(1).split()
        if len(toks) != 16:
            raise FormatError(f"transform needs 16 numbers, got {len(toks)}", file=path, line=ln)
        settings["transform"] = np.array([parse_number(t, path, ln, "transform") for t in toks]).reshape(4, 4)


def _column_names(header: list[str], declared: str | None) -> tuple[list[str], str | None]:
    """Our name of each header column (``x_mm`` -> ``x``, aliases resolved), and the unit: ``declared``
    (a ``# units:`` line) first, else the one written into the column names."""
    names = []
    for h in header:
        m = re.fullmatch(r"(.+?)[_\s\[(]*(mm|m)[\])]*", h)
        if m and m.group(1) in ("x", "y", "z", "u", "v"):
            declared = declared or m.group(2)
            names.append(m.group(1))
        else:
            names.append(_ALIASES.get(h, h))
    return names, declared


def _check_columns(header: list[str], names: list[str], header_line: int, rows: list, path,
                   report: ImportReport) -> dict[str, int]:
    """``{name: column index}`` once x, y, z are there and there are rows; unknown columns warned."""
    missing = [c for c in ("x", "y", "z") if c not in names]
    if missing:
        raise FormatError(f"header lacks column(s) {', '.join(missing)} (has: {', '.join(header)})",
                          file=path, line=header_line)
    unknown = [h for h, nm in zip(header, names) if nm not in _CSV_COLS]
    if unknown:
        report.warn(f"ignored unknown column(s): {', '.join(unknown)}", line=header_line)
    if not rows:
        raise FormatError("no taxel rows after the header", file=path)
    return {nm: i for i, nm in enumerate(names)}


def _numeric(rows: list, header: list[str], i: int, path, integer: bool = False) -> np.ndarray:
    """(N,) float64 (int64 with ``integer``) of column ``i``; a bad value names its line and column."""
    parse = parse_integer if integer else parse_number
    out = [parse(toks[i], path, ln, f"column {header[i]}") for ln, toks in rows]
    return np.asarray(out, dtype=np.int64 if integer else np.float64)


def _layout(rows: list, header: list[str], col: dict[str, int], settings: dict, declared: str | None,
            units: str | None, path, report: ImportReport) -> Layout:
    """The Layout of the rows, in metres: positions and flat scaled, normals cleaned (estimated where
    missing), ids, modules, roles and CAN ids from their columns where present."""
    def numeric(name, integer=False):
        return _numeric(rows, header, col[name], path, integer)

    n = len(rows)
    pos = np.column_stack([numeric(c) for c in ("x", "y", "z")])
    if all(c in col for c in ("nx", "ny", "nz")):
        nrm = np.column_stack([numeric(c) for c in ("nx", "ny", "nz")])
    else:
        nrm = np.zeros((n, 3))
    scale = units_scale(pos, units, report, declared)
    nrm, estimated = clean_normals(nrm, pos, report)
    check_repeats(pos, report)
    ids = numeric("taxel_id", True) if "taxel_id" in col else np.arange(n)
    mods = numeric("module_id", True) if "module_id" in col else (
        cyskin_modules(ids) if "taxel_id" in col else np.zeros(n, np.int64))
    flat = np.column_stack([numeric("u"), numeric("v")]) * scale if ("u" in col and "v" in col) else None
    roles = np.asarray([toks[col["role"]] or "pressure" for _, toks in rows], dtype=object) \
        if "role" in col else None
    can = numeric("can_id", True) if "can_id" in col else None
    transform = settings["transform"].copy()
    transform[:3, 3] *= scale
    return Layout(pos * scale, nrm, ids, mods, flat, roles, settings["frame"], transform, can_ids=can,
                  parent=settings["parent"], normals_estimated=estimated)


