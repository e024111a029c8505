"""Place one flat patch on a mesh around a point: by the exponential map or by projection."""

from __future__ import annotations

import time
import warnings

import numpy as np

from ..errors import InputError
from ..geometry import barycentric
from .grow import grow, map_modules
from .logmap import LogMap
from .mesh import LayoutWarning
from .model import Layout
from .modules import TAXEL_DIAMETER
from .patches import Patch, make_patch
from .repair import boundary_faces, clean_mesh
from .report import (NORMAL_DEVIATION_DEG, OVERLAP_FRACTION, PlacementReport, coverage_of, find_overlaps, find_overlaps_between,
                     layout_strain, overlap_note)
from .surface import REST_LEAN_DEG, at_notes, closest_points, frame_at, rest_normals, snap, surface_normals

def _as_patch(patch, module) -> Patch:
    if isinstance(patch, Patch):
        return patch
    return make_patch(str(patch), module)


def place(mesh, patch="hexagon", at=(0.0, 0.0, 0.0), direction=None, *, module: str = "cyskin10",
          offset: float = 0.0, method: str = "logmap", region=None,
          logmap: "LogMap | None" = None, max_faces: int | None = 20_000,
          existing: Layout | None = None) -> tuple[Layout, PlacementReport]:
    """Conform ``patch`` to ``mesh`` around the surface point nearest ``at``.

    mesh : trimesh.Trimesh, metres (open, non-manifold or with degenerate faces is fine;
        it is cleaned first). patch : a :class:`Patch` or ``"triangle"``, ``"hexagon"``,
        ``"strip:N"`` (centred on ``at``). at : (3,) metres. direction : (3,) in-plane
        direction of the patch's x axis (default: world x projected). module : module type
        for named patches. offset : metres along the normal (e.g. a PCB's thickness).
    method : ``"logmap"`` or ``"project"``. region : optional (F,) bool face mask of
        ``mesh`` for the coverage figure (default: faces within the patch's radius).
    logmap : a :class:`LogMap` of this mesh at this point to reuse (several patches, one solve).
    max_faces : when the (cropped) mesh has more faces, solve the log map on a copy simplified
        to about this many faces by vertex clustering, then snap the taxels to the full mesh
        (None: always the full mesh). The benchmark shows what it costs in accuracy.
    existing : the skin already on this mesh (same frame). Modules of the new patch with
        taxels closer than ``OVERLAP_FRACTION`` pitch to its taxels are reported in
        ``report.existing_overlaps`` (and counted in ``as_dict()["overlaps"]``) with a warning;
        the new layout itself never contains the existing taxels (merge it yourself).

    Returns ``(layout, report)``; ``layout.meta["placement"]`` holds ``report.as_dict()``.
    """
    t0 = time.perf_counter()
    if method not in ("logmap", "project"):
        raise InputError(f"unknown method {method!r}; use logmap or project", key="method")
    p = _as_patch(patch, module)
    if len(p) == 0:
        raise InputError("the patch has no taxels", key="patch")
    at = np.asarray(at, dtype=np.float64).reshape(-1)
    if at.shape != (3,) or not np.isfinite(at).all():
        raise InputError(f"'at' must be 3 finite numbers, got {at.tolist()}", key="at")
    clean, notes = clean_mesh(mesh) if logmap is None else (mesh, [])
    charts = 1
    extent = float(np.hypot(*p.flat.T).max()) + p.module.pitch
    if method == "logmap":
        lm = logmap if logmap is not None else LogMap(clean, at, direction, radius=1.5 * extent + 2 * p.module.pitch,
                                                      max_faces=max_faces, resolution=p.module.pitch / 2)
        notes += lm.notes
        uvmap = lm
        surf_mesh = lm.surface
        if logmap is None and lm.trusted_radius() < extent:
            # the patch reaches past where one log map is trusted (round a closed link, past the
            # cut locus): map it chart by chart along one lattice (see grow.py)
            g = grow(lm.prepared, lm.at, direction, p, first=lm)
            charts = len(g.charts)
            pos, nrm, face, found = map_modules(g.charts, p, g.chart)
            uvmap = None if charts > 1 else lm
        else:
            pos, nrm, face, found = lm.exp(p.flat)
    else:
        cp, face0, dist0, spread = snap(clean, at)
        notes += at_notes(cp[0], float(dist0[0]), spread)
        tri = np.asarray(clean.vertices)[np.asarray(clean.faces)[face0]]
        normal = surface_normals(clean, face0, barycentric(tri, cp))[0]
        t1, t2 = frame_at(normal, direction)
        guess = cp[0] + p.flat[:, :1] * t1 + p.flat[:, 1:] * t2
        pos, face, _ = closest_points(clean, guess)
        tri = np.asarray(clean.vertices)[np.asarray(clean.faces)[face]]
        nrm = surface_normals(clean, face, barycentric(tri, pos))
        # off an open boundary: the closest point is on the boundary, far from the tangent-plane point
        boundary = boundary_faces(clean)
        found = ~(boundary[face] & (np.linalg.norm(pos - guess, axis=1) > 0.5 * p.module.pitch))
        surf_mesh = clean
        uvmap = None
    cov = coverage_of(clean, p, uvmap, region, extent)
    info = list(uvmap.info) if uvmap is not None else []
    return finish(p, pos, nrm, found, surf_mesh, method=method, notes=notes, info=info, offset=offset, at=at,
                  direction=direction, existing=existing, coverage=cov, t0=t0, charts=charts)


def finish(p: Patch, pos, nrm, found, surf_mesh, *, method, notes, info, offset, at, direction, existing,
           coverage, t0, charts=1, seam_modules=0, kind="place"):
    """The layout of patch ``p`` with taxels at ``pos`` (N, 3) on ``surf_mesh`` (normals ``nrm``,
    ``found`` (N,) bool), moved ``offset`` metres along the normals, and its report."""
    _, sface, dist = closest_points(surf_mesh, pos)
    # a normal smoothed across a coarse mesh's facets that leans from the face under it rests on the
    # faces under its footprint instead (surface.rest_normals)
    nrm = rest_normals(surf_mesh, pos, nrm, sface, TAXEL_DIAMETER / 2, REST_LEAN_DEG)
    # taxels whose normal is still more than a few degrees off the face they lie on (a taxel across a
    # coarse mesh's edge, or next to a crease): listed, never hidden
    fn = np.asarray(surf_mesh.face_normals)[sface] if len(pos) else np.zeros((0, 3))
    dev = np.degrees(np.arccos(np.clip(np.einsum("ij,ij->i", fn, nrm), -1.0, 1.0))) if len(pos) else np.zeros(0)
    pos = pos + offset * nrm
    meta = {"placement_method": method, "at": np.asarray(at, float).tolist(),
            "direction": None if direction is None else np.asarray(direction, float).tolist(),
            "offset_m": float(offset)}
    layout = p.to_layout(pos, nrm, meta)
    strain = layout_strain(layout.subset(slice(None)) if offset == 0 else _unoffset(layout, offset), p.flat,
                           p.module_edges)
    mstrain = np.zeros(p.n_modules)
    if len(strain):
        np.maximum.at(mstrain, p.module_ids[p.module_edges[:, 0]], np.abs(np.nan_to_num(strain)))
    overlaps = find_overlaps(layout.positions, layout.module_ids, OVERLAP_FRACTION * p.module.pitch)
    ex_overlaps = find_overlaps_between(existing, layout.positions, layout.module_ids,
                                        OVERLAP_FRACTION * p.module.pitch)
    if ex_overlaps:
        notes.append(overlap_note(ex_overlaps))
    off = np.flatnonzero(~found)
    if len(off):
        notes.append(f"{len(off)} taxels fall outside the mapped surface (off an open boundary, or past "
                     "the cut locus of a closed one where the log map is unreliable)")
    at_distance = float(snap(surf_mesh, at)[2][0])
    report = PlacementReport(strain, mstrain, overlaps, off, coverage, float(dist.max()) if len(dist) else 0.0,
                             method, time.perf_counter() - t0, notes + info, ex_overlaps, charts=int(charts),
                             seam_modules=int(seam_modules),
                             normal_outliers=np.flatnonzero(dev > NORMAL_DEVIATION_DEG),
                             normal_deviation_max=float(dev.max()) if len(dev) else 0.0,
                             at_distance=at_distance, n_taxels=len(layout), module_radius=p.module.radius)
    layout.meta["placement"] = report.as_dict()
    for msg in notes:
        warnings.warn(f"{kind}: {msg}", LayoutWarning, stacklevel=3)
    return layout, report


def _unoffset(layout: Layout, offset: float) -> Layout:
    out = layout.subset(slice(None))
    out.positions = layout.positions - offset * layout.normals
    return out
