"""Calibrated layout files: read and write.

Formats (``format=`` names):

- ``json``: our own versioned JSON (``"format": "vtcore-layout", "version": 1``):
  positions, normals, taxel and module ids, roles, CAN addresses, frame name and
  4x4 transform (row-major), units, flat coordinates when known, provenance.
- ``icub``: the iCub skinGui positions text (``name``, ``spatial_sampling``,
  ``taxel2Repr ( ... )``, ``[calibration]`` rows ``x y z nx ny nz``, 12 per triangle).
- ``cyskin``: the CySkin calibration JSON (``file_version`` "2"; variants with
  ``skin``, ``tactile_maps`` or both; we write ``info`` + ``skin`` + ``tactile_maps``).
- ``csv``: one taxel a row under a header (``x,y,z`` required; ``nx,ny,nz``,
  ``taxel_id``, ``module_id``, ``u,v``, ``role``, ``can_id`` optional; ``x_mm`` style
  headers declare millimetres).
- ``ply``: vertices with per-taxel attributes, faces of the skin mesh (ASCII written;
  ASCII and binary read).
- ``mjcf``: export only: one MuJoCo site per taxel and a ``touch`` sensor on each.

Readers are lenient about what real files do (mixed tabs and spaces, CRLF,
scientific notation, non-unit or placeholder normals, repeated positions,
mismatched declared counts): they keep going and warn with
:class:`~vtcore.layout.LayoutWarning`; every warning is also kept in
``layout.meta["import_warnings"]``. A value that cannot be a number (NaN,
text) or a short row is an error that names the file and line.

Units: files without a declared unit are checked: taxels whose median
neighbour spacing exceeds 0.1 "metres" are in millimetres; we convert and warn.
Pass ``units="m"`` or ``units="mm"`` to declare them instead.
"""

from __future__ import annotations

import json
import math
import re
import warnings
from pathlib import Path

import numpy as np

from .._io import atomic_write
from ..errors import FormatError, InputError
from .mesh import LayoutWarning, _nn_spacing, estimate_normals
from .model import Layout

FORMATS = ("json", "icub", "cyskin", "csv", "ply", "mjcf")
READ_FORMATS = ("json", "icub", "cyskin", "csv", "ply")
JSON_VERSION = 1
_MM_SPACING = 0.1  # m: no skin has taxels 10 cm apart; such spacing means millimetres


class _Report:
    """Collects import warnings, emits each as a LayoutWarning once."""

    def __init__(self, path):
        self.path = str(path)
        self.items: list[str] = []

    def warn(self, msg: str, line: int | None = None):
        where = f"{self.path}:{line}" if line is not None else self.path
        text = f"{where}: {msg}"
        self.items.append(text)
        warnings.warn(text, LayoutWarning, stacklevel=3)


# --- helpers ------------------------------------------------------------------------------------
def _detect_format(path: Path) -> str:
    ext = path.suffix.lower()
    if ext == ".csv":
        return "csv"
    if ext == ".ply":
        return "ply"
    if ext in (".xml", ".mjcf"):
        return "mjcf"
    if ext == ".json":
        try:
            head = path.read_text(encoding="utf-8", errors="replace")
            data = json.loads(head)
        except (OSError, ValueError):
            return "json"
        if isinstance(data, dict) and data.get("format") == "vtcore-layout":
            return "json"
        if isinstance(data, dict) and ("skin" in data or "tactile_maps" in data or "info" in data):
            return "cyskin"
        return "json"
    if ext in (".txt", ".ini", ""):
        return "icub"
    raise InputError(f"cannot tell the layout format of {path.name!r} from its extension; "
                     f"pass format= one of {', '.join(FORMATS)}", file=path)


def _units_scale(positions: np.ndarray, units: str | None, report: _Report, declared: str | None = None) -> float:
    """Scale to metres: declared units win; else millimetres are detected from the spacing."""
    u = units or declared
    if u is not None:
        if u not in ("m", "mm"):
            raise InputError(f"units must be 'm' or 'mm', got {u!r}", file=report.path, key="units")
        if u == "m" and len(positions) > 1 and np.median(_nn_spacing(positions)) > _MM_SPACING:
            report.warn(f"declared in metres but the median taxel spacing is "
                        f"{np.median(_nn_spacing(positions)):.3g} m; is it millimetres?")
        return 1e-3 if u == "mm" else 1.0
    if len(positions) > 1:
        s = float(np.median(_nn_spacing(positions)))
        if s > _MM_SPACING:
            report.warn(f"median taxel spacing {s:.4g} would be {s:.4g} m: read as millimetres and "
                        f"converted to metres (declare units='m' or 'mm' to decide yourself)")
            return 1e-3
    return 1.0


def _clean_normals(normals: np.ndarray, positions: np.ndarray, report: _Report, what: str = "normal"):
    """Unit normals; zero ones estimated from the neighbours; non-unit ones normalised (warned)."""
    normals = np.array(normals, dtype=np.float64)
    norm = np.linalg.norm(normals, axis=1)
    zero = norm < 1e-9
    off = ~zero & (np.abs(norm - 1) > 1e-3)
    if off.any():
        report.warn(f"{int(off.sum())} {what}s are not unit length (norm {norm[off].min():.3g}-"
                    f"{norm[off].max():.3g}); normalised")
    normals[~zero] /= norm[~zero, None]
    if zero.any():
        if len(positions) >= 3:
            est = estimate_normals(positions, reference=np.where(zero[:, None], 0.0, normals)
                                   if (~zero).any() else None)
            normals[zero] = est[zero]
        else:
            normals[zero] = [0.0, 0.0, 1.0]
        report.warn(f"{int(zero.sum())} taxels have no {what} (all zeros); estimated from their neighbours")
    if len(normals) > 3 and len(np.unique(np.round(normals, 9), axis=0)) == 1:
        c = positions - positions.mean(axis=0)
        if np.linalg.svd(c, compute_uv=False)[2] > 1e-3 * np.linalg.svd(c, compute_uv=False)[0]:
            report.warn(f"every {what} is {normals[0].round(6).tolist()} on a non-planar layout: "
                        "placeholder normals? kept as given")
    return normals


def _check_repeats(positions: np.ndarray, report: _Report):
    from .mesh import find_duplicates

    rep = find_duplicates(positions, 1e-7)
    k = int((rep != np.arange(len(positions))).sum())
    if k:
        report.warn(f"{k} taxels repeat another taxel's position (kept; skin_mesh merges them)")


def _num(token: str, path, line: int, what: str) -> float:
    try:
        v = float(token)
    except ValueError:
        raise FormatError(f"{what}: {token!r} is not a number", file=path, line=line) from None
    if not math.isfinite(v):
        raise FormatError(f"{what}: {token!r} is not a finite number", file=path, line=line)
    return v


def _finish(layout: Layout, report: _Report, path, fmt: str) -> Layout:
    layout.meta.setdefault("source", str(path))
    layout.meta["source_format"] = fmt
    if report.items:
        layout.meta["import_warnings"] = list(report.items)
    return layout


def _arr(x):
    return None if x is None else np.asarray(x).tolist()


# --- own JSON -----------------------------------------------------------------------------------
def _jsonable(obj):
    if isinstance(obj, dict):
        return {str(k): _jsonable(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_jsonable(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return _jsonable(obj.tolist())
    if isinstance(obj, (np.integer,)):
        return int(obj)
    if isinstance(obj, (np.floating,)):
        return float(obj)
    if isinstance(obj, float) and not math.isfinite(obj):
        return None
    if isinstance(obj, (str, int, float, bool)) or obj is None:
        return obj
    return str(obj)


def write_json(layout: Layout, path) -> None:
    doc = {
        "format": "vtcore-layout", "version": JSON_VERSION, "units": "m",
        "frame": layout.frame, "transform": layout.transform.tolist(),
        "n_taxels": len(layout),
        "taxels": {
            "positions": layout.positions.tolist(), "normals": layout.normals.tolist(),
            "taxel_ids": layout.taxel_ids.tolist(), "module_ids": layout.module_ids.tolist(),
            "roles": [str(r) for r in layout.roles],
            "flat": _arr(layout.flat), "can_ids": _arr(layout.can_ids),
        },
        "meta": _jsonable(layout.meta),
    }
    with atomic_write(path, "w", encoding="utf-8") as fh:
        json.dump(doc, fh, indent=1)
        fh.write("\n")


def read_json(path, units: str | None = None) -> Layout:
    report = _Report(path)
    try:
        doc = json.loads(Path(path).read_text(encoding="utf-8"))
    except json.JSONDecodeError as exc:
        raise FormatError(f"not valid JSON: {exc.msg}", file=path, line=exc.lineno) from None
    if not isinstance(doc, dict) or doc.get("format") != "vtcore-layout":
        raise FormatError("not a vtcore layout JSON (no \"format\": \"vtcore-layout\")", file=path)
    if int(doc.get("version", 0)) > JSON_VERSION:
        raise FormatError(f"layout JSON version {doc.get('version')} is newer than this reader "
                          f"({JSON_VERSION})", file=path, key="version")
    t = doc.get("taxels") or {}
    for key in ("positions", "normals"):
        if key not in t:
            raise FormatError("missing", file=path, key=f"taxels.{key}")
    try:
        pos = np.asarray(t["positions"], dtype=np.float64)
        nrm = np.asarray(t["normals"], dtype=np.float64)
    except (TypeError, ValueError):
        raise FormatError("positions and normals must be lists of 3 numbers", file=path, key="taxels") from None
    for key, a in (("positions", pos), ("normals", nrm)):
        if a.ndim != 2 or a.shape[1] != 3:
            raise FormatError(f"must be a list of [x, y, z], got shape {a.shape}", file=path, key=f"taxels.{key}")
        bad = ~np.isfinite(a).all(axis=1)
        if bad.any():
            raise FormatError(f"row {int(np.flatnonzero(bad)[0])} is not finite", file=path, key=f"taxels.{key}")
    n = len(pos)
    if doc.get("n_taxels") is not None and doc["n_taxels"] != n:
        report.warn(f"n_taxels says {doc['n_taxels']} but there are {n} positions; using the list")
    scale = _units_scale(pos, units, report, doc.get("units"))
    flat = t.get("flat")
    layout = Layout(pos * scale, _clean_normals(nrm, pos, report), t.get("taxel_ids", np.arange(n)),
                    t.get("module_ids", np.zeros(n, int)),
                    None if flat is None else np.asarray(flat, dtype=np.float64) * scale,
                    t.get("roles"), doc.get("frame", "end_effector"),
                    np.asarray(doc.get("transform", np.eye(4)), dtype=np.float64), dict(doc.get("meta") or {}),
                    t.get("can_ids"))
    return _finish(layout, report, path, "json")


# --- iCub positions -------------------------------------------------------------------------------
_T2R = re.compile(r"taxel2Repr\s*\((.*?)\)", re.S)


def read_icub(path, units: str | None = None) -> Layout:
    """Read an iCub skinGui positions file. Every calibration row is read (the
    reference reader drops the last one); rows of six zeros are empty slots."""
    report = _Report(path)
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
        rows.append([_num(tok, path, ln, "calibration value") for tok in toks[:6]])
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
    scale = _units_scale(pos, units, report)
    nrm = _clean_normals(data[keep, 3:], pos, report)
    _check_repeats(pos, report)
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
    return _finish(layout, report, path, "icub")


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


def write_icub(layout: Layout, path) -> None:
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


# --- CySkin calibration JSON --------------------------------------------------------------------------
def read_cyskin(path, units: str | None = None) -> Layout:
    report = _Report(path)
    try:
        doc = json.loads(Path(path).read_text(encoding="utf-8"))
    except json.JSONDecodeError as exc:
        raise FormatError(f"not valid JSON: {exc.msg}", file=path, line=exc.lineno) from None
    if not isinstance(doc, dict):
        raise FormatError("the top level must be an object with 'skin' and/or 'tactile_maps'", file=path)
    info = doc.get("info") or {}
    skin = doc.get("skin")
    maps = doc.get("tactile_maps")
    if isinstance(maps, dict):
        maps = [maps]
    maps = maps or []
    if skin is None and not maps:
        raise FormatError("neither 'skin' nor 'tactile_maps' found", file=path)
    if info and str(info.get("file_version", "2")) != "2":
        report.warn(f"file_version {info.get('file_version')!r}; this reader knows version 2")

    def taxels_of(obj, key, dim):
        tl = obj.get("taxels")
        if not isinstance(tl, list):
            raise FormatError("'taxels' must be a list", file=path, key=f"{key}.taxels")
        xs, ids, types = [], [], []
        ns = []
        for i, t in enumerate(tl):
            k = f"{key}.taxels[{i}]"
            if not isinstance(t, dict) or "x" not in t:
                raise FormatError("each taxel needs 'x'", file=path, key=k)
            x = t["x"]
            if not isinstance(x, list) or len(x) < dim:
                raise FormatError(f"'x' must have {dim} numbers, got {x!r}", file=path, key=k)
            xs.append([_num(str(v), path, None, f"{k}.x") for v in x[:dim]])
            if dim == 3:
                nn = t.get("n", [0, 0, 0])
                if not isinstance(nn, list) or len(nn) < 3:
                    raise FormatError(f"'n' must have 3 numbers, got {nn!r}", file=path, key=k)
                ns.append([_num(str(v), path, None, f"{k}.n") for v in nn[:3]])
            ids.append(int(t.get("id", 0)))
            types.append(str(t.get("type", "pressure")) or "pressure")
        declared = obj.get("n_taxels")
        if declared is not None and declared != len(tl):
            report.warn(f"{key}.n_taxels says {declared} but the list has {len(tl)}; using the list")
        faces = np.asarray(obj.get("faces") or np.zeros((0, 3)), dtype=np.int64).reshape(-1, 3)
        if obj.get("n_faces") is not None and obj["n_faces"] != len(faces):
            report.warn(f"{key}.n_faces says {obj['n_faces']} but the list has {len(faces)}; using the list")
        return np.asarray(xs, float).reshape(-1, dim), np.asarray(ns, float).reshape(-1, 3), \
            np.asarray(ids, np.int64), np.asarray(types, dtype=object), faces

    flat = None
    chosen_map = None
    if skin is not None:
        pos, nrm, ids, types, faces = taxels_of(skin, "skin", 3)
        for mp in maps:
            if mp.get("type") in ("isomap", "flat_sensors_placement") and len(mp.get("taxels", [])) == len(pos):
                chosen_map = mp
                break
    else:
        mp = next((m for m in maps if m.get("type") == "isomap"), maps[0])
        uv, _, ids, types, faces = taxels_of(mp, "tactile_maps", 2)
        pos = np.column_stack([uv, np.zeros(len(uv))])
        nrm = np.tile([0.0, 0.0, 1.0], (len(uv), 1))
        flat = uv
        report.warn("no 'skin' (3-D positions): taxels placed at the 2-D map coordinates in the plane z = 0")
    if len(pos) == 0:
        raise FormatError("no taxels", file=path)
    n = len(pos)
    if len(faces) and (faces.min() < 0 or faces.max() >= n):
        raise FormatError(f"faces index taxels 0..{n - 1} but contain {faces.min()}..{faces.max()}",
                          file=path, key="skin.faces")
    if len(faces):
        u = np.unique(np.sort(faces, axis=1), axis=0)
        if len(u) < len(faces):
            report.warn(f"{len(faces) - len(u)} duplicated faces")
        lonely = np.setdiff1d(np.arange(n), faces.ravel())
        if len(lonely):
            report.warn(f"{len(lonely)} taxels belong to no face")
    nz = ids[ids > 0]
    if len(np.unique(nz)) < len(nz):
        report.warn(f"{len(nz) - len(np.unique(nz))} repeated taxel ids (positions all kept)")
    scale = _units_scale(pos, units, report)
    if chosen_map is not None:
        uv, _, _, _, _ = taxels_of(chosen_map, "tactile_maps", 2)
        flat = uv * scale
    elif flat is not None:
        flat = flat * scale
    nrm = _clean_normals(nrm, pos, report)
    _check_repeats(pos, report)
    transform = np.eye(4)
    frame = "end_effector"
    parents = (skin or {}).get("parent_frames") or []
    if parents:
        pf = parents[0]
        tf = pf.get("tf_matrix")
        if tf is not None:
            if len(tf) != 16:
                raise FormatError(f"tf_matrix needs 16 numbers, got {len(tf)}", file=path,
                                  key="skin.parent_frames[0].tf_matrix")
            transform = np.asarray(tf, dtype=np.float64).reshape(4, 4).T  # column-major
            transform[:3, 3] *= scale
            if not np.allclose(transform[3], [0, 0, 0, 1], atol=1e-6):
                report.warn("tf_matrix bottom row is not [0, 0, 0, 1]: was it written row-major?")
        frame = pf.get("name") or frame
        if len(parents) > 1:
            report.warn(f"{len(parents)} parent frames; used the first")
    # UID = module_uid << 4 | sensor; our module ids are 0-based (module_uid - 1), -1 unknown
    mods = np.where(ids > 0, (ids >> 4) - 1, -1)
    meta = {"info": info, "id_scheme": "cyskin", "parent_frame": parents[0] if parents else None,
            "faces": faces.tolist(), "maps": [{k: m.get(k) for k in ("key", "name", "type", "description")}
                                              for m in maps]}
    layout = Layout(pos * scale, nrm, ids, mods, flat, types, frame, transform, meta)
    return _finish(layout, report, path, "cyskin")


def _default_faces(layout: Layout) -> np.ndarray:
    """The faces a file read from had (``meta["faces"]``, kept for a lossless round trip), else the
    layout's skin mesh triangles."""
    f = layout.meta.get("faces")
    if f is not None:
        f = np.asarray(f, dtype=np.int64).reshape(-1, 3)
        if not len(f) or (f.min() >= 0 and f.max() < len(layout)):
            return f
    from .mesh import skin_mesh

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", LayoutWarning)
        return skin_mesh(layout).triangles if len(layout) >= 3 else np.zeros((0, 3), np.int64)


def write_cyskin(layout: Layout, path, faces: np.ndarray | None = None) -> None:
    """Write the CySkin calibration JSON (variant B: info, skin, tactile_maps).

    faces : (F, 3) taxel indices; default: the faces the layout was read with, else its skin
    mesh triangles.
    """
    if faces is None:
        faces = _default_faces(layout)
    faces = np.asarray(faces, dtype=np.int64).reshape(-1, 3).tolist()
    info = dict(layout.meta.get("info") or {})
    info = {"file_version": "2", "type": info.get("type", "rigid_body"),
            "name": str(info.get("name", layout.meta.get("name", layout.frame))),
            "application": str(info.get("application", "vtcore")),
            "description": str(info.get("description", layout.meta.get("source", "")))}
    parent = dict(layout.meta.get("parent_frame") or {"key": 0, "id": 0, "type": "", "name": ""})
    parent["name"] = parent.get("name") or layout.frame
    parent["tf_matrix"] = layout.transform.T.reshape(-1).tolist()  # column-major
    taxels = [{"id": int(i), "x": p.tolist(), "n": q.tolist(), "type": str(r), "cut": 0}
              for i, p, q, r in zip(layout.taxel_ids, layout.positions, layout.normals, layout.roles)]
    doc = {"info": info,
           "skin": {"n_taxels": len(layout), "n_faces": len(faces), "parent_frames": [parent],
                    "taxels": taxels, "faces": faces}}
    if layout.flat is not None:
        doc["tactile_maps"] = [{
            "key": 0, "name": "isomap", "type": "isomap",
            "description": ["flat (unrolled) patch coordinates, metres"],
            "n_taxels": len(layout), "n_faces": len(faces),
            "taxels": [{"id": int(i), "x": f.tolist(), "type": str(r), "cut": 0}
                       for i, f, r in zip(layout.taxel_ids, layout.flat, layout.roles)],
            "faces": faces}]
    with atomic_write(path, "w", encoding="utf-8") as fh:
        json.dump(doc, fh, indent=1)
        fh.write("\n")


# --- CSV --------------------------------------------------------------------------------------------------
_CSV_COLS = ("taxel_id", "module_id", "x", "y", "z", "nx", "ny", "nz", "u", "v", "role", "can_id")


def write_csv(layout: Layout, path) -> None:
    cols = ["taxel_id", "module_id", "x", "y", "z", "nx", "ny", "nz"]
    if layout.flat is not None:
        cols += ["u", "v"]
    cols.append("role")
    if layout.can_ids is not None:
        cols.append("can_id")
    fmt = lambda v: format(float(v), ".12g")  # noqa: E731
    lines = [",".join(cols)]
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


def read_csv(path, units: str | None = None) -> Layout:
    report = _Report(path)
    text = Path(path).read_bytes().decode("utf-8-sig", errors="replace").replace("\r\n", "\n").replace("\r", "\n")
    lines = text.split("\n")
    header = None
    declared = None
    rows = []
    for ln, line in enumerate(lines, start=1):
        s = line.strip()
        if not s:
            continue
        if s.startswith("#"):
            m = re.search(r"units?\s*[:=]\s*(mm|m)\b", s)
            if m:
                declared = m.group(1)
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
    # units written into column names: x_mm, y_mm ...
    names = []
    for h in header:
        m = re.fullmatch(r"(.+?)[_\s\[(]*(mm|m)[\])]*", h)
        if m and m.group(1) in ("x", "y", "z", "u", "v"):
            declared = declared or m.group(2)
            names.append(m.group(1))
        else:
            names.append({"id": "taxel_id", "uid": "taxel_id", "module": "module_id", "type": "role",
                          "can": "can_id"}.get(h, h))
    missing = [c for c in ("x", "y", "z") if c not in names]
    if missing:
        raise FormatError(f"header lacks column(s) {', '.join(missing)} (has: {', '.join(header)})",
                          file=path, line=header_line)
    unknown = [h for h, nm in zip(header, names) if nm not in _CSV_COLS]
    if unknown:
        report.warn(f"ignored unknown column(s): {', '.join(unknown)}", line=header_line)
    if not rows:
        raise FormatError("no taxel rows after the header", file=path)
    col = {nm: i for i, nm in enumerate(names)}

    def numeric(name, integer=False):
        i = col[name]
        out = []
        for ln, toks in rows:
            v = _num(toks[i], path, ln, f"column {header[i]}")
            if integer:
                if v != int(v):
                    raise FormatError(f"column {header[i]}: {toks[i]!r} is not an integer", file=path, line=ln)
                v = int(v)
            out.append(v)
        return np.asarray(out, dtype=np.int64 if integer else np.float64)

    n = len(rows)
    pos = np.column_stack([numeric(c) for c in ("x", "y", "z")])
    if all(c in col for c in ("nx", "ny", "nz")):
        nrm = np.column_stack([numeric(c) for c in ("nx", "ny", "nz")])
    else:
        nrm = np.zeros((n, 3))
    scale = _units_scale(pos, units, report, declared)
    nrm = _clean_normals(nrm, pos, report)
    _check_repeats(pos, report)
    ids = numeric("taxel_id", True) if "taxel_id" in col else np.arange(n)
    mods = numeric("module_id", True) if "module_id" in col else (
        np.where(ids > 0, (ids >> 4) - 1, -1) if "taxel_id" in col else np.zeros(n, np.int64))
    flat = np.column_stack([numeric("u"), numeric("v")]) * scale if ("u" in col and "v" in col) else None
    roles = np.asarray([toks[col["role"]] or "pressure" for _, toks in rows], dtype=object) \
        if "role" in col else None
    can = numeric("can_id", True) if "can_id" in col else None
    layout = Layout(pos * scale, nrm, ids, mods, flat, roles, can_ids=can)
    return _finish(layout, report, path, "csv")


# --- PLY --------------------------------------------------------------------------------------------------
_ROLE_CODE = {"pressure": 0, "thermal": 1}


def write_ply(layout: Layout, path, faces: np.ndarray | None = None) -> None:
    """ASCII PLY: vertex ``x y z nx ny nz taxel_id module_id role [u v] [can_id]`` and the
    faces the layout was read with, else its skin mesh (``role`` 0 pressure, 1 thermal, 2 other)."""
    if faces is None:
        faces = _default_faces(layout)
    faces = np.asarray(faces, dtype=np.int64).reshape(-1, 3)
    props = ["double x", "double y", "double z", "double nx", "double ny", "double nz",
             "int taxel_id", "int module_id", "uchar role"]
    if layout.flat is not None:
        props += ["double u", "double v"]
    if layout.can_ids is not None:
        props += ["int can_id"]
    head = ["ply", "format ascii 1.0", "comment vtcore layout, units metres",
            f"comment frame {layout.frame}",
            "comment transform " + " ".join(format(v, ".12g") for v in layout.transform.ravel()),
            f"element vertex {len(layout)}"] + [f"property {p}" for p in props] + \
        [f"element face {len(faces)}", "property list uchar int vertex_indices", "end_header"]
    fmt = lambda v: format(float(v), ".12g")  # noqa: E731
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


def read_ply(path, units: str | None = None) -> Layout:
    report = _Report(path)
    raw = Path(path).read_bytes()
    end = raw.find(b"end_header")
    if not raw.startswith(b"ply") or end < 0:
        raise FormatError("not a PLY file (no 'ply' magic or no end_header)", file=path, line=1)
    nl = raw.find(b"\n", end)
    head = raw[:end].decode("ascii", errors="replace").replace("\r", "").split("\n")
    body = raw[nl + 1:]
    fmt = None
    elements = []  # (name, count, [(type, name) or ('list', ct, it, name)])
    frame, transform = "end_effector", np.eye(4)
    for line in head:
        tok = line.split()
        if not tok:
            continue
        if tok[0] == "format":
            fmt = tok[1]
        elif tok[0] == "comment" and len(tok) > 2 and tok[1] == "frame":
            frame = tok[2]
        elif tok[0] == "comment" and len(tok) == 18 and tok[1] == "transform":
            transform = np.asarray([float(t) for t in tok[2:]]).reshape(4, 4)
        elif tok[0] == "element":
            elements.append((tok[1], int(tok[2]), []))
        elif tok[0] == "property" and elements:
            if tok[1] == "list":
                elements[-1][2].append(("list", tok[2], tok[3], tok[4]))
            else:
                elements[-1][2].append((tok[1], tok[2]))
    if fmt not in ("ascii", "binary_little_endian", "binary_big_endian"):
        raise FormatError(f"unknown PLY format {fmt!r}", file=path)
    vert = None
    faces = np.zeros((0, 3), np.int64)
    if fmt == "ascii":
        lines = body.decode("utf-8", errors="replace").replace("\r", "").split("\n")
        hl = len(head) + 1
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
                    vals.append([_num(t, path, ln, f"vertex {names[j]}") for j, t in enumerate(toks[:len(names)])])
                vert = {nm: np.asarray(vals, float).reshape(count, -1)[:, j] for j, nm in enumerate(names)}
            elif name == "face":
                fl = []
                for k in range(count):
                    toks = lines[pos_line + k].split()
                    if toks and int(toks[0]) == 3 and len(toks) >= 4:
                        fl.append([int(t) for t in toks[1:4]])
                faces = np.asarray(fl, np.int64).reshape(-1, 3)
            pos_line += count
    else:
        order = "<" if fmt == "binary_little_endian" else ">"
        off = 0
        for name, count, props in elements:
            if any(p[0] == "list" for p in props):
                if name != "face" or len(props) != 1:
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
    if vert is None:
        raise FormatError("no vertex element", file=path)
    for c in ("x", "y", "z"):
        if c not in vert:
            raise FormatError(f"vertex has no '{c}' property", file=path)
    pos = np.column_stack([vert["x"], vert["y"], vert["z"]])
    if not np.isfinite(pos).all():
        raise FormatError(f"vertex {int(np.flatnonzero(~np.isfinite(pos).all(1))[0])} is not finite", file=path)
    n = len(pos)
    nrm = np.column_stack([vert[c] for c in ("nx", "ny", "nz")]) if all(c in vert for c in ("nx", "ny", "nz")) \
        else np.zeros((n, 3))
    scale = _units_scale(pos, units, report, "m" if "vtcore" in "".join(head) else None)
    nrm = _clean_normals(nrm, pos, report)
    ids = vert["taxel_id"].astype(np.int64) if "taxel_id" in vert else np.arange(n)
    mods = vert["module_id"].astype(np.int64) if "module_id" in vert else np.zeros(n, np.int64)
    inv = {v: k for k, v in _ROLE_CODE.items()}
    roles = np.asarray([inv.get(int(r), "other") for r in vert["role"]], dtype=object) if "role" in vert else None
    flat = np.column_stack([vert["u"], vert["v"]]) * scale if ("u" in vert and "v" in vert) else None
    can = vert["can_id"].astype(np.int64) if "can_id" in vert else None
    if len(faces) and (faces.min() < 0 or faces.max() >= n):
        raise FormatError("face indices out of range", file=path)
    layout = Layout(pos * scale, nrm, ids, mods, flat, roles, frame, transform,
                    {"faces": faces.tolist()}, can)
    return _finish(layout, report, path, "ply")


# --- MJCF -------------------------------------------------------------------------------------------------
def write_mjcf(layout: Layout, path, *, site_radius: float | None = None, site_depth: float = 1e-3) -> None:
    """MuJoCo MJCF: a body holding one cylinder site per taxel (axis along its normal)
    and a ``touch`` sensor on each site, in taxel order."""
    from xml.sax.saxutils import quoteattr

    r = site_radius if site_radius is not None else float(layout.meta.get("taxel_radius_m", 2e-3))
    fmt = lambda v: format(float(v), ".9g")  # noqa: E731
    name = str(layout.meta.get("name") or layout.meta.get("end_effector") or "skin")
    lines = [f'<mujoco model={quoteattr(name)}>',
             '  <!-- written by vtcore: one site per taxel, one touch sensor per site; metres -->',
             "  <worldbody>", f"    <body name={quoteattr(layout.frame)}>"]
    sites = []
    unique_ids = len(np.unique(layout.taxel_ids)) == len(layout)  # else name sites by row
    for k in range(len(layout)):
        sname = f"taxel_{int(layout.taxel_ids[k])}" if unique_ids else f"taxel_{k}"
        sites.append(sname)
        p = " ".join(fmt(v) for v in layout.positions[k])
        z = " ".join(fmt(v) for v in layout.normals[k])
        lines.append(f'      <site name="{sname}" type="cylinder" pos="{p}" zaxis="{z}" '
                     f'size="{fmt(r)} {fmt(site_depth / 2)}" rgba="0.2 0.8 0.2 0.5"/>')
    lines += ["    </body>", "  </worldbody>", "  <sensor>"]
    lines += [f'    <touch name="touch_{s[6:]}" site="{s}"/>' for s in sites]
    lines += ["  </sensor>", "</mujoco>"]
    with atomic_write(path, "w", encoding="utf-8", newline="\n") as fh:
        fh.write("\n".join(lines) + "\n")


# --- dispatch -------------------------------------------------------------------------------------------
_READERS = {"json": read_json, "icub": read_icub, "cyskin": read_cyskin, "csv": read_csv, "ply": read_ply}
_WRITERS = {"json": write_json, "icub": write_icub, "cyskin": write_cyskin, "csv": write_csv,
            "ply": write_ply, "mjcf": write_mjcf}


def load(path, format: str | None = None, *, units: str | None = None) -> Layout:
    """Read a layout file.

    path : file. format : one of ``json, icub, cyskin, csv, ply`` (default: from
    the extension and, for ``.json``, the content). units : ``"m"`` or ``"mm"``
    to declare the file's length unit; by default declared units in the file
    are used, else millimetres are detected (and warned about).
    """
    path = Path(path)
    if not path.is_file():
        raise InputError("file not found", file=path)
    fmt = format or _detect_format(path)
    if fmt not in _READERS:
        raise InputError(f"cannot read format {fmt!r}; readable: {', '.join(READ_FORMATS)}", file=path,
                         key="format")
    return _READERS[fmt](path, units=units)


def save(layout: Layout, path, format: str | None = None, *, transform=None) -> None:
    """Write ``layout`` to ``path`` (written to a temporary file, then renamed).

    format : one of ``json, icub, cyskin, csv, ply, mjcf`` (default from the
    extension; ``.json`` means our own JSON). transform : optional (4, 4)
    rigid transform; the taxels are written in that frame (``p' = R p + t``).
    """
    path = Path(path)
    fmt = format
    if fmt is None:
        ext = path.suffix.lower()
        fmt = {".json": "json", ".csv": "csv", ".ply": "ply", ".xml": "mjcf", ".mjcf": "mjcf",
               ".txt": "icub", ".ini": "icub"}.get(ext)
        if fmt is None:
            raise InputError(f"cannot tell the format from {path.name!r}; pass format= one of "
                             f"{', '.join(FORMATS)}", file=path)
    if fmt not in _WRITERS:
        raise InputError(f"unknown format {fmt!r}; use one of {', '.join(FORMATS)}", file=path, key="format")
    if transform is not None:
        t = np.asarray(transform, dtype=np.float64)
        if t.shape != (4, 4) or not np.isfinite(t).all():
            raise InputError("transform must be a finite 4x4 matrix", key="transform")
        r = t[:3, :3]
        if not np.allclose(r @ r.T, np.eye(3), atol=1e-4) or not np.allclose(t[3], [0, 0, 0, 1]):
            raise InputError("transform must be rigid (orthonormal rotation, bottom row 0 0 0 1)",
                             key="transform")
        layout = layout.transformed(t)
    _WRITERS[fmt](layout, path)
