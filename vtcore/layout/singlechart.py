"""The former fill of one log map (before chart growth), kept for the benchmark's comparison
(``vtcore bench layout``, rows ``fill_faces`` / ``fill_region``: growth against one chart)."""

from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

from ..errors import InputError
from .logmap import LogMap
from .model import Layout
from .patches import fill_patch
from .placement import place
from .repair import clean_mesh, source_faces
from .report import OVERLAP_FRACTION, PlacementReport, find_overlaps, find_overlaps_between, layout_strain, \
    points_in_outlines


def fill_one_chart(mesh, at, direction=None, *, module: str = "cyskin10", region=None, radius: float | None = None,
         offset: float = 0.0, max_strain: float = 0.05,
         max_faces: int | None = 20_000, existing: Layout | None = None,
         angles=tuple(np.radians(np.arange(0, 180, 30))), offsets: int = 2,
         refine_offsets: int = 4) -> tuple[Layout, PlacementReport]:
    """The fill of one log map at ``at`` (before chart growth; kept for the benchmark's comparison).

    region : (F,) bool face mask of ``mesh`` (default: every face). radius :
        metres, limit the fill to this geodesic radius around ``at`` (default:
        the whole region). Modules that would fall off the region, strain more
        than ``max_strain``, overlap a module nearer to ``at`` or overlap a module of
        ``existing`` (the skin already there, same frame) are left out.
    angles : radians, offsets : the module tiling is tried at each angle (a CySkin tiling only
        repeats every 180 degrees: its strips run one way) and ``offsets x offsets`` shifts within
        a tiling cell, then at the best angle with ``refine_offsets x refine_offsets`` shifts; the
        try whose kept modules cover most of the region wins (ties: the first); the report's notes
        name it, ``report.coverage`` is its coverage, ``layout.meta["fill_tilings"]`` lists every try.
    """
    from .modules import get_module

    mod = get_module(module)
    clean, notes = clean_mesh(mesh)
    if region is not None:
        region = np.asarray(region, dtype=bool)
        if len(region) != len(mesh.faces):
            raise InputError(f"region has {len(region)} entries, the mesh {len(mesh.faces)} faces", key="region")
        creg = region[source_faces(clean, mesh)]
    else:
        creg = np.ones(len(clean.faces), bool)
    lm = LogMap(clean, at, direction, radius=None if radius is None else radius + 2 * mod.radius,
                max_faces=max_faces, resolution=mod.pitch / 2)
    _, near = cKDTree(np.asarray(clean.triangles_center)).query(np.asarray(lm.mesh.triangles_center))
    lreg = creg[near]
    inside = _inside_region(lm, lreg, radius)
    coverage = _region_coverage(lm, lreg, radius)
    best, tried = _best_tiling(lm, inside, mod, radius, max_strain, existing, angles, offsets, refine_offsets)
    if best is None or not best[0].n_modules:
        raise InputError("no whole module fits in the region" + (" (beside the modules already there)"
                         if existing is not None and len(existing) else ""), key="region")
    p, _, n_out, n_existing, ang, shift = best
    cov = coverage(p)
    first = tried[0]
    first_cov = coverage(first[3]) if first[3] is not None and first[3].n_modules else 0.0
    p.kind = "fill"
    layout, report = place(clean, p, lm.at, direction, offset=offset, method="logmap", logmap=lm,
                           existing=existing)
    report.notes = notes + report.notes + [
        f"fill: {len(tried)} tilings tried ({len(angles)} angles x {offsets * offsets} shifts, then finer "
        f"shifts at the best angle); best at "
        f"{np.degrees(ang):.0f} deg, shift ({shift[0]:.2f}, {shift[1]:.2f}) cells: {p.n_modules} modules, "
        f"coverage {cov:.3f} (unrotated, unshifted: {first[2]} modules, coverage {first_cov:.3f}); {n_out} candidate "
        f"modules of it left out (strain > {max_strain} or overlap; {n_existing} of them overlap modules "
        "already on the skin)"]
    report.coverage = cov
    layout.meta["fill_tilings"] = [{"angle_deg": float(np.degrees(a)), "shift_cells": [float(x) for x in sh],
                                    "modules": int(n)} for a, sh, n, _ in tried]
    layout.meta["placement"] = report.as_dict()
    return layout, report


def _inside_region(lm: LogMap, lreg: np.ndarray, radius: float | None):
    """``inside(flat (n, 2)) -> (n,) bool``: which flat points of the log map ``lm`` land on the region
    (``lreg`` (F,) bool on ``lm.mesh``), within ``radius`` metres of its origin when given."""
    uv_lo, uv_hi = lm.uv[lm.reachable].min(axis=0), lm.uv[lm.reachable].max(axis=0)

    def inside(flat):
        # only points within the map's extent (and the radius) can be inside: skip exp for the rest
        ok = np.all((flat >= uv_lo) & (flat <= uv_hi), axis=1)
        if radius is not None:
            ok &= np.hypot(*flat.T) <= radius
        idx = np.flatnonzero(ok)
        if len(idx):
            _, _, face, found = lm.exp(flat[idx])
            ok[idx] = found & lreg[face]
        return ok

    return inside


def _region_coverage(lm: LogMap, lreg: np.ndarray, radius: float | None):
    """``coverage(patch) -> float``: the fraction of the region's area (``lreg`` (F,) bool on
    ``lm.mesh``, within ``radius`` metres) whose face centres lie in the patch's module outlines."""
    F = np.asarray(lm.mesh.faces)
    cent = lm.uv[F].mean(axis=1)
    sel = lreg & lm.reachable[F].all(axis=1) & (True if radius is None else (np.hypot(*cent.T) <= radius))
    area = lm.mesh.area_faces
    cand_cent, cand_area = cent[sel], area[sel]
    tot = float(cand_area.sum())

    def coverage(p):
        return float(cand_area[points_in_outlines(cand_cent, p)].sum() / tot) if tot > 0 else 0.0

    return coverage


def _kept_modules(lm: LogMap, p, mod, max_strain: float, existing: Layout | None):
    """``(kept patch, modules left out, of them overlapping existing)``: the modules of candidate tiling
    ``p`` kept after strain and overlap."""
    pos, nrm, _, _ = lm.exp(p.flat)
    strain = layout_strain(p.to_layout(pos, nrm), p.flat, p.module_edges)
    ms = np.zeros(p.n_modules)
    np.maximum.at(ms, p.module_ids[p.module_edges[:, 0]], np.abs(np.nan_to_num(strain, nan=1.0)))
    keep = ms <= max_strain
    # overlaps (past the cut locus the map folds back): keep the module nearer to 'at'
    dist_src = np.hypot(*p.poses[:, 1:].T)
    pairs = find_overlaps(pos, p.module_ids, OVERLAP_FRACTION * mod.pitch)
    for a, b in sorted(pairs, key=lambda ab: min(dist_src[ab[0]], dist_src[ab[1]])):
        if keep[a] and keep[b]:
            keep[b if dist_src[b] >= dist_src[a] else a] = False
    n_ex = 0
    if existing is not None and len(existing):
        clash = find_overlaps_between(existing, pos, p.module_ids, OVERLAP_FRACTION * mod.pitch)
        hit = np.unique(np.asarray([c[1] for c in clash], np.int64))
        n_ex = int(keep[hit].sum()) if len(hit) else 0
        keep[hit] = False
    return p.select_modules(keep), int((~keep).sum()), n_ex


def _best_tiling(lm: LogMap, inside, mod, radius, max_strain, existing, angles, offsets, refine_offsets):
    """``(best, tried)``: the tiling keeping most modules, as ``(kept patch, None, modules left out, of
    them overlapping existing, angle, shift)`` (None when no try has a candidate), and every try as
    ``(angle, shift, modules kept, kept patch or None)``."""
    span = np.abs(lm.uv).max(axis=0)
    lim = span if radius is None else np.minimum(span, radius)
    # the plane tiling is tried at several angles and shifts within a cell; the one keeping most
    # whole modules after strain and overlap filtering wins (ties: the first, angle 0 unshifted):
    # with whole, non-overlapping modules of one type that is the best coverage, and cheaper to
    # rank by than the covered area (computed for the winner and the plain tiling only).
    # One log map serves them all: each try is two vectorised exps. A coarse pass over the angles,
    # then finer shifts at the best one (a strip in a narrow band needs its offset to ~1/4 cell).
    best = None
    tried = []
    coarse = [(a, (fu / offsets, fv / offsets)) for a in angles for fu, fv in np.ndindex(offsets, offsets)]

    def fine():
        if best is None or refine_offsets <= offsets:
            return []
        return [(best[4], (fu / refine_offsets, fv / refine_offsets))
                for fu, fv in np.ndindex(refine_offsets, refine_offsets)
                if (fu / refine_offsets, fv / refine_offsets) not in
                {(u / offsets, v / offsets) for u, v in np.ndindex(offsets, offsets)}]

    for stage in (lambda: coarse, fine):
        for ang, shift in stage():
            cand = fill_patch(mod, inside, -lim, lim, angles=(ang,), offsets=1, shift=shift)
            if not cand.n_modules:
                tried.append((ang, shift, 0, None))
                continue
            kept, n_out, n_ex = _kept_modules(lm, cand, mod, max_strain, existing)
            tried.append((ang, shift, kept.n_modules, kept))
            if best is None or kept.n_modules > best[0].n_modules:
                best = (kept, None, n_out, n_ex, ang, shift)
    return best, tried


__all__ = ["fill_one_chart"]
