"""CySkin calibration JSON (``file_version`` "2"): variants with ``skin``, ``tactile_maps`` or both."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from ..._io import atomic_write
from ...errors import FormatError
from ..model import Layout
from ..uids import cyskin_modules
from .common import ImportReport, check_repeats, clean_normals, default_faces, finish, parse_number, units_scale

NAME = "cyskin"
SUFFIXES = (".json",)


def read(path, units: str | None = None) -> Layout:
    report = ImportReport(path)
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
    scale = units_scale(pos, units, report)
    if chosen_map is not None:
        uv, _, _, _, _ = taxels_of(chosen_map, "tactile_maps", 2)
        flat = uv * scale
    elif flat is not None:
        flat = flat * scale
    nrm = clean_normals(nrm, pos, report)
    check_repeats(pos, report)
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
    mods = cyskin_modules(ids)
    meta = {"info": info, "id_scheme": "cyskin", "parent_frame": parents[0] if parents else None,
            "faces": faces.tolist(), "maps": [{k: m.get(k) for k in ("key", "name", "type", "description")}
                                              for m in maps]}
    layout = Layout(pos * scale, nrm, ids, mods, flat, types, frame, transform, meta)
    return finish(layout, report, path, "cyskin")


def write(layout: Layout, path, faces: np.ndarray | None = None) -> None:
    """Write the CySkin calibration JSON (variant B: info, skin, tactile_maps).

    faces : (F, 3) taxel indices; default: the faces the layout was read with, else its skin
    mesh triangles.
    """
    if faces is None:
        faces = default_faces(layout)
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


