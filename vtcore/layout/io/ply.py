"""PLY: taxels as vertices with per-taxel attributes, the skin mesh's triangles beside them.

Point-cloud loaders must keep one vertex per taxel, in taxel order: ``trimesh.load``
(default ``process=True``) merges coincident vertices and drops vertices no face uses
when the file has a ``face`` element (528 taxels became 403 in a real layout). So by
default the triangles go in an element named ``skin_face``, which mesh loaders skip:
``trimesh.load`` gives a ``PointCloud`` of every taxel, ids in
``pc.metadata["_ply_raw"]["vertex"]["data"]["taxel_id"]``; Open3D's ``read_point_cloud``
reads points and normals. ``mesh=True`` writes a standard ``face`` element instead (for
MeshLab or Blender); trimesh 5.2 then drops taxels that no triangle uses even with
``process=False`` (and merges coincident ones without it), so it is not the default.
Our reader takes either. Numbers are written as the shortest decimal that reads back exactly.
"""

from __future__ import annotations


import numpy as np

from ..._io import atomic_write
from ...errors import FormatError, InputError
from ...inputs import read_bytes
from ..model import Layout
from .common import (ImportReport, clean_normals, default_faces, finish, number, parse_number, transform_of,
                     units_scale)

NAME = "ply"
SUFFIXES = (".ply",)


_ROLE_CODE = {"pressure": 0, "thermal": 1}


def _int_type(values: np.ndarray, key: str) -> str:
    """The PLY property type of an id column: ``int`` (32 bits) when every value fits, else ``double``,
    which holds integers exactly to 2**53 (PLY has no 64-bit integer); past that, an error naming ``key``."""
    if not len(values) or (values.min() >= -(2 ** 31) and values.max() < 2 ** 31):
        return "int"
    if np.abs(values).max() <= 2 ** 53:
        return "double"
    raise InputError(f"holds {int(np.abs(values).max())}; a PLY file holds integers exactly up to 2**53 "
                     "(its widest number is a double)", key=key)


def write(layout: Layout, path, faces: np.ndarray | None = None, *, mesh: bool = False) -> None:
    """ASCII PLY: vertex ``x y z nx ny nz taxel_id module_id role [u v] [can_id]`` (one per
    taxel, metres; ``role`` 0 pressure, 1 thermal, 2 other) and the faces the layout was read
    with, else its skin mesh, as element ``skin_face`` (``face`` with ``mesh=True``)."""
    if faces is None:
        faces = default_faces(layout)
    faces = np.asarray(faces, dtype=np.int64).reshape(-1, 3)
    props = ["double x", "double y", "double z", "double nx", "double ny", "double nz",
             f"{_int_type(layout.taxel_ids, 'taxel_ids')} taxel_id",
             f"{_int_type(layout.module_ids, 'module_ids')} module_id", "uchar role"]
    if layout.flat is not None:
        props += ["double u", "double v"]
    if layout.can_ids is not None:
        props += [f"{_int_type(layout.can_ids, 'can_ids')} can_id"]
    face_el = "face" if mesh else "skin_face"
    head = ["ply", "format ascii 1.0", "comment vtcore layout, units metres, one vertex per taxel in taxel order",
            f"comment frame {layout.frame}",
            *([f"comment parent {layout.parent}"] if layout.parent else []),
            "comment transform " + " ".join(number(v) for v in layout.transform.ravel()),
            f"element vertex {len(layout)}"] + [f"property {p}" for p in props] + \
        [f"element {face_el} {len(faces)}", "property list uchar int vertex_indices", "end_header"]
    fmt = number
    roles = [_ROLE_CODE.get(str(r), 2) for r in layout.roles]
    body = []
    for k in range(len(layout)):
        row = [fmt(v) for v in layout.positions[k]] + [fmt(v) for v in layout.normals[k]]
        row += [str(int(layout.taxel_ids[k])), str(int(layout.module_ids[k])), str(roles[k])]
        if layout.flat is not None:
            row += [fmt(v) for v in layout.flat[k]]
        if layout.can_ids is not None:
            row.append(str(int(layout.can_ids[k])))
        body.append(" ".join(row))
    body += [f"3 {a} {b} {c}" for a, b, c in faces]
    with atomic_write(path, "w", encoding="utf-8", newline="\n") as fh:
        fh.write("\n".join(head + body) + "\n")


_PLY_TYPES = {"char": "i1", "int8": "i1", "uchar": "u1", "uint8": "u1", "short": "i2", "int16": "i2",
              "ushort": "u2", "uint16": "u2", "int": "i4", "int32": "i4", "uint": "u4", "uint32": "u4",
              "float": "f4", "float32": "f4", "double": "f8", "float64": "f8"}


def read(path, units: str | None = None) -> Layout:
    """A layout from a PLY file (ASCII or binary) whose vertices are the taxels."""
    report = ImportReport(path)
    raw = read_bytes(path, "layout file")
    head, body, fmt, elements, frame, transform, parent = _header(raw, path)
    if fmt == "ascii":
        vert, faces = _ascii_elements(body, len(head), elements, path)
    else:
        vert, faces = _binary_elements(body, "<" if fmt == "binary_little_endian" else ">", elements, path, report)
    _check_vertices(vert, path)
    pos = np.column_stack([vert["x"], vert["y"], vert["z"]])
    n = len(pos)
    nrm = np.column_stack([vert[c] for c in ("nx", "ny", "nz")]) if all(c in vert for c in ("nx", "ny", "nz")) \
        else np.zeros((n, 3))
    scale = units_scale(pos, units, report, "m" if "vtcore" in "".join(head) else None)
    nrm, estimated = clean_normals(nrm, pos, report)
    ids = vert["taxel_id"].astype(np.int64) if "taxel_id" in vert else np.arange(n)
    mods = vert["module_id"].astype(np.int64) if "module_id" in vert else np.zeros(n, np.int64)
    inv = {v: k for k, v in _ROLE_CODE.items()}
    roles = np.asarray([inv.get(int(r), "other") for r in vert["role"]], dtype=object) if "role" in vert else None
    flat = np.column_stack([vert["u"], vert["v"]]) * scale if ("u" in vert and "v" in vert) else None
    can = vert["can_id"].astype(np.int64) if "can_id" in vert else None
    if len(faces) and (faces.min() < 0 or faces.max() >= n):
        raise FormatError("face indices out of range", file=path)
    layout = Layout(pos * scale, nrm, ids, mods, flat, roles, frame, transform,
                    {"faces": faces.tolist()}, can, normals_estimated=estimated, parent=parent)
    return finish(layout, report, path, "ply")


def _header(raw: bytes, path):
    """The header lines, the body's bytes, the format, the elements ``[(name, count, [(type, name) or
    ('list', count type, index type, name)])]`` and our comments' frame, transform (4, 4) and parent."""
    end = raw.find(b"end_header")
    if not raw.startswith(b"ply") or end < 0:
        raise FormatError("not a PLY file (no 'ply' magic or no end_header)", file=path, line=1)
    nl = raw.find(b"\n", end)
    head = raw[:end].decode("ascii", errors="replace").replace("\r", "").split("\n")
    body = raw[nl + 1:]
    fmt = None
    elements = []  # (name, count, [(type, name) or ('list', ct, it, name)])
    frame, transform, parent = "end_effector", np.eye(4), None
    for hno, line in enumerate(head, start=1):
        tok = line.split()
        if not tok:
            continue
        if tok[0] == "format":
            fmt = tok[1]
        elif tok[0] == "comment" and len(tok) > 2 and tok[1] == "frame":
            frame = tok[2]
        elif tok[0] == "comment" and len(tok) > 2 and tok[1] == "parent":
            parent = tok[2]
        elif tok[0] == "comment" and len(tok) == 18 and tok[1] == "transform":
            transform = transform_of([parse_number(t, path, hno, "transform") for t in tok[2:]], path,
                                     "comment transform", line=hno)
        elif tok[0] == "element":
            elements.append((tok[1], int(tok[2]), []))
        elif tok[0] == "property" and elements:
            if tok[1] == "list":
                elements[-1][2].append(("list", tok[2], tok[3], tok[4]))
            else:
                elements[-1][2].append((tok[1], tok[2]))
    if fmt not in ("ascii", "binary_little_endian", "binary_big_endian"):
        raise FormatError(f"unknown PLY format {fmt!r}", file=path)
    return head, body, fmt, elements, frame, transform, parent


def _ascii_elements(body: bytes, head_lines: int, elements: list, path):
    """``(vertex columns {name: (n,) float} or None, triangles (F, 3) int)`` of an ASCII body;
    ``head_lines`` counts the header's lines before ``end_header`` (for line numbers)."""
    vert = None
    faces = np.zeros((0, 3), np.int64)
    lines = body.decode("utf-8", errors="replace").replace("\r", "").split("\n")
    hl = head_lines + 1
    pos_line = 0
    for name, count, props in elements:
        if name == "vertex":
            names = [p[-1] for p in props]
            vals = []
            for k in range(count):
                ln = hl + pos_line + k + 1
                if pos_line + k >= len(lines):
                    raise FormatError(f"file ends after {k} of {count} vertices", file=path, line=ln)
                toks = lines[pos_line + k].split()
                if len(toks) < len(names):
                    raise FormatError(f"vertex row has {len(toks)} values, needs {len(names)}",
                                      file=path, line=ln)
                vals.append([parse_number(t, path, ln, f"vertex {names[j]}") for j, t in enumerate(toks[:len(names)])])
            vert = {nm: np.asarray(vals, float).reshape(count, -1)[:, j] for j, nm in enumerate(names)}
        elif name in ("face", "skin_face"):
            fl = []
            for k in range(count):
                toks = lines[pos_line + k].split()
                if toks and int(toks[0]) == 3 and len(toks) >= 4:
                    fl.append([int(t) for t in toks[1:4]])
            faces = np.asarray(fl, np.int64).reshape(-1, 3)
        pos_line += count
    return vert, faces


def _binary_elements(body: bytes, order: str, elements: list, path, report: ImportReport):
    """``(vertex columns {name: (n,) float} or None, triangles (F, 3) int)`` of a binary body
    (``order`` ``<`` little-, ``>`` big-endian); reading stops at an element with list properties
    that is not the faces (its size is unknown without parsing every row)."""
    vert = None
    faces = np.zeros((0, 3), np.int64)
    off = 0
    for name, count, props in elements:
        if any(p[0] == "list" for p in props):
            if name not in ("face", "skin_face") or len(props) != 1:
                report.warn(f"skipped element {name!r} with list properties")
                break
            _, ct, it, _ = props[0]
            dt = np.dtype([("n", order + _PLY_TYPES[ct]), ("i", order + _PLY_TYPES[it], 3)])
            arr = np.frombuffer(body, dtype=dt, count=count, offset=off)
            if np.any(arr["n"] != 3):
                report.warn("non-triangle faces ignored")
            faces = arr["i"][arr["n"] == 3].astype(np.int64)
            off += dt.itemsize * count
            continue
        dt = np.dtype([(p[1], order + _PLY_TYPES[p[0]]) for p in props])
        try:
            arr = np.frombuffer(body, dtype=dt, count=count, offset=off)
        except ValueError:
            raise FormatError(f"file too short for {count} {name} elements", file=path) from None
        off += dt.itemsize * count
        if name == "vertex":
            vert = {nm: arr[nm].astype(np.float64) for nm in arr.dtype.names}
    return vert, faces


def _check_vertices(vert: dict | None, path) -> None:
    """Refuse a file without vertices, without x, y or z, or with a value that is not finite."""
    if vert is None:
        raise FormatError("no vertex element", file=path)
    for c in ("x", "y", "z"):
        if c not in vert:
            raise FormatError(f"vertex has no '{c}' property", file=path)
    for nm, col in vert.items():  # binary files: NaN and infinity are valid bit patterns
        if not np.isfinite(col).all():
            raise FormatError(f"vertex {int(np.flatnonzero(~np.isfinite(col))[0])} is not finite", file=path,
                              key=f"vertex.{nm}")
