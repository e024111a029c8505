"""Our own versioned layout JSON (``"format": "vtcore-layout"``): everything a Layout holds."""

from __future__ import annotations

import json
import math

import numpy as np

from ..._io import atomic_write
from ...errors import FormatError
from ...inputs import finite_json
from ..model import Layout
from .common import (ImportReport, as_list, clean_normals, finish, finite_rows, read_json_doc, transform_of,
                     units_scale)

NAME = "json"
SUFFIXES = (".json",)
JSON_VERSION = 1


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


def write(layout: Layout, path) -> None:
    doc = {
        "format": "vtcore-layout", "version": JSON_VERSION, "units": "m",
        "frame": layout.frame, "parent": layout.parent, "transform": layout.transform.tolist(),
        "n_taxels": len(layout),
        "taxels": {
            "positions": layout.positions.tolist(), "normals": layout.normals.tolist(),
            "taxel_ids": layout.taxel_ids.tolist(), "module_ids": layout.module_ids.tolist(),
            "roles": [str(r) for r in layout.roles],
            "flat": as_list(layout.flat), "can_ids": as_list(layout.can_ids),
            "normals_estimated": as_list(layout.normals_estimated),
        },
        "meta": _jsonable(layout.meta),
    }
    finite_json(doc)  # a NaN tf or coordinate would be written as the non-JSON token NaN
    with atomic_write(path, "w", encoding="utf-8") as fh:
        json.dump(doc, fh, indent=1, allow_nan=False)
        fh.write("\n")


def _name(value, path):
    if value is None or isinstance(value, str):
        return value or None
    raise FormatError(f"must be a frame name (a string), got {type(value).__name__}", file=path, key="parent")


def read(path, units: str | None = None) -> Layout:
    report = ImportReport(path)
    doc = read_json_doc(path)
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
    transform = transform_of(doc["transform"], path, "transform") if doc.get("transform") is not None else np.eye(4)
    flat = t.get("flat")
    if flat is not None:
        try:
            flat = np.asarray(flat, dtype=np.float64).reshape(n, 2)
        except (TypeError, ValueError, OverflowError):
            raise FormatError(f"must be a list of {n} [u, v]", file=path, key="taxels.flat") from None
        finite_rows(flat, path, "taxels.flat")
    if doc.get("n_taxels") is not None and doc["n_taxels"] != n:
        report.warn(f"n_taxels says {doc['n_taxels']} but there are {n} positions; using the list")
    scale = units_scale(pos, units, report, doc.get("units"))
    nrm, estimated = clean_normals(nrm, pos, report)
    if t.get("normals_estimated") is not None:  # estimated when first read, kept through our JSON
        estimated = estimated | np.asarray(t["normals_estimated"], dtype=bool).reshape(-1)[:n]
    layout = Layout(pos * scale, nrm, t.get("taxel_ids", np.arange(n)),
                    t.get("module_ids", np.zeros(n, int)),
                    None if flat is None else flat * scale,
                    t.get("roles"), doc.get("frame", "end_effector"), transform, dict(doc.get("meta") or {}),
                    t.get("can_ids"), estimated, _name(doc.get("parent"), path))
    return finish(layout, report, path, "json")


