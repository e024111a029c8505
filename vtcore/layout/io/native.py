"""Our own versioned layout JSON (``"format": "vtcore-layout"``): everything a Layout holds."""

from __future__ import annotations

import json
import math

import numpy as np

from ..._io import atomic_write
from ...errors import FormatError
from ...inputs import finite_json, validate
from ..model import Layout
from .common import ImportReport, as_list, clean_normals, finish, finite_rows, read_json_doc, units_scale
from .fields import DOCUMENT, META, TAXELS, relation_problems

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


def read(path, units: str | None = None) -> Layout:
    """Read our JSON. Every field kept is checked against :mod:`.fields` first (types, shapes, ranges,
    one entry per taxel), so whatever this returns every writer can write."""
    report = ImportReport(path)
    doc = read_json_doc(path)
    if not isinstance(doc, dict) or doc.get("format") != "vtcore-layout":
        raise FormatError("not a vtcore layout JSON (no \"format\": \"vtcore-layout\")", file=path)
    top = validate(doc, DOCUMENT, file=path)
    if (top["version"] or 0) > JSON_VERSION:
        raise FormatError(f"layout JSON version {top['version']} is newer than this reader "
                          f"({JSON_VERSION})", file=path, key="version")
    t = validate(doc.get("taxels"), TAXELS, file=path, prefix="taxels")
    meta_in = doc.get("meta") if doc.get("meta") is not None else {}
    meta = validate(meta_in, META, file=path, prefix="meta")
    pos, nrm = t["positions"], t["normals"]
    n = len(pos)
    broken = relation_problems(t, meta, n)
    if broken:
        raise FormatError(broken[1], file=path, key=broken[0])
    finite_rows(pos, path, "taxels.positions")
    if top["n_taxels"] is not None and top["n_taxels"] != n:
        report.warn(f"n_taxels says {top['n_taxels']} but there are {n} positions; using the list")
    scale = units_scale(pos, units, report, top["units"])
    nrm, estimated = clean_normals(nrm, pos, report)
    if t["normals_estimated"] is not None:  # estimated when first read, kept through our JSON
        estimated = estimated | np.asarray(t["normals_estimated"], dtype=bool)
    flat = t["flat"]
    # meta keeps what the file had, with the checked entries in their checked form (numbers, not strings)
    kept = dict(meta_in)
    kept.update({k: (v.tolist() if isinstance(v, np.ndarray) else v) for k, v in meta.items() if v is not None})
    layout = Layout(pos * scale, nrm, t["taxel_ids"] if t["taxel_ids"] is not None else np.arange(n),
                    t["module_ids"] if t["module_ids"] is not None else np.zeros(n, int),
                    None if flat is None else flat * scale, t["roles"], top["frame"],
                    np.eye(4) if top["transform"] is None else top["transform"], kept,
                    t["can_ids"], estimated, top["parent"] or None)
    return finish(layout, report, path, "json")
