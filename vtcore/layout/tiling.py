"""Tile a region of a mesh with whole modules, without overlap.

:func:`fill` grows one lattice chart by chart (:mod:`.grow`) over the region, keeps modules
whole, unstrained (``max_strain``), off open edges and sharp creases (``crease_angle``),
closes the seam where growth fronts meet, and fills every island of the region.
:func:`fill_one_chart` is the former fill of one log map, kept for the benchmark.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy.spatial import cKDTree

from ..errors import InputError
from ..geometry import closest_point_on_triangles
from .grow import Chart, close_seam, grow, map_modules, module_frames, module_strain, taxel_index
from .logmap import LogMap, PreparedSurface
from .model import Layout
from .patches import Patch, fill_patch, patch_from_poses, tile_poses
from .placement import finish, place
from .repair import clean_mesh, edge_keys, face_pairs, face_submesh, source_faces
from .surface import snap
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
    span = np.abs(lm.uv).max(axis=0)
    lim = span if radius is None else np.minimum(span, radius)

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

    F = np.asarray(lm.mesh.faces)
    cent = lm.uv[F].mean(axis=1)
    sel = lreg & lm.reachable[F].all(axis=1) & (True if radius is None else (np.hypot(*cent.T) <= radius))
    area = lm.mesh.area_faces
    cand_cent, cand_area = cent[sel], area[sel]
    tot = float(cand_area.sum())

    def evaluate(p):
        """The modules of candidate tiling ``p`` kept after strain and overlap, and the coverage."""
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

    def coverage(p):
        return float(cand_area[points_in_outlines(cand_cent, p)].sum() / tot) if tot > 0 else 0.0

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
            kept, n_out, n_ex = evaluate(cand)
            tried.append((ang, shift, kept.n_modules, kept))
            if best is None or kept.n_modules > best[0].n_modules:
                best = (kept, None, n_out, n_ex, ang, shift)
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


MAX_CANDIDATES = 2_000_000  #: lattice modules a fill may consider (each ~10 taxels): ~1 GB of work arrays
SEAM_SHIFTS = ((0.5, 0.0), (0.0, 0.5), (0.5, 0.5), (0.25, 0.0), (0.75, 0.0), (0.25, 0.5), (0.75, 0.5))


def fill(mesh, at, direction=None, *, module: str = "cyskin10", region=None, radius: float | None = None,
         offset: float = 0.0, max_strain: float = 0.05, max_faces: int | str | None = "auto",
         existing: Layout | None = None, angles=tuple(np.radians(np.arange(0, 180, 30))), offsets: int = 2,
         refine_offsets: int = 4, crease_angle: float = 40.0, seam: bool = True,
         progress=None) -> tuple[Layout, PlacementReport]:
    """Tile a region of ``mesh`` with whole modules on one lattice grown chart by chart.

    mesh : trimesh.Trimesh, metres. at : (3,) metres, where growth starts. direction : (3,) the
        lattice x axis at ``at`` (default world x projected).
    region : (F,) bool face mask of ``mesh`` (default: every face). Every island (connected part)
        of the region is filled: the one holding ``at`` from ``at``, the others from their most
        central point. radius : metres, limit to this geodesic radius around ``at``.
    max_faces : solve the log maps on a copy of the (cropped) mesh simplified to about this many
        faces when it has more (taxels still land on the full mesh); ``"auto"``: the faces of
        triangles with edges of about 0.75 module pitch over the region, 4,000 to 20,000
        (:func:`solve_faces`); None: never simplify.
    max_strain : modules straining more are left out. crease_angle : degrees; no module covers an
        edge sharper than this, nor an open edge of the mesh or of the region.
    angles, offsets, refine_offsets : the lattice is tried at each angle and ``offsets x offsets``
        shifts in the first chart, then at the best angle with ``refine_offsets x refine_offsets``
        shifts; the one keeping most modules there is grown (ties: the first);
        ``layout.meta["fill_tilings"]`` lists every try (a try is evaluated from the rim inwards
        and stopped once it cannot beat the best so far: its ``"exact"`` is then False and its
        ``"modules"`` the upper bound it reached).
    existing : the skin already there (same frame); no module overlaps it.
    seam : run the seam pass (lattice shifts where growth fronts meet).
    progress : None or ``progress(fraction) -> bool`` (0..1) called as growth proceeds; False
        stops the fill (``vtcore.errors.Cancelled``), nothing is returned.

    Returns ``(layout, report)``; the report carries ``charts`` and ``seam_modules``; its notes
    say which tiling won and what was left out.
    """
    import time

    from .modules import get_module

    t0 = time.perf_counter()
    mod = get_module(module)
    at = np.asarray(at, dtype=np.float64).reshape(-1)
    if at.shape != (3,) or not np.isfinite(at).all():
        raise InputError(f"'at' must be 3 finite numbers, got {at.tolist()}", key="at")
    clean, notes = clean_mesh(mesh)
    if region is not None:
        region = np.asarray(region, dtype=bool).reshape(-1)
        if len(region) != len(mesh.faces):
            raise InputError(f"region has {len(region)} entries, the mesh {len(mesh.faces)} faces", key="region")
        if not region.any():
            raise InputError("the region selects no face", key="region")
        creg = region[source_faces(clean, mesh)]
    else:
        creg = np.ones(len(clean.faces), bool)
    if radius is not None:
        cp, f0, _, _ = snap(clean, at)
        creg &= crop_mask(clean, cp[0], int(f0[0]), float(radius) + 2 * mod.radius)
    if not creg.any():
        raise InputError("the region selects no face within the radius", key="region")
    islands = face_islands(clean, creg)
    # the island nearest 'at' grows from 'at'; the others from their own most central point
    first = int(np.argmin([np.linalg.norm(clean.triangles_center[f] - at, axis=1).min() for f in islands]))
    islands.insert(0, islands.pop(first))
    # the log map is solved on the region and the surface round it, not on the region alone: a
    # narrow band gives the heat method no room (14 mm of error 20 mm along a 26 mm band); a wider
    # margin gives geodesics shortcuts off the region (across the cap of a cylinder whose side is
    # filled), which shrink the charts
    cen = np.asarray(clean.triangles_center)
    dist = np.zeros(len(cen))  # the region's own faces are at 0: only the others are searched
    dist[~creg] = cKDTree(cen[creg]).query(cen[~creg], distance_upper_bound=2 * mod.pitch)[0]
    sub = face_submesh(clean, np.flatnonzero(np.isfinite(dist)))
    if isinstance(max_faces, str):
        if max_faces != "auto":
            raise InputError(f"max_faces must be a number, None or 'auto', got {max_faces!r}", key="max_faces")
        max_faces = solve_faces(float(sub.area), mod.pitch)
    prepared = PreparedSurface(sub, resolution=mod.pitch, max_faces=max_faces)
    cen_tree = cKDTree(cen)  # also maps the surface's faces for the coverage below
    _, near = cen_tree.query(np.asarray(prepared.mesh.triangles_center))
    preg = creg[near]  # the region on the faces the log maps are solved on
    samples = feature_samples(prepared.mesh, crease_angle, preg)
    reports = []
    avoid = None if existing is None or not len(existing) else np.asarray(existing.positions, float)
    for k, faces in enumerate(islands):
        start = at if k == 0 else central_point(clean.submesh([faces], append=True, repair=False))
        reports.append(_fill_island(prepared, preg, samples, start, direction if k == 0 else None, mod,
                                    radius if k == 0 else None, max_strain, avoid, angles, offsets,
                                    refine_offsets, crease_angle, seam, progress, island=k, n_faces=len(faces)))
        if reports[-1].n_modules:  # later islands keep clear of this one's modules
            prev = reports[-1].pos
            avoid = prev if avoid is None else np.concatenate([avoid, prev])
    if not any(r.n_modules for r in reports):
        raise InputError("no whole module fits in the region: " + "; ".join(r.why for r in reports), key="region")
    chosen = [r for r in reports if r.n_modules]
    # the islands' own patches side by side (re-building one from all poses would drop taxels that
    # coincide in the flat domain across islands, whose flat frames differ, and leave pos longer)
    first = np.cumsum([0] + [r.patch.n_modules for r in chosen[:-1]])
    p = Patch(mod, np.concatenate([r.patch.poses for r in chosen]), np.concatenate([r.patch.flat for r in chosen]),
              np.concatenate([r.patch.module_ids + f for r, f in zip(chosen, first)]),
              np.concatenate([r.patch.sensors for r in chosen]), np.concatenate([r.patch.roles for r in chosen]),
              "fill")
    pos = np.concatenate([r.pos for r in chosen])
    nrm = np.concatenate([r.nrm for r in chosen])
    found = np.concatenate([r.found for r in chosen])
    surf = prepared.surface
    # coverage: the region's area (on the subdivided surface) under some module's outline
    sc = np.asarray(surf.triangles_center)
    _, near = cen_tree.query(sc, workers=-1)
    sel = creg[near]
    if radius is not None:  # the disc of the radius (geodesic; measured in 3-D, a little wider)
        sel &= np.linalg.norm(sc - reports[0].start, axis=1) <= radius
    frames = np.concatenate([r.frames for r in chosen])
    cov_den = float(np.asarray(surf.area_faces)[sel].sum())
    cov = coverage_by_frames(sc[sel], np.asarray(surf.area_faces)[sel], frames, p.poses[:, 0], mod) / cov_den \
        if cov_den > 0 else float("nan")
    notes = notes + [n for r in reports for n in r.notes]
    if len(islands) > 1:
        notes.append(f"the region has {len(islands)} islands (" + ", ".join(
            f"#{i}: {len(f)} faces, {r.patch.n_modules if r.n_modules else 0} modules" for i, (f, r) in
            enumerate(zip(islands, reports))) + "); each was filled from its own start")
    layout, report = finish(p, pos, nrm, found, surf, method="logmap", notes=notes,
                            info=[n for r in reports for n in r.info], offset=offset, at=at,
                            direction=direction, existing=existing, coverage=cov, t0=t0,
                            charts=sum(r.charts for r in reports), seam_modules=sum(r.seam for r in reports),
                            kind="fill")
    layout.meta["fill_tilings"] = [t for r in reports for t in r.tilings]
    # which chart placed each module (numbered across islands) and which the seam pass added
    layout.meta["module_charts"] = np.concatenate(
        [r.chart_of + sum(q.charts for q in chosen[:i]) for i, r in enumerate(chosen)]).tolist()
    layout.meta["seam_module_ids"] = np.flatnonzero(np.concatenate([r.is_seam for r in chosen])).tolist()
    layout.meta["placement"] = report.as_dict()
    return layout, report


@dataclass
class IslandFill:
    """The fill of one island of the region (internal result of :func:`fill`)."""

    patch: Patch
    pos: np.ndarray
    nrm: np.ndarray
    found: np.ndarray
    surface: object
    covered: float
    region_area: float
    notes: list
    charts: int
    seam: int
    tilings: list
    why: str = ""
    info: list = field(default_factory=list)
    frames: np.ndarray = None
    start: np.ndarray = None
    chart_of: np.ndarray = None
    is_seam: np.ndarray = None

    @property
    def n_modules(self) -> int:
        return self.patch.n_modules


def solve_faces(area: float, pitch: float) -> int:
    """Faces for the mesh a fill's log maps are solved on: triangles with edges of about 0.75
    ``pitch`` (metres) over ``area`` (square metres), between 4,000 and 20,000.

    The log map's cost is its first factorization, which grows faster than the face count (0.7 s
    at 10k faces, 1.7 s at 20k, 16 s at 100k on this machine's 2 cores), while its accuracy for
    placing modules needs only a few triangles per module: on the 72 x 200 mm link, 4k, 8k and
    20k faces place the same modules (benchmarked in docs/layout.md).
    """
    equilateral = np.sqrt(3) / 4 * (0.75 * pitch) ** 2
    return int(np.clip(area / max(equilateral, 1e-300), 4_000, 20_000))


def crop_mask(mesh, point: np.ndarray, face: int, radius: float) -> np.ndarray:
    """(F,) bool: faces of ``mesh`` with a point within ``radius`` metres of ``point`` (3,)."""
    tri = np.asarray(mesh.triangles)
    near = closest_point_on_triangles(tri, np.broadcast_to(point, (len(tri), 3)).copy())
    keep = np.linalg.norm(near - point, axis=1) <= radius
    keep[face] = True
    return keep


def face_islands(mesh, mask: np.ndarray) -> list:
    """Connected parts (by shared edges) of the faces where ``mask`` (F,) is true, largest first."""
    import trimesh

    idx = np.flatnonzero(mask)
    adj = face_pairs(mesh)
    both = mask[adj].all(axis=1) if len(adj) else np.zeros(0, bool)
    comps = trimesh.graph.connected_components(adj[both], nodes=idx, min_len=1)
    return sorted((np.sort(np.asarray(c, np.int64)) for c in comps), key=lambda c: -len(c))


def central_point(mesh) -> np.ndarray:
    """A start for an island: the face centre nearest the island's area-weighted centre (3,)."""
    c = np.asarray(mesh.triangles_center)
    w = np.asarray(mesh.area_faces)
    g = (c * w[:, None]).sum(axis=0) / max(w.sum(), 1e-300)
    return c[int(np.argmin(np.linalg.norm(c - g, axis=1)))]


def _concat_meshes(meshes):
    import trimesh

    return trimesh.util.concatenate(meshes)


def feature_samples(mesh, crease_angle: float, region: np.ndarray | None = None):
    """Points on the edges no module's taxels may straddle: open edges, edges sharper than
    ``crease_angle`` degrees and the border of ``region`` (F,) bool. Returns ``(pairs (K, 2)
    vertex indices, w (K,) position along the edge, n_open, n_sharp)``; five points per edge (the
    edges are at most about a pitch long after the log map's subdivision)."""
    f = np.asarray(mesh.faces)
    nv = len(mesh.vertices)
    key, cnt = np.unique(edge_keys(f, n=nv), return_counts=True)
    open_e = np.column_stack([key[cnt == 1] // nv, key[cnt == 1] % nv])
    ang = np.asarray(mesh.face_adjacency_angles)
    adj = np.asarray(mesh.face_adjacency)
    ae = np.asarray(mesh.face_adjacency_edges, np.int64).reshape(-1, 2)
    sharp = ae[ang > np.radians(crease_angle)] if len(ang) else np.zeros((0, 2), np.int64)
    border = ae[region[adj[:, 0]] != region[adj[:, 1]]] if region is not None and len(adj) else np.zeros((0, 2), np.int64)
    ed = np.concatenate([open_e, sharp, border])
    w = np.array([0.1, 0.3, 0.5, 0.7, 0.9])
    return np.repeat(ed, len(w), axis=0), np.tile(w, len(ed)), len(open_e), len(sharp)


def taxel_hull(mod) -> np.ndarray:
    """(h, 2) metres, counter-clockwise: the convex hull of a module's taxel centres (the part of
    the board that must lie on one smooth piece of surface; the margin round it may overhang)."""
    from scipy.spatial import ConvexHull

    return mod.taxels[ConvexHull(mod.taxels).vertices]


def modules_covering(points: np.ndarray, patch: Patch, modules: np.ndarray, origin: np.ndarray) -> np.ndarray:
    """(len(modules),) bool: which of ``modules`` of ``patch`` hold one of the flat ``points``
    (n, 2) inside the hull of their taxels; points in the frame of a chart whose origin is
    ``origin`` (2,) in the patch's frame."""
    out = np.zeros(len(modules), bool)
    if not len(points) or not len(modules):
        return out
    mod = patch.module
    cen = patch.poses[modules, 1:] - origin
    hits = cKDTree(points).query_ball_point(cen, float(np.linalg.norm(mod.taxels, axis=1).max()))
    rows = np.repeat(np.arange(len(modules)), [len(h) for h in hits])
    if not len(rows):
        return out
    pts = points[np.concatenate([np.asarray(h, np.int64) for h in hits if len(h)])]
    ang = patch.poses[modules, 0][rows]
    c, s = np.cos(ang), np.sin(ang)
    rel = pts - cen[rows]
    local = np.column_stack([c * rel[:, 0] + s * rel[:, 1], -s * rel[:, 0] + c * rel[:, 1]])  # R(-ang) rel
    poly = taxel_hull(mod)
    edge = np.roll(poly, -1, axis=0) - poly
    r = local[:, None, :] - poly[None]
    cr = edge[None, :, 0] * r[..., 1] - edge[None, :, 1] * r[..., 0]
    ins = np.all(cr >= 0, axis=1)
    out[np.unique(rows[ins])] = True
    return out


def coverage_by_frames(centres: np.ndarray, areas: np.ndarray, frames: np.ndarray, angles: np.ndarray,
                       mod) -> float:
    """Area of the faces (centres (F, 3), areas (F,)) under some module outline, each module
    given by its frame (M, 3, 3: origin, lattice x axis, normal) and its angle (M,) to the
    lattice x axis; a face centre is projected on a module's tangent plane (a module is small
    against the curvature it sits on)."""
    if not len(frames) or not len(centres):
        return 0.0
    o, x, n = frames[:, 0], frames[:, 1], frames[:, 2]
    y = np.cross(n, x)
    # the k nearest module origins within a module radius, as arrays (query_ball_point's lists of
    # lists cost seconds on 100k face centres); modules do not overlap, so a handful are near a
    # point: k doubles until the farthest answer is past the radius
    tree, k = cKDTree(o), min(8, len(o))
    while True:
        d, ms = tree.query(centres, k=k, distance_upper_bound=mod.radius, workers=-1)  # same answer, both cores
        d, ms = d.reshape(len(centres), -1), ms.reshape(len(centres), -1)
        if k >= len(o) or not np.isfinite(d[:, -1]).any():
            break
        k = min(2 * k, len(o))
    hit = np.isfinite(d)
    rows = np.nonzero(hit)[0]
    if not len(rows):
        return 0.0
    ms = ms[hit]
    rel = centres[rows] - o[ms]
    # within a module radius along the normal too: not the other side of a thin part
    near = np.abs(np.einsum("ij,ij->i", rel, n[ms])) < 0.5 * mod.radius
    u, v = np.einsum("ij,ij->i", rel, x[ms]), np.einsum("ij,ij->i", rel, y[ms])
    c, s = np.cos(angles[ms]), np.sin(angles[ms])
    local = np.column_stack([c * u + s * v, -s * u + c * v])
    poly = mod.outline
    edge = np.roll(poly, -1, axis=0) - poly
    r = local[:, None, :] - poly[None]
    cr = edge[None, :, 0] * r[..., 1] - edge[None, :, 1] * r[..., 0]
    ins = np.all(cr >= 0, axis=1) & near
    covered = np.zeros(len(centres), bool)
    covered[rows[ins]] = True
    return float(areas[covered].sum())


def lattice_patch(mod, angle: float, shift, centre, rad: float, limit: float | None = None) -> Patch:
    """The fill lattice's modules (a Patch in the lattice's flat frame) with origins within
    ``rad`` metres of ``centre`` (2,): the module type's plane tiling turned by ``angle`` and
    shifted by ``shift`` (2,) fractions of a tiling cell; ``limit``: only modules whose taxels are
    all within this distance of the lattice origin. Raises InputError, naming the size, before building
    more than MAX_CANDIDATES modules."""
    cell = abs(float(np.linalg.det(np.column_stack([mod.strip_period, mod.fill_row]))))
    est = (2 * rad + 4 * mod.radius) ** 2 / max(cell, 1e-300) * len(mod.strip)
    if est > MAX_CANDIDATES:
        raise InputError(f"the fill would consider about {est:.3g} module positions (a region "
                         f"{2e3 * rad:.0f} mm across, {1e3 * mod.pitch:.1f} mm pitch), more than the "
                         f"{MAX_CANDIDATES} this machine is sized for; give a radius or a smaller region",
                         key="region")
    c, s = np.cos(angle), np.sin(angle)
    rot = np.array([[c, -s], [s, c]])
    centre = np.asarray(centre, float)
    cu = rot.T @ centre
    d = shift[0] * mod.strip_period + shift[1] * mod.fill_row
    poses = tile_poses(mod, cu - d - rad, cu - d + rad)
    poses[:, 1:] = (poses[:, 1:] + d) @ rot.T
    poses[:, 0] += angle
    keep = np.linalg.norm(poses[:, 1:] - centre, axis=1) <= rad
    if limit is not None:  # a superset first (any orientation), then taxel by taxel
        keep &= np.linalg.norm(poses[:, 1:], axis=1) - np.linalg.norm(mod.taxels, axis=1).max() <= limit
    p = patch_from_poses(mod, poses[keep], "fill")
    if limit is not None and p.n_modules:
        # every taxel within the limit: a module at the rim whose far taxels point along it fits
        far = np.zeros(p.n_modules)
        np.maximum.at(far, p.module_ids, np.linalg.norm(p.flat, axis=1))
        p = p.select_modules(far <= limit)
    return p


def _fill_island(prepared, preg, samples, start, direction, mod, radius, max_strain, avoid, angles,
                 offsets, refine_offsets, crease_angle, seam, progress, island=0, n_faces=0) -> IslandFill:
    notes = list(prepared.notes) if island == 0 else []
    lm0 = LogMap(None, start, direction, prepared=prepared)
    tag = f"island #{island}: " if island else ""
    R0 = lm0.trusted_radius(faces=preg)
    pairs, w, n_open, n_sharp = samples

    def check(chart, patch, modules, tfaces, tmod):
        """Taxels on region faces; no open, sharp or region-border edge under a module's taxels."""
        on_region = np.bincount(tmod, weights=~preg[tfaces], minlength=len(modules)) == 0
        lm = chart.logmap
        i, j = pairs[:, 0], pairs[:, 1]
        cons = lm.consistent()
        ok = lm.reachable[i] & lm.reachable[j] & cons[i] & cons[j]
        uv = (1 - w[ok, None]) * lm.uv[i[ok]] + w[ok, None] * lm.uv[j[ok]]
        uv = uv[np.linalg.norm(uv, axis=1) <= chart.radius + mod.radius]
        return on_region & ~modules_covering(uv, patch, modules, chart.origin)

    reach_uv = float(np.linalg.norm(lm0.uv[lm0.reachable], axis=1).max()) if lm0.reachable.any() else 0.0
    # one lattice for the whole island: a disc larger than the farthest point (geodesic distance),
    # with room for curvature (charts on a non-developable surface use more lattice per area)
    extent = 1.5 * reach_uv + 2 * mod.radius
    if radius is not None:
        extent = min(extent, float(radius) + mod.radius)
    # the tiling (angle, shift) that keeps most modules in the first chart wins (ties: the first)
    tilings, best = [], None
    r_try = min(R0, extent)
    coarse = [(a, (fu / offsets, fv / offsets)) for a in angles for fu, fv in np.ndindex(offsets, offsets)]

    def fine():
        done = {(u / offsets, v / offsets) for u, v in np.ndindex(offsets, offsets)}
        return [(best[1], (fu / refine_offsets, fv / refine_offsets))
                for fu, fv in np.ndindex(refine_offsets, refine_offsets)
                if (fu / refine_offsets, fv / refine_offsets) not in done] if refine_offsets > offsets else []

    def first_chart(ang, sh, beat) -> tuple[int, bool]:
        """Modules of the lattice (angle, shift) the first chart keeps, and whether that count is
        exact. The modules are tried from the rim inwards, in chunks: the rim is where the map
        strains and the region ends, so the rejections come first, and a try stops as soon as it
        cannot keep more than ``beat`` modules (the best so far; ties go to the earlier try, so a
        stopped try could not have won) and returns that upper bound."""
        cand = lattice_patch(mod, ang, sh, np.zeros(2), r_try, radius)
        d = np.linalg.norm(cand.poses[:, 1:], axis=1)
        cand = cand.select_modules(d + reach <= r_try)
        M = cand.n_modules
        if not M:
            return 0, True
        d = np.linalg.norm(cand.poses[:, 1:], axis=1)
        counts = np.bincount(cand.module_ids, minlength=M)
        starts = np.concatenate([[0], np.cumsum(counts)[:-1]]).astype(np.int64)
        pos, nrm = np.full((len(cand), 3), np.nan), np.full((len(cand), 3), np.nan)
        chart = Chart(np.zeros(2), lm0.at, lm0.t1, lm0, r_try)
        order = np.argsort(-d, kind="stable")
        kept, done = 0, 0
        for mods in np.split(order, [M // 4, M // 2]):  # the outer quarter, the next, the inner half
            if not len(mods):
                continue
            ti = taxel_index(counts, starts, mods)
            p_, n_, f_, ok_ = lm0.exp(cand.flat[ti], fallback=False, on_surface=False)
            pos[ti], nrm[ti] = p_, n_
            tm = np.repeat(np.arange(len(mods)), counts[mods])
            keep = np.bincount(tm, weights=ok_, minlength=len(mods)) == counts[mods]
            keep &= module_strain(cand, pos, nrm, mods) <= max_strain
            keep &= check(chart, cand, mods, f_, tm)
            if avoid is not None and keep.any():
                hit = cKDTree(avoid).query_ball_point(p_, OVERLAP_FRACTION * mod.pitch, return_length=True) > 0
                keep &= np.bincount(tm, weights=hit, minlength=len(mods)) == 0
            kept, done = kept + int(keep.sum()), done + len(mods)
            if beat is not None and kept + (M - done) <= beat and done < M:
                return kept + (M - done), False
        return kept, True

    reach = float(np.linalg.norm(mod.taxels, axis=1).max()) + 0.5 * mod.pitch
    for stage in (lambda: coarse, fine):
        for ang, sh in stage():
            n, exact = first_chart(ang, sh, None if best is None else best[0])
            tilings.append({"angle_deg": float(np.degrees(ang)), "shift_cells": [float(sh[0]), float(sh[1])],
                            "modules": n, "exact": exact, "island": island})
            if best is None or n > best[0]:
                best = (n, ang, sh)
    _, ang, sh = best
    latt = lattice_patch(mod, ang, sh, np.zeros(2), extent, radius)
    g = grow(prepared, lm0.at, direction, latt, check=check, max_strain=max_strain, first=lm0, avoid=avoid,
             progress=progress, faces=preg, min_gain=2)
    kept = np.flatnonzero(g.kept)
    poses, chart_of = latt.poses[kept], g.chart[kept]
    n_seam = 0
    if seam and len(kept):
        sp, sc = close_seam(g, lambda s2, c, r: lattice_patch(mod, ang, (sh[0] + s2[0], sh[1] + s2[1]), c, r, radius),
                            check, max_strain, SEAM_SHIFTS, avoid=avoid)
        n_seam = len(sp)
        poses, chart_of = np.concatenate([poses, sp]), np.concatenate([chart_of, sc])
    p = patch_from_poses(mod, poses, "fill")
    if not p.n_modules:
        why = (f"{tag}{n_faces} faces; {g.reasons_text()}; {n_open} open and {n_sharp} sharp "
               f"(> {crease_angle:g} deg) edges; module radius {1e3 * mod.radius:.1f} mm")
        if g.reasons.get("off", 0) and n_faces < 1000:
            why += "; the mesh may be too coarse for the log map: subdivide it (--subdivide) and retry"
        return IslandFill(p, np.zeros((0, 3)), np.zeros((0, 3)), np.zeros(0, bool), None, 0.0, 0.0, notes,
                          len(g.charts), 0, tilings, why, frames=np.zeros((0, 3, 3)))
    pos, nrm, face, found = map_modules(g.charts, p, chart_of)
    frames = module_frames(g.charts, p, chart_of)
    if g.reasons.get("existing"):
        notes.append(f"{tag}{g.reasons['existing']} candidate modules left out: they would overlap modules "
                     "already on the skin")
    info = [f"{tag}fill: {len(tilings)} tilings tried in the first chart ({len(angles)} angles x "
                 f"{offsets * offsets} shifts, then finer shifts at the best angle); best at "
                 f"{np.degrees(ang):.0f} deg, shift ({sh[0]:.2f}, {sh[1]:.2f}) cells ({best[0]} modules there, "
                 f"the first try {tilings[0]['modules']}); grown through {len(g.charts)} chart(s): "
                 f"{len(kept)} modules, {n_seam} more closing the seam; left out: {g.reasons_text()}"]
    return IslandFill(p, pos, nrm, found, None, 0.0, 0.0, notes, len(g.charts), n_seam,
                      tilings, info=(prepared.info if island == 0 else []) + info, frames=frames, start=lm0.at,
                      chart_of=chart_of, is_seam=np.arange(p.n_modules) >= len(kept))
