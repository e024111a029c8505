"""CySkin calibration JSON (``file_version`` "2"): variants with ``skin``, ``tactile_maps`` or both.

Lossless: the reader keeps the document as read (``meta["cyskin_doc"]``: ``info``, every
``tactile_maps`` entry, bare object or list, map keys, names and types, ``parent_frames``
with ``tf_matrix`` in the file's unit), the file's length unit and digests of the taxel
rows, the flat coordinates and the transform. The writer gives back the document as read
wherever the layout still holds what was read, and writes afresh only what changed (a
moved taxel, a new transform, new flat coordinates): maps-only files stay maps-only, a file
in millimetres stays in millimetres, zero normals stay zero (``estimate_normals=True``
writes the estimates). A layout from elsewhere is written as variant B.
"""

from __future__ import annotations

import copy
import json
from pathlib import Path

import numpy as np

from ..._io import atomic_write
from ...errors import FormatError, InputError
from ...inputs import clean, finite_json
from ..model import Layout
from ..uids import cyskin_modules
from .checks import MAX_COORDINATE_M, check_layout
from .common import (ImportReport, array_digest, check_repeats, clean_normals, default_faces, finish, parse_number,
                     read_json_doc, row_digests, transform_of, unchanged_rows, units_scale)

NAME = "cyskin"
SUFFIXES = (".json",)


def read(path, units: str | None = None) -> Layout:
    return parse(read_json_doc(path), path, units)


def parse(doc, path, units: str | None = None) -> Layout:
    """The Layout of a decoded CySkin document ``doc`` (``path`` names it in messages)."""
    report = ImportReport(path)
    info, skin, maps = _sections(doc, path, report)
    pos, nrm, ids, types, faces, flat, chosen_map = _taxels(skin, maps, path, report)
    _check_faces_and_ids(faces, ids, len(pos), path, report)
    scale = units_scale(pos, units, report)
    if chosen_map is not None:
        uv, _, _, _, _ = _taxels_of(chosen_map, "tactile_maps", 2, path, report)
        flat = uv * scale
    elif flat is not None:
        flat = flat * scale
    nrm, estimated = clean_normals(nrm, pos, report)
    if skin is None:
        estimated[:] = True  # (0, 0, 1) was invented for a maps-only file
    check_repeats(pos, report)
    parents = (skin or {}).get("parent_frames") or []
    transform, frame, parent = _parent_frame(parents, scale, path, report)
    # UID = module_uid << 4 | sensor; our module ids are 0-based (module_uid - 1), -1 unknown
    mods = cyskin_modules(ids)
    meta = {"info": info, "id_scheme": "cyskin", "parent_frame": parents[0] if parents else None,
            "faces": faces.tolist(), "maps": [{k: m.get(k) for k in ("key", "name", "type", "description")}
                                              for m in maps],
            "cyskin_doc": doc, "cyskin_units": "mm" if scale == 1e-3 else "m"}
    layout = Layout(pos * scale, nrm, ids, mods, flat, types, frame, transform, meta,
                    normals_estimated=estimated, parent=parent)
    layout.meta.update(_digests(layout))
    return finish(layout, report, path, "cyskin")


def _sections(doc, path, report: ImportReport):
    """``(info, skin, maps)`` of the document: ``maps`` always a list (a bare object wrapped)."""
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
    return info, skin, maps


def _taxels_of(obj, key: str, dim: int, path, report: ImportReport):
    """The taxels of a ``skin`` (``dim`` 3) or a tactile map (``dim`` 2): ``x (n, dim)`` in the
    file's unit, normals ``(n, 3)`` (``(0, 3)`` for a map), ids ``(n,)``, types ``(n,)`` and faces
    ``(F, 3)``. ``key`` names the object in messages."""
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
        xs.append([parse_number(str(v), path, None, f"{k}.x") for v in x[:dim]])
        if dim == 3:
            nn = t.get("n", [0, 0, 0])
            if not isinstance(nn, list) or len(nn) < 3:
                raise FormatError(f"'n' must have 3 numbers, got {nn!r}", file=path, key=k)
            ns.append([parse_number(str(v), path, None, f"{k}.n") for v in nn[:3]])
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


def _taxels(skin, maps: list, path, report: ImportReport):
    """The taxels of the skin, or of the first isomap (else first map) of a maps-only file placed
    in the plane z = 0: ``(pos, nrm, ids, types, faces, flat, chosen_map)``, where ``flat`` is the
    maps-only file's map coordinates and ``chosen_map`` the skin's isomap (or flat placement) of
    as many taxels, if any."""
    flat = None
    chosen_map = None
    if skin is not None:
        pos, nrm, ids, types, faces = _taxels_of(skin, "skin", 3, path, report)
        for mp in maps:
            if mp.get("type") in ("isomap", "flat_sensors_placement") and len(mp.get("taxels", [])) == len(pos):
                chosen_map = mp
                break
    else:
        mp = next((m for m in maps if m.get("type") == "isomap"), maps[0])
        uv, _, ids, types, faces = _taxels_of(mp, "tactile_maps", 2, path, report)
        pos = np.column_stack([uv, np.zeros(len(uv))])
        nrm = np.tile([0.0, 0.0, 1.0], (len(uv), 1))
        flat = uv
        report.warn("no 'skin' (3-D positions): taxels placed at the 2-D map coordinates in the plane z = 0")
    if len(pos) == 0:
        raise FormatError("no taxels", file=path)
    return pos, nrm, ids, types, faces, flat, chosen_map


def _check_faces_and_ids(faces: np.ndarray, ids: np.ndarray, n: int, path, report: ImportReport) -> None:
    """Refuse faces indexing past the ``n`` taxels; warn of duplicated faces, taxels in no face
    and repeated (nonzero) taxel ids."""
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


def _parent_frame(parents: list, scale: float, path, report: ImportReport):
    """``(transform (4, 4) m, frame, parent)`` from the skin's first parent frame: its ``tf_matrix``
    (column-major by the format; a row-major one is recognised and warned of) scaled to metres."""
    transform = np.eye(4)
    frame, parent = "end_effector", None
    if parents:
        pf = parents[0]
        tf = pf.get("tf_matrix")
        if tf is not None:
            transform = transform_of(tf, path, "skin.parent_frames[0].tf_matrix", column_major=True)
            if not np.allclose(transform[3], [0, 0, 0, 1], atol=1e-6) and np.allclose(transform[:, 3], [0, 0, 0, 1]):
                transform = transform.T.copy()  # the translation sat in the bottom row: a row-major matrix
                report.warn("tf_matrix bottom row is not [0, 0, 0, 1] but its last column is: read it as written "
                            "row-major (the format says column-major)")
            elif not np.allclose(transform[3], [0, 0, 0, 1], atol=1e-6):
                report.warn("tf_matrix bottom row is not [0, 0, 0, 1]: was it written row-major?")
            transform[:3, 3] *= scale
        # tf_matrix is the patch's pose in the link the parent frame names (p_link = R p + t): that
        # link is the layout's parent; the patch frame itself has no name in the format
        parent = pf.get("name") or None
        frame = f"{parent}_patch" if parent else frame
        if len(parents) > 1:
            report.warn(f"{len(parents)} parent frames; used the first")
    return transform, frame, parent


def doc_problem(doc: dict) -> str | None:
    """Why ``doc`` (a layout's ``meta["cyskin_doc"]``, the document as read) cannot be written back by
    :func:`write` and read again, or None: it must be a document this reader accepts, and finite."""
    import warnings

    from ...errors import VtError
    from ..mesh import LayoutWarning

    try:
        finite_json(doc)
    except InputError as exc:
        return f"{exc.key}: {exc.reason}"
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", LayoutWarning)
            with np.errstate(all="ignore"):
                lay = parse(doc, "cyskin_doc")
        if np.abs(lay.positions).max() > MAX_COORDINATE_M:
            return f"holds taxels beyond +-{MAX_COORDINATE_M:g} m"
        check_layout(lay, "cyskin_doc")
    except VtError as exc:
        return f"is not a CySkin document this reader accepts ({getattr(exc, 'reason', exc)})"
    except (ValueError, TypeError, KeyError, IndexError, AttributeError, OverflowError, RecursionError) as exc:
        return f"is not a CySkin document this reader accepts ({type(exc).__name__}: {clean(exc)})"
    return None


def _digests(layout: Layout) -> dict:
    """What the writer compares with to tell what changed since reading."""
    return {"cyskin_digests": row_digests(layout), "cyskin_transform": array_digest(layout.transform),
            "cyskin_flat": None if layout.flat is None else array_digest(layout.flat),
            "cyskin_ids": array_digest(layout.taxel_ids)}


def _fresh_doc(layout: Layout, faces: list, estimate_normals: bool) -> dict:
    """Variant B for a layout that was not read from a CySkin file."""
    info = dict(layout.meta.get("info") or {})
    source = layout.meta.get("source")
    info = {"file_version": "2", "type": info.get("type", "rigid_body"),
            "name": str(info.get("name", layout.meta.get("name", layout.frame))),
            "application": str(info.get("application", "vtcore")),
            # the file name, never a local absolute path
            "description": str(info.get("description", f"vtcore layout from {Path(source).name}" if source else
                                        "vtcore layout"))}
    doc = {"info": info, "skin": _fresh_skin(layout, faces, estimate_normals, 1.0, None)}
    maps = _fresh_maps(layout, faces)
    if maps is not None:
        doc["tactile_maps"] = maps
    return doc


def _normals_out(layout: Layout, estimate_normals: bool) -> np.ndarray:
    est = layout.normals_estimated
    if est is None or estimate_normals:
        return layout.normals
    return np.where(est[:, None], 0.0, layout.normals)  # as the file had them: zeros


def _taxel(layout, k, normals, scale, cut=0) -> dict:
    return {"id": int(layout.taxel_ids[k]), "x": [float(v) for v in layout.positions[k] / scale],
            "n": [float(v) for v in normals[k]], "type": str(layout.roles[k]), "cut": cut}


def _parent_name(layout: Layout, read_name) -> str:
    """The name of ``parent_frames[0]``: the link ``tf_matrix`` places the patch in (the layout's
    parent; a layout born in a link frame names that link), else what the file had."""
    if layout.parent:
        return layout.parent
    if layout.frame != "end_effector" and not (read_name and layout.frame == f"{read_name}_patch"):
        return layout.frame
    return read_name or ""


def _fresh_skin(layout, faces, estimate_normals, scale, parent) -> dict:
    normals = _normals_out(layout, estimate_normals)
    parent = dict(parent or {"key": 0, "id": 0, "type": "", "name": ""})
    parent["name"] = _parent_name(layout, parent.get("name"))
    tf = layout.transform.copy()
    tf[:3, 3] /= scale
    parent["tf_matrix"] = tf.T.reshape(-1).tolist()  # column-major
    return {"n_taxels": len(layout), "n_faces": len(faces), "parent_frames": [parent],
            "taxels": [_taxel(layout, k, normals, scale) for k in range(len(layout))], "faces": faces}


def _fresh_maps(layout, faces, scale: float = 1.0):
    if layout.flat is None:
        return None
    return [{"key": 0, "name": "isomap", "type": "isomap",
             "description": ["flat (unrolled) patch coordinates, " + ("millimetres" if scale == 1e-3 else "metres")],
             "n_taxels": len(layout), "n_faces": len(faces),
             "taxels": [{"id": int(i), "x": (f / scale).tolist(), "type": str(r), "cut": 0}
                        for i, f, r in zip(layout.taxel_ids, layout.flat, layout.roles)],
             "faces": faces}]


def _as_read_doc(layout: Layout, faces_arg, estimate_normals: bool) -> dict:
    """The document as read, with only what changed since reading written afresh."""
    meta = layout.meta
    doc = copy.deepcopy(meta["cyskin_doc"])
    scale = 1e-3 if meta.get("cyskin_units") == "mm" else 1.0
    now = _digests(layout)
    same = unchanged_rows(layout, meta.get("cyskin_digests"))
    skin = doc.get("skin")
    n_read = len(meta.get("cyskin_digests") or [])
    all_same = bool(same.all()) and len(layout) == n_read
    est = layout.normals_estimated if layout.normals_estimated is not None else np.zeros(len(layout), bool)
    rewrite_normals = estimate_normals and bool(est.any())
    faces = default_faces(layout) if faces_arg is None else np.asarray(faces_arg, dtype=np.int64).reshape(-1, 3)
    faces = faces.tolist()
    if "info" in doc or meta.get("info"):
        doc["info"] = meta.get("info") if meta.get("info") is not None else doc.get("info")
    if skin is None:
        if not all_same or rewrite_normals:  # the taxels were given 3-D places: the file gets a skin
            doc["skin"] = _fresh_skin(layout, faces, estimate_normals, scale, None)
    else:
        normals = _normals_out(layout, estimate_normals)
        raw = skin.get("taxels") or []
        taxels = []
        for k in range(len(layout)):
            if same[k] and k < len(raw) and not (rewrite_normals and est[k]):
                taxels.append(raw[k])
            else:
                cut = raw[k].get("cut", 0) if k < len(raw) and isinstance(raw[k], dict) else 0
                taxels.append(_taxel(layout, k, normals, scale, cut))
        skin["taxels"] = taxels
        if not all_same or faces_arg is not None:
            skin["faces"] = faces
            skin["n_taxels"], skin["n_faces"] = len(layout), len(faces)
        if now["cyskin_transform"] != meta.get("cyskin_transform"):
            parents = skin.get("parent_frames") or [{}]
            tf = layout.transform.copy()
            tf[:3, 3] /= scale
            parents[0] = dict(parents[0], name=_parent_name(layout, parents[0].get("name")),
                              tf_matrix=tf.T.reshape(-1).tolist())
            skin["parent_frames"] = parents
    # the maps are 2-D: they stay as read while the same taxels (ids, order) keep their flat coordinates
    maps_same = all(now[k] == meta.get(k) for k in ("cyskin_flat", "cyskin_ids")) and len(layout) == n_read
    if "tactile_maps" in doc and not maps_same:
        fresh = _fresh_maps(layout, faces, scale)
        if fresh is None:
            del doc["tactile_maps"]
        else:
            doc["tactile_maps"] = fresh if isinstance(doc["tactile_maps"], list) else fresh[0]
    elif "tactile_maps" not in doc and layout.flat is not None and now["cyskin_flat"] != meta.get("cyskin_flat"):
        doc["tactile_maps"] = _fresh_maps(layout, faces, scale)
    return doc


def write(layout: Layout, path, faces: np.ndarray | None = None, *, estimate_normals: bool = False) -> None:
    """Write the CySkin calibration JSON: as read for a layout read from one, else variant B.

    faces : (F, 3) taxel indices; default: the faces the layout was read with, else its skin
    mesh triangles. estimate_normals : write estimated normals (``layout.normals_estimated``)
    instead of the zeros the file had.
    """
    if isinstance(layout.meta.get("cyskin_doc"), dict):
        doc = _as_read_doc(layout, faces, estimate_normals)
    else:
        f = default_faces(layout) if faces is None else np.asarray(faces, dtype=np.int64).reshape(-1, 3)
        doc = _fresh_doc(layout, f.tolist(), estimate_normals)
    finite_json(doc)  # a NaN tf or coordinate would be written as the non-JSON token NaN
    with atomic_write(path, "w", encoding="utf-8") as fh:
        json.dump(doc, fh, indent=1, allow_nan=False)
        fh.write("\n")
