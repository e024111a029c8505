"""Skin layout edits for a front end: lay or fill a patch, remove or move modules, export."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..._progress import keep_going
from ...errors import InputError
from ...layout import Layout, skin_mesh
from .common import as_trimesh


def merge(base: Layout | None, extra: Layout) -> Layout:
    """Taxels of ``base`` followed by those of ``extra``, whose modules are numbered after
    base's (from 0 without a base): :meth:`Layout.concat`.

    Without a base, ``extra`` keeps its flat coordinates. With one, the result has none:
    ``extra`` was unrolled about its own anchor and ``base`` about another, so their flat
    coordinates are in different charts and together would overlap.
    """
    if base is None or len(base) == 0:
        return extra.renumber(0)
    out = Layout.concat([base, extra])
    out.flat = None
    return out


def selection_anchor(face_centres, face_areas, selected) -> np.ndarray:
    """Where a patch or a fill over selected faces is anchored: (3,) metres.

    face_centres : (F, 3) metres, any frame (the result is in the same one);
    face_areas : (F,) m^2; selected : (F,) bool mask or indices of the selected faces.
    The anchor is the selected face centre nearest the area-weighted mean of the selected
    centres: the mean itself lies inside the body when the selection is curved (the top and
    a flank) and snaps to a face outside the selection, where a fill finds no room.
    """
    c = np.asarray(face_centres, dtype=np.float64).reshape(-1, 3)
    w = np.asarray(face_areas, dtype=np.float64).reshape(-1)
    if len(w) != len(c):
        raise InputError(f"{len(w)} face areas for {len(c)} face centres", key="face_areas")
    sel = np.asarray(selected)
    if sel.dtype == bool:
        if len(sel) != len(c):
            raise InputError(f"a mask of {len(sel)} faces for {len(c)} faces", key="selected")
        sel = np.flatnonzero(sel)
    sel = sel.astype(np.int64).reshape(-1)
    if len(sel) and (sel.min() < 0 or sel.max() >= len(c)):
        raise InputError(f"face indices must be in 0..{len(c) - 1}", key="selected")
    if len(sel) == 0:
        raise InputError("select at least one face", key="selected")
    c, w = c[sel], w[sel] + 1e-30  # zero-area faces still count when all are zero
    mean = (c * w[:, None]).sum(0) / w.sum()
    return c[np.argmin(((c - mean) ** 2).sum(1))]


@dataclass
class LayoutEdit:
    """A layout after an edit, with what to show.

    layout : all taxels (skin frame, metres). triangles : (F, 3) skin mesh.
    report : dict of the placement report (strain_max, strain_mean, overlaps,
    coverage, notes) of the edit, or {}.
    """

    layout: Layout
    triangles: np.ndarray
    report: dict


def skin_triangles(layout: Layout) -> np.ndarray:
    """(F, 3) int64 skin mesh triangles of ``layout`` to show; none for fewer than three taxels
    or a layout the skin mesh refuses (its InputError), so the add-on shows the taxels alone."""
    if len(layout) < 3:
        return np.zeros((0, 3), np.int64)
    try:
        return np.asarray(skin_mesh(layout).triangles, np.int64)
    except ValueError:
        return np.zeros((0, 3), np.int64)


def _edit(layout: Layout, report: dict) -> LayoutEdit:
    return LayoutEdit(layout, skin_triangles(layout), report)


def lay_patch(vertices, triangles, at, *, existing: Layout | None = None, patch: str = "hexagon",
              module: str = "cyskin10", direction=None, offset: float = 0.0, method: str = "logmap",
              fill_region=None, max_faces: int | None = 20_000, progress=None) -> LayoutEdit:
    """Conform a patch (or fill a face region with modules) onto a mesh, added to ``existing``.

    vertices : (V, 3) metres and triangles : (F, 3) of the end-effector surface, in
    the skin frame. at : (3,) metres, the point the patch is centred on (snapped to
    the surface). patch : "hexagon", "triangle" or "strip:N"; module : module type.
    direction : (3,) in-plane x axis or None. offset : metres along the normal.
    fill_region : (F,) bool face mask: tile that region with whole modules instead.
    max_faces : the log map is solved on a copy simplified to about this many faces
        (vtcore.layout.place's speed/accuracy knob; None: the full mesh). A fill sizes its copy
        by the module pitch instead (``fill(max_faces="auto")``) unless this is None.
    progress : None or ``progress(fraction) -> bool`` (0..1); returning False stops a fill,
        which raises :class:`vtcore.errors.Cancelled` (nothing is returned or changed).
        It is told 0 when the fill starts, the fill's own fractions as its growth proceeds
        (after each chart, so a stop takes effect at the next one) and 1 when it ends.
    Returns the merged layout, its skin mesh and the placement report.
    """
    from ...layout import fill, place

    mesh = as_trimesh(vertices, triangles)
    at = np.asarray(at, dtype=np.float64).reshape(3)
    if fill_region is not None:
        region = np.asarray(fill_region, dtype=bool).reshape(-1)
        if len(region) != len(mesh.faces) or not region.any():
            raise InputError("select at least one face of the end-effector to fill", key="region")
        keep_going(progress, 0.0, "the fill")
        new, rep = fill(mesh, at, direction, module=module, region=region, offset=offset,
                        max_faces=None if max_faces is None else "auto", existing=existing, progress=progress)
        keep_going(progress, 1.0, "the fill")
    else:
        new, rep = place(mesh, patch, at, direction, module=module, offset=offset, method=method,
                         max_faces=max_faces, existing=existing)
    if len(new) == 0:
        raise InputError("no module fits there", key="at")
    report = rep.as_dict()
    if existing is not None and len(existing) and report["existing_overlap_pairs"]:
        # name the new modules by their ids in the merged skin (merge renumbers them)
        ids = np.unique(new.module_ids)
        first = int(existing.module_ids.max()) + 1
        report["existing_overlap_pairs"] = [[a, first + int(np.searchsorted(ids, b))]
                                            for a, b in report["existing_overlap_pairs"]]
    return _edit(merge(existing, new), report)


def remove_modules(layout: Layout, modules) -> LayoutEdit:
    """``layout`` without the taxels of ``modules`` (module ids)."""
    modules = np.unique(np.asarray(modules, dtype=np.int64).reshape(-1))
    if len(modules) == 0:
        raise InputError("select a taxel of the module to remove", key="modules")
    keep = ~np.isin(layout.module_ids, modules)
    if keep.all():
        raise InputError(f"no module {modules.tolist()} in this skin", key="modules")
    return _edit(layout.subset(keep), {})


def move_module(layout: Layout, module: int, vertices, triangles, at, direction=None,
                offset: float = 0.0) -> LayoutEdit:
    """Move one module of ``layout`` to ``at`` on the mesh (re-conformed there).

    Keeps the module's id and its taxel ids; the other modules are untouched.
    """
    from ...layout import place

    mask = layout.module_ids == int(module)
    if not mask.any():
        raise InputError(f"no module {module} in this skin", key="module")
    mesh = as_trimesh(vertices, triangles)
    mod_type = str(layout.meta.get("module", "cyskin10"))
    new, rep = place(mesh, "triangle", np.asarray(at, float).reshape(3), direction,
                     module=mod_type if mod_type in _module_names() else "cyskin10", offset=offset)
    old = layout.subset(mask)
    if len(new) != len(old):
        raise InputError(f"module {module} has {len(old)} taxels, a placed module {len(new)}", key="module")
    new.module_ids[:] = int(module)
    new.taxel_ids = old.taxel_ids.copy()
    new.can_ids = old.can_ids  # the same board, wired to the same bus
    # Flat coordinates are dropped: the module was unrolled about its new place, the rest
    # about the old anchor.
    moved = Layout.concat([layout.subset(~mask), new], renumber=False)
    moved.flat = None
    return _edit(moved, rep.as_dict())


def _module_names():
    from ...layout import MODULES

    return MODULES


def export_layout(layout: Layout, triangles, path, format: str | None = None, transform=None) -> Path:
    """Write ``layout`` (with its skin mesh faces) to ``path`` in a layout format.

    transform : optional (4, 4) rigid transform from the skin frame to the
    frame the file should use (another object's frame).
    """
    from ...layout import save

    tri = np.asarray(triangles, np.int64).reshape(-1, 3)
    out = layout.subset(slice(None))
    if len(tri):
        out.meta["faces"] = tri
    if len(out) == 0:
        raise InputError("the skin has no taxels", key="layout")
    path = Path(path)
    save(out, path, format, transform=transform)
    return path
