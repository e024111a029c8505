"""Skin layout edits for a front end: lay or fill a patch, remove or move modules, export."""

from __future__ import annotations

import warnings
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..._progress import keep_going
from ...errors import InputError, for_users
from ...layout import Layout, skin_mesh
from .common import as_trimesh
from .link import LinkExposure, fill_on_link


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
    coverage, notes) of the whole skin after the edit.
    warnings : lines the user must see (the front end shows them, not only a terminal).
    strain : (N,) per taxel, the largest |strain| of its module's edges (fraction).
    overlap : (N,) bool, taxels closer than OVERLAP_FRACTION pitch to another module's.
    kept : (N,) int, the index of each taxel in the skin before the edit (-1: new or moved, so
        results computed for the old skin, a simulated response, do not hold for it).
    exposure : a fill on a robot's link (``lay_patch(link=...)``): the link's exposed surface per
        face of the mesh filled, its legend and what the fill left out (:class:`.link.LinkExposure`);
        None otherwise.
    """

    layout: Layout
    triangles: np.ndarray
    report: dict
    warnings: list = field(default_factory=list)
    strain: np.ndarray = None
    overlap: np.ndarray = None
    kept: np.ndarray = None
    exposure: LinkExposure | None = None


def _module_of(layout: Layout, module=None):
    from ...layout import MODULES, get_module

    if module is not None:
        return get_module(module)
    name = str(layout.meta.get("module_type") or layout.meta.get("module") or "cyskin10")
    return get_module(name if name in MODULES else "cyskin10", mirror=bool(layout.meta.get("module_mirror")))


def _whole(layout: Layout, report: dict, kept, caught, module=None, n_before=None, extra=()) -> LayoutEdit:
    """The LayoutEdit of ``layout`` with the whole skin judged (:func:`vtcore.layout.report.skin_report`):
    overlaps between any modules, strain per taxel; notes and warnings kept."""
    from ...layout.report import skin_report

    whole, strain, overlap = skin_report(layout, _module_of(layout, module), report, n_before)
    rep = dict(report)
    if n_before is not None or "strain_max" not in rep:
        rep["strain_max"], rep["strain_mean"] = whole["strain_max"], whole["strain_mean"]
    else:  # a new patch on a skin: the worst edge anywhere; the mean stays the patch's own
        rep["strain_max"] = max(float(rep["strain_max"]), whole["strain_max"])
    for key in ("overlaps", "overlap_pairs"):
        rep[key] = whole[key]
    if n_before is not None:  # an edit of an existing skin: coverage scaled, pairs of the whole skin
        rep.update({k: whole[k] for k in ("overlaps_within", "overlaps_existing", "existing_overlap_pairs")})
        if "coverage" in whole:
            rep["coverage"] = whole["coverage"]
        else:
            rep.pop("coverage", None)
        rep["notes"] = list(whole["notes"])
    else:
        rep["overlaps"] = max(rep["overlaps"], int(report.get("overlaps") or 0))
    msgs = [str(w.message) for w in for_users(caught)] + list(extra)
    if rep["overlaps"]:
        msgs.append(f"{rep['overlaps']} pairs of modules overlap (taxels closer than 0.75 pitch): "
                    "colour by Overlap to see them")
    return LayoutEdit(layout, skin_triangles(layout), rep, list(dict.fromkeys(msgs)), strain, overlap,
                      np.asarray(kept, np.int64))


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
              fill_region=None, max_faces: int | None = 20_000, progress=None, radius: float | None = None,
              facing=None, within: float = 45.0, crease_angle: float = 40.0, max_strain: float | None = None,
              islands: str = "each", force: bool = False, link: dict | None = None) -> LayoutEdit:
    """Conform a patch (or fill a face region with modules) onto a mesh, added to ``existing``.

    vertices : (V, 3) metres and triangles : (F, 3) of the end-effector surface, in
    the skin frame. at : (3,) metres, the point the patch is centred on (snapped to
    the surface). patch : "hexagon", "triangle" or "strip:N"; module : module type.
    direction : (3,) in-plane x axis or None. offset : metres along the normal.
    fill_region : (F,) bool face mask: tile that region with whole modules instead (None with
        ``radius`` or ``facing``: fill every face, within the radius / cone).
    radius : metres, fill within this geodesic radius round ``at``. facing : (3,) and within :
        degrees, fill only faces whose normal is within that cone (:func:`vtcore.layout.regions.facing_region`).
    crease_angle : degrees, islands : see :func:`vtcore.layout.fill`.
    max_strain : fill leaves out modules straining more; a patch straining more is refused. None:
        the defaults (fill 0.05, a patch 0.10: ``vtcore.layout.report``).
    force : keep a patch or fill that :func:`vtcore.layout.report.check_trust` refuses (taxels off
        the surface, over-strained, ``at`` far off the surface); its reasons become warnings.
    link : the mesh is a robot's link in its frame: {"robot": file, "link": name, "geometry", "packages",
        "anywhere"} (:func:`.link.fill_on_link`). A fill then lays modules only on the link's exposed
        surface, as ``vtcore layout fill ROBOT --link NAME`` does, and the edit carries the exposure
        (``LayoutEdit.exposure``); a placed patch is laid as on any mesh.
    max_faces : the log map is solved on a copy simplified to about this many faces
        (vtcore.layout.place's speed/accuracy knob; None: the full mesh). A fill sizes its copy
        by the module pitch instead (``fill(max_faces="auto")``) unless this is None.
    progress : None or ``progress(fraction) -> bool`` (0..1); returning False stops a fill,
        which raises :class:`vtcore.errors.Cancelled` (nothing is returned or changed).
        It is told 0 when the fill starts, the fill's own fractions as its growth proceeds
        (after each chart, so a stop takes effect at the next one) and 1 when it ends.
    Returns the merged layout, its skin mesh, the placement report of the whole skin (overlaps
    with the modules already there), the warnings and per-taxel strain and overlap.
    Raises PlacementRefused (an InputError) when the placement is not to be trusted and not forced.
    """
    from ...layout import fill, place
    from ...layout.regions import facing_region
    from ...layout.report import DEFAULT_MAX_STRAIN, PLACE_MAX_STRAIN, check_trust

    mesh = as_trimesh(vertices, triangles)
    at = np.asarray(at, dtype=np.float64).reshape(3)
    filling = fill_region is not None or radius is not None or facing is not None
    limit = max_strain or (DEFAULT_MAX_STRAIN if filling else PLACE_MAX_STRAIN)
    shown = None
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        if filling:
            region = np.ones(len(mesh.faces), bool) if fill_region is None else \
                np.asarray(fill_region, dtype=bool).reshape(-1)
            if len(region) != len(mesh.faces) or not region.any():
                raise InputError("select at least one face of the end-effector to fill", key="region")
            if facing is not None:
                region &= facing_region(mesh, facing, within)
                if not region.any():
                    raise InputError(f"no selected face faces that way (within {within:g} deg)", key="facing")
            keep_going(progress, 0.0, "the fill")
            opts = dict(module=module, region=region, offset=offset, radius=radius, existing=existing,
                        max_faces=None if max_faces is None else "auto", progress=progress, max_strain=limit,
                        crease_angle=crease_angle, islands=islands)
            if link is not None:  # a robot's link: its exposed surface only
                new, rep, shown = fill_on_link(mesh, at, direction, link, **opts)
            else:
                new, rep = fill(mesh, at, direction, **opts)
            keep_going(progress, 1.0, "the fill")
        else:
            new, rep = place(mesh, patch, at, direction, module=module, offset=offset, method=method,
                             max_faces=max_faces, existing=existing)
        forced = check_trust(rep, max_strain=limit, force=force, what="fill" if filling else patch)
    if len(new) == 0:
        raise InputError("no module fits there", key="at")
    report = rep.as_dict()
    if existing is not None and len(existing) and report["existing_overlap_pairs"]:
        # name the new modules by their ids in the merged skin (merge renumbers them)
        ids = np.unique(new.module_ids)
        first = int(existing.module_ids.max()) + 1
        report["existing_overlap_pairs"] = [[a, first + int(np.searchsorted(ids, b))]
                                            for a, b in report["existing_overlap_pairs"]]
    n0 = 0 if existing is None else len(existing)
    kept = np.concatenate([np.arange(n0), np.full(len(new), -1)])
    merged = merge(existing, new)
    merged.meta.setdefault("module_type", new.meta.get("module_type"))
    merged.meta.setdefault("module_mirror", new.meta.get("module_mirror"))
    edit = _whole(merged, report, kept, caught, module=module,
                  extra=[f"kept though refused (forced): {p}" for p in forced])
    edit.exposure = shown
    return edit


def remove_modules(layout: Layout, modules, module=None) -> LayoutEdit:
    """``layout`` without the taxels of ``modules`` (module ids); the whole skin's report
    recomputed (``module``: the module type, else the layout's ``meta``)."""
    modules = np.unique(np.asarray(modules, dtype=np.int64).reshape(-1))
    if len(modules) == 0:
        raise InputError("select a taxel of the module to remove", key="modules")
    keep = ~np.isin(layout.module_ids, modules)
    if keep.all():
        raise InputError(f"no module {modules.tolist()} in this skin", key="modules")
    prev = dict(layout.meta.get("placement") or {})
    out = layout.subset(keep)
    return _whole(out, prev, np.flatnonzero(keep), [], module=module, n_before=layout.n_modules)


def move_module(layout: Layout, module: int, vertices, triangles, at, direction=None,
                offset: float = 0.0, *, module_type=None, force: bool = False,
                max_strain: float | None = None) -> LayoutEdit:
    """Move one module of ``layout`` to ``at`` on the mesh (re-conformed there).

    Keeps the module's id and its taxel ids; the other modules are untouched. The move is judged
    against the other modules (overlaps) and refused like a placed patch (taxels off the surface,
    strain over ``max_strain``, default 0.10, ``at`` far off the surface) unless ``force``; the
    whole skin's report is recomputed. module_type : the module type (default: the layout's meta).
    """
    from ...layout import place
    from ...layout.report import PLACE_MAX_STRAIN, check_trust

    mask = layout.module_ids == int(module)
    if not mask.any():
        raise InputError(f"no module {module} in this skin", key="module")
    mesh = as_trimesh(vertices, triangles)
    mod = _module_of(layout, module_type)
    rest = layout.subset(~mask)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        new, rep = place(mesh, "triangle", np.asarray(at, float).reshape(3), direction, module=mod, offset=offset,
                         existing=rest if len(rest) else None)
        forced = check_trust(rep, max_strain=max_strain or PLACE_MAX_STRAIN, force=force, what="move")
    old = layout.subset(mask)
    if len(new) != len(old):
        raise InputError(f"module {module} has {len(old)} taxels, a placed module {len(new)}", key="module")
    new.module_ids[:] = int(module)
    new.taxel_ids = old.taxel_ids.copy()
    new.can_ids = old.can_ids  # the same board, wired to the same bus
    # Flat coordinates are dropped: the module was unrolled about its new place, the rest
    # about the old anchor.
    moved = Layout.concat([rest, new], renumber=False)
    moved.flat = None
    moved.meta = dict(layout.meta)
    kept = np.concatenate([np.flatnonzero(~mask), np.full(len(new), -1)])
    prev = dict(layout.meta.get("placement") or {})
    return _whole(moved, prev, kept, caught, module=mod, n_before=layout.n_modules,
                  extra=[f"kept though refused (forced): {p}" for p in forced])


def export_layout(layout: Layout, triangles, path, format: str | None = None, transform=None,
                  frame: str | None = None) -> Path:
    """Write ``layout`` (with its skin mesh faces) to ``path`` in a layout format.

    transform : optional (4, 4) rigid pose of the layout's frame in the frame ``frame`` (another
    object's, a robot link): the taxels are written in that frame (positions ``R p + t``), which
    becomes the layout's frame (a URDF's parent link, a merged MJCF's body), with no transform left.
    """
    from ...layout import save

    tri = np.asarray(triangles, np.int64).reshape(-1, 3)
    out = layout.subset(slice(None))
    if transform is not None:
        out = out.posed(transform, frame or "parent").in_parent()
    if len(tri):
        out.meta["faces"] = tri
    if len(out) == 0:
        raise InputError("the skin has no taxels", key="layout")
    path = Path(path)
    save(out, path, format)
    return path
