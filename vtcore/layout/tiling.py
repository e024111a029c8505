"""Tile a region of a mesh with whole modules, without overlap.

:func:`fill` grows one lattice chart by chart (:mod:`.grow`) over the region, keeps modules
whole, unstrained (``max_strain``), off open edges and sharp creases (``crease_angle``),
closes the seam where growth fronts meet, and fills every island of the region (:mod:`.islands`:
which, from where, further seeds, the error when nothing fits). The former fill of one log map,
kept for the benchmark, is :func:`vtcore.layout.singlechart.fill_one_chart`.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import partial

import numpy as np
from scipy.spatial import cKDTree

from ..errors import InputError
from .grow import Chart, close_seam, grow, map_modules, module_frames, module_strain, taxel_index
from .islands import island_groups, islands_note, next_seed, no_module_fits
from .logmap import LogMap, PreparedSurface
from .model import Layout
from .lattice import centred_shift, lattice_patch, modules_covering
from .patches import Patch, patch_from_poses
from .placement import finish
from .regions import crop_mask, face_islands
from .repair import clean_mesh, edge_keys, face_submesh, source_faces
from .surface import at_notes, closest_points, faces_at, snap
from .report import OVERLAP_FRACTION, PlacementReport, coverage_by_frames

CREASE_ANGLE = 40.0  #: degrees: no module covers an edge where the faces turn more than this (a design crease)
#: why the fill's candidate modules were left out (``layout.meta["fill_left_out"]``: counts over every
#: island and seed): off the surface, on a sharp/open/region edge, strained, overlapping, over the skin there
LEFT_OUT = ("off", "rules", "strain", "overlap", "existing")
SEAM_SHIFTS = ((0.5, 0.0), (0.0, 0.5), (0.5, 0.5), (0.25, 0.0), (0.75, 0.0), (0.25, 0.5), (0.75, 0.5))


def fill(mesh, at, direction=None, *, module: str = "cyskin10", region=None, radius: float | None = None,
         offset: float = 0.0, max_strain: float = 0.05, max_faces: int | str | None = "auto",
         existing: Layout | None = None, angles=tuple(np.radians(np.arange(0, 180, 30))), offsets: int = 2,
         refine_offsets: int = 4, crease_angle: float = CREASE_ANGLE, seam: bool = True, islands: str = "each",
         seeds: int = 8, progress=None) -> tuple[Layout, PlacementReport]:
    """Tile a region of ``mesh`` with whole modules on one lattice grown chart by chart.

    mesh : trimesh.Trimesh, metres. at : (3,) metres, where growth starts. direction : (3,) the
        lattice x axis at ``at`` (default world x projected).
    region : (F,) bool face mask of ``mesh`` (default: every face; see :mod:`.regions` for
        selections by normal cone or face-index file). radius : metres, limit to this geodesic
        radius around ``at``.
    islands : ``"each"`` (default): every island (connected part) of the region gets its own
        lattice, the one nearest ``at`` grown from ``at``, the others from their most central
        point; ``"one"``: islands within two pitches of each other (across unselected faces)
        share one lattice, grown from one start, so the modules line up across the gaps. Islands
        smaller than a module (by area, or narrower than it between their edges) are left out
        and named in the notes.
    max_faces : solve the log maps on a copy of the (cropped) mesh simplified to about this many
        faces when it has more (taxels still land on the full mesh); ``"auto"``: the faces of
        triangles with edges of about 0.75 module pitch over the region, 4,000 to 20,000
        (:func:`solve_faces`); None: never simplify.
    max_strain : modules straining more are left out (0.05: 5 % stretch of a module edge, more
        than a flexible PCB takes). crease_angle : degrees (default :data:`CREASE_ANGLE`); no module
        covers an edge sharper than this, nor an open edge of the mesh or of the region.
    angles, offsets, refine_offsets : the lattice is tried at each angle and ``offsets x offsets``
        shifts in the first chart, then at the best angle with ``refine_offsets x refine_offsets``
        shifts; the one keeping most modules there is grown (ties: the first);
        ``layout.meta["fill_tilings"]`` lists every try (a try is evaluated from the rim inwards
        and stopped once it cannot beat the best so far: its ``"exact"`` is then False and its
        ``"modules"`` the upper bound it reached).
    existing : the skin already there (same frame); no module overlaps it.
    seam : run the seam pass (lattice shifts where growth fronts meet).
    seeds : growths per island at most: after the growth from the start, where room for a module
        is left (away from placed modules, creases and the border: :func:`next_seed`) a new lattice
        is grown from the middle of that room, with its own tiling, and so on (1: one growth), until
        a further seed adds fewer than two modules. With ``islands="one"`` a group gets a further
        seed only while it has no module.
    progress : None or ``progress(fraction) -> bool`` (0..1) called as growth proceeds; False
        stops the fill (``vtcore.errors.Cancelled``), nothing is returned.

    Returns ``(layout, report)``; the report carries ``charts`` and ``seam_modules``; its notes
    say which tiling won and what was left out. Raises :class:`.islands.NoModuleFits` (an InputError: one
    line saying why and what to do, then one line per island) when no module fits.
    """
    import time

    from .modules import get_module

    t0 = time.perf_counter()
    mod = get_module(module)
    at = _checked_start(at, islands)
    clean, creg, notes = _cropped_region(mesh, region, at, radius, mod)
    parts = face_islands(clean, creg)
    prepared = _solve_surface(clean, creg, mod, max_faces)
    plabel = _island_labels(clean, parts, prepared)
    samples = feature_samples(prepared.mesh, crease_angle, plabel >= 0)  # the region on the solve mesh
    groups, skipped, widths, fdist = island_groups(prepared, plabel, parts, clean, samples, mod, at, islands)
    tile = partial(_fill_island, prepared, samples=samples, mod=mod, max_strain=max_strain, angles=angles,
                   refine_offsets=refine_offsets, crease_angle=crease_angle, seam=seam, progress=progress)
    reports, avoid = [], None if existing is None or not len(existing) else np.asarray(existing.positions, float)
    group_of = []
    for k, (members, start, own) in enumerate(groups):
        got, avoid = _fill_group(tile, prepared, np.isin(plabel, members), start, own, direction=direction,
                                 radius=radius, offsets=offsets, seeds=seeds, one=islands == "one", fdist=fdist,
                                 avoid=avoid, mod=mod, island=k, n_faces=int(sum(len(parts[i]) for i in members)))
        reports += got
        group_of += [k] * len(got)
    if not any(r.n_modules for r in reports):
        raise no_module_fits(reports, parts, skipped, widths, mod, existing, crease_angle, max_strain)
    notes = notes + [n for r in reports for n in r.notes]
    if len(parts) > 1:
        notes.append(islands_note(parts, groups, reports, group_of, skipped))
    cover = _region_coverage(prepared.surface, clean, creg, radius, reports[0].start, mod)
    return _fill_result(reports, prepared.surface, cover, notes, max_strain, method="logmap",
                        info=[n for r in reports for n in r.info], offset=offset, at=at, direction=direction,
                        existing=existing, t0=t0, charts=sum(r.charts for r in reports),
                        seam_modules=sum(r.seam for r in reports), kind="fill")


def _checked_start(at, islands: str) -> np.ndarray:
    """``at`` as (3,) float64 metres; InputError naming the key when it or ``islands`` is not valid."""
    if islands not in ("each", "one"):
        raise InputError(f"must be 'each' or 'one', got {islands!r}", key="islands")
    at = np.asarray(at, dtype=np.float64).reshape(-1)
    if at.shape != (3,) or not np.isfinite(at).all():
        raise InputError(f"'at' must be 3 finite numbers, got {at.tolist()}", key="at")
    return at


def _cropped_region(mesh, region, at, radius, mod):
    """``(clean, creg, notes)``: the repaired mesh, the region on it ((F',) bool; every face by
    default), cropped to ``radius`` metres (plus a module) round ``at`` snapped to the surface, and
    the notes so far (the repairs, how far ``at`` was off the surface)."""
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
    cp, f0, d0, spread = snap(clean, at)
    notes += at_notes(cp[0], float(d0[0]), spread)
    if radius is not None:
        creg &= crop_mask(clean, cp[0], int(f0[0]), float(radius) + 2 * mod.radius)
    if not creg.any():
        raise InputError("the region selects no face within the radius", key="region")
    return clean, creg, notes


def _solve_surface(clean, creg, mod, max_faces) -> PreparedSurface:
    """The surface the fill's log maps are solved on: the region ``creg`` (F,) bool of ``clean`` and
    the faces within two pitches of it, simplified to ``max_faces`` (see :func:`fill`)."""
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
    return PreparedSurface(sub, resolution=mod.pitch, max_faces=max_faces)


def _island_labels(clean, parts, prepared) -> np.ndarray:
    """(F,) int: the island (index into ``parts``) of each face of the solve mesh, -1 off the region."""
    # each face the log maps are solved on, and each face taxels land on, belongs to the clean face
    # it lies on (closest point: a CAD needle's pieces are far from its centre, nearer another's)
    label = np.full(len(clean.faces), -1, np.int64)
    for k, f in enumerate(parts):
        label[f] = k
    return label[closest_points(clean, np.asarray(prepared.mesh.triangles_center))[1]]


def _fill_group(tile, prepared, mask, start, own, *, direction, radius, offsets, seeds, one, fdist, avoid, mod,
                island, n_faces):
    """Fill one group of islands (``mask`` (F,) bool on the solve mesh) from ``start`` (3,), then from
    further seeds (see :func:`fill`'s ``seeds``); ``tile`` is :func:`_fill_island` with the fill's
    settings, ``own``: the group holds the island of the fill's start. Returns ``(the IslandFill of
    each growth, avoid)``: ``avoid`` (n, 3) metres, the taxels to keep clear of, with the new ones."""
    reports, tried, room, got = [], [], None, False
    for j in range(max(int(seeds), 1)):
        # a further seed fills a room between modules: one shift per angle, then finer shifts
        r = tile(preg=mask, start=start, direction=direction if own and not j else None,
                 radius=radius if own and not j else None, avoid=avoid, offsets=offsets if not j or not got else 1,
                 island=island, n_faces=n_faces, seed=j, room=room)
        reports.append(r)
        tried.append(r.start)
        if r.n_modules:  # later seeds and islands keep clear of these modules
            avoid = r.pos if avoid is None else np.concatenate([avoid, r.pos])
        if not j and radius is not None and own:
            # further seeds stay within the radius (along the surface) of the first
            mask = mask & (r.dist0[np.asarray(prepared.mesh.faces)] <= radius).all(axis=1)
        if one and any(q.n_modules for q in reports):
            break  # one lattice per group: a further seed would start another
        had, got = got, got or bool(r.n_modules)
        if j and r.n_modules < 2 and had:
            break  # rooms left are smaller than the seeds' cost is worth (each costs a tiling search)
        # while the island has no module, every seed is tried, with the full tiling search, a pitch
        # (not a module's width) from the failed ones: on the G1 elbow's 40 mm patch (a ribbed CAD
        # part) the start keeps nothing, and the one spot a module fits is 6 mm from a failed seed
        nxt = next_seed(prepared, mask, fdist, avoid, tried, mod, modules=2 if got else 1,
                        spacing=None if got else mod.pitch)
        if nxt is None:
            break
        start, room = nxt
    return reports, avoid


def _joined_islands(chosen: list):
    """The islands' fills side by side: ``(patch, pos, nrm, found, frames, chart_of, is_seam)``, the
    charts numbered across islands (``chart_of`` (M,): which chart placed each module; ``is_seam``
    (M,): which the seam pass added)."""
    # the islands' own patches side by side (re-building one from all poses would drop taxels that
    # coincide in the flat domain across islands, whose flat frames differ, and leave pos longer)
    first = np.cumsum([0] + [r.patch.n_modules for r in chosen[:-1]])
    p = Patch(chosen[0].patch.module, np.concatenate([r.patch.poses for r in chosen]),
              np.concatenate([r.patch.flat for r in chosen]),
              np.concatenate([r.patch.module_ids + f for r, f in zip(chosen, first)]),
              np.concatenate([r.patch.sensors for r in chosen]), np.concatenate([r.patch.roles for r in chosen]),
              "fill")
    chart_of = np.concatenate([r.chart_of + sum(q.charts for q in chosen[:i]) for i, r in enumerate(chosen)])
    return (p, np.concatenate([r.pos for r in chosen]), np.concatenate([r.nrm for r in chosen]),
            np.concatenate([r.found for r in chosen]), np.concatenate([r.frames for r in chosen]), chart_of,
            np.concatenate([r.is_seam for r in chosen]))


def _region_coverage(surf, clean, creg, radius, start, mod):
    """``cover(frames, angles)``: the fraction of the region's area (on the subdivided surface ``surf``;
    within ``radius`` metres of ``start`` (3,) when given) under the modules of ``frames`` (M, 3, 3)
    turned by ``angles`` (M,) radians (NaN for a region of no area)."""
    sc = np.asarray(surf.triangles_center)
    sel = creg[faces_at(clean, sc)]
    if radius is not None:  # the disc of the radius (geodesic; measured in 3-D, a little wider)
        sel &= np.linalg.norm(sc - start, axis=1) <= radius
    cov_den = float(np.asarray(surf.area_faces)[sel].sum())

    def cover(frames, angles):
        return coverage_by_frames(sc[sel], np.asarray(surf.area_faces)[sel], frames, angles, mod) / cov_den \
            if cov_den > 0 else float("nan")

    return cover


def _fill_result(reports, surf, cover, notes, max_strain, **kw) -> tuple[Layout, PlacementReport]:
    """The fill's layout and report from the islands' fills ``reports`` (``kw``: :func:`.placement.finish`'s)."""
    p, pos, nrm, found, frames, chart_of, is_seam = _joined_islands([r for r in reports if r.n_modules])
    layout, report = finish(p, pos, nrm, found, surf, notes=notes, coverage=cover(frames, p.poses[:, 0]), **kw)
    over = np.asarray(report.module_strain) > max_strain if max_strain is not None else np.zeros(p.n_modules, bool)
    if over.any() and not over.all():
        # the growth measured a module's strain in the chart that mapped it; with the taxels' final
        # normals a module can come out a hair over the limit (5.1 % on the UR10 wrist-3 hull): the
        # fill keeps its promise and leaves it out
        keep, t = ~over, ~over[p.module_ids]
        p, pos, nrm, found, frames = p.select_modules(keep), pos[t], nrm[t], found[t], frames[keep]
        chart_of, is_seam = chart_of[keep], is_seam[keep]
        kw["seam_modules"] = int(is_seam.sum())
        notes = notes + [f"{int(over.sum())} modules left out: strained more than {100 * max_strain:.0f} % "
                         "on the final surface"]
        layout, report = finish(p, pos, nrm, found, surf, notes=notes, coverage=cover(frames, p.poses[:, 0]), **kw)
    layout.meta["fill_tilings"] = [t for r in reports for t in r.tilings]
    layout.meta["fill_left_out"] = {k: sum(r.reasons.get(k, 0) for r in reports) for k in LEFT_OUT}
    layout.meta["module_charts"] = chart_of.tolist()
    layout.meta["seam_module_ids"] = np.flatnonzero(is_seam).tolist()
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
    reasons: dict = field(default_factory=dict)
    dist0: np.ndarray = None  #: (V,) metres along the solve mesh from the start

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


def _fill_island(prepared, preg, samples, start, direction, mod, radius, max_strain, avoid, angles,
                 offsets, refine_offsets, crease_angle, seam, progress, island=0, n_faces=0, seed=0,
                 room=None) -> IslandFill:
    """Fill one island (``preg`` (F,) bool on the solve mesh) from ``start`` (3,) metres: choose the
    tiling in the first chart, grow its lattice chart by chart, close the seam (see :func:`fill`)."""
    notes = list(prepared.notes) if island == 0 and seed == 0 else []
    lm0 = LogMap(None, start, direction, prepared=prepared)
    R0 = lm0.trusted_radius(faces=preg)
    check = _edge_check(preg, samples, mod)
    extent = _lattice_extent(prepared, preg, lm0, mod, radius)
    # the tiling (angle, shift) that keeps most modules in the first chart wins (ties: the first)
    r_try = min(R0, extent)
    if room is not None:  # a further seed: its tiling is chosen for the room it was started in
        r_try = min(r_try, room + 2 * mod.radius)
    first_chart = partial(_first_chart, lm0, mod, r_try, radius, check, max_strain, avoid)
    best, tilings = _best_tiling(first_chart, mod, angles, offsets, refine_offsets, island, seed)
    n_best, ang, sh = best
    if not n_best:
        # no tiling keeps a module in the first chart: a module on the start, which the growth
        # always tries (its reasons then say what is wrong there)
        sh = centred_shift(mod, ang)
    latt = lattice_patch(mod, ang, sh, np.zeros(2), extent, radius)
    g = grow(prepared, lm0.at, direction, latt, check=check, max_strain=max_strain, first=lm0, avoid=avoid,
             progress=progress, faces=preg, min_gain=2)
    kept = np.flatnonzero(g.kept)
    poses, chart_of = latt.poses[kept], g.chart[kept]
    n_seam = 0
    if seam and len(kept):
        sp, sc = _seam_modules(g, mod, ang, sh, extent, radius, check, max_strain, avoid)
        n_seam = len(sp)
        poses, chart_of = np.concatenate([poses, sp]), np.concatenate([chart_of, sc])
    p = patch_from_poses(mod, poses, "fill")
    if not p.n_modules:
        why = f"island #{island}{f' seed {seed}' if seed else ''}: {n_faces} faces; candidate modules left out: " \
              f"{g.reasons_text()}"
        return IslandFill(p, np.zeros((0, 3)), np.zeros((0, 3)), np.zeros(0, bool), None, 0.0, 0.0, notes,
                          len(g.charts), 0, tilings, why, frames=np.zeros((0, 3, 3)), reasons=dict(g.reasons),
                          start=lm0.at, dist0=lm0.edge_distance())
    pos, nrm, face, found = map_modules(g.charts, p, chart_of)
    frames = module_frames(g.charts, p, chart_of)
    tag = (f"island #{island}" if island else "") + (f" seed {seed}" if seed else "")
    tag = f"{tag.strip()}: " if tag else ""
    if g.reasons.get("existing"):
        notes.append(f"{tag}{g.reasons['existing']} candidate modules left out: they would overlap modules "
                     "already on the skin")
    info = [f"{tag}fill: {len(tilings)} tilings tried in the first chart ({len(angles)} angles x "
                 f"{offsets * offsets if offsets > 1 else 0} shifts and one centred on the start, then finer shifts "
                 f"at the best angle); best at "
                 f"{np.degrees(ang):.0f} deg, shift ({sh[0]:.2f}, {sh[1]:.2f}) cells ({best[0]} modules there, "
                 f"the first try {tilings[0]['modules']}); grown through {len(g.charts)} chart(s): "
                 f"{len(kept)} modules, {n_seam} more closing the seam; left out: {g.reasons_text()}"]
    return IslandFill(p, pos, nrm, found, None, 0.0, 0.0, notes, len(g.charts), n_seam,
                      tilings, info=(prepared.info if island == 0 else []) + info, frames=frames, start=lm0.at,
                      reasons=dict(g.reasons), dist0=lm0.edge_distance(),
                      chart_of=chart_of, is_seam=np.arange(p.n_modules) >= len(kept))


def _edge_check(preg, samples, mod):
    """The growth's ``check(chart, patch, modules, tfaces, tmod) -> (len(modules),) bool``: taxels on
    region faces (``preg`` (F,) bool), no open, sharp or region-border edge (``samples``: the points of
    :func:`feature_samples`) under a module's taxels."""
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

    return check


def _lattice_extent(prepared, preg, lm0, mod, radius) -> float:
    """Metres: the radius of the lattice disc for the island ``preg`` (F,) bool grown from ``lm0``."""
    # one lattice for the whole island: a disc larger than its farthest point, with room for
    # curvature (charts on a non-developable surface use more lattice per area). The distance is the
    # path along the surface (at most ~10 % over the geodesic), over the island's own vertices: the
    # log map's own distances are garbage past the cut locus (0.48 m on a 0.14 m forearm), and
    # other islands' are not this lattice's business
    own = np.unique(np.asarray(prepared.mesh.faces)[preg])
    far = lm0.edge_distance()[own]
    far = far[np.isfinite(far)]
    extent = 1.5 * (float(far.max()) if len(far) else 0.0) + 2 * mod.radius
    if radius is not None:
        extent = min(extent, float(radius) + mod.radius)
    return extent


def _best_tiling(first_chart, mod, angles, offsets, refine_offsets, island, seed):
    """``((modules, angle, shift), tilings)``: the tiling whose lattice keeps most modules in the first
    chart (``first_chart(angle, shift, beat) -> (modules, exact)``; ties: the first), and every try as
    ``layout.meta["fill_tilings"]`` lists it."""
    tilings, best = [], None
    # at each angle the grid of shifts and the shift that centres a module's taxels on the start
    # (a designer's cursor or a seed in the middle of a strip: a 24 mm band along a plate took 2
    # modules from the grid's best shift, 3 centred); a further seed (offsets 1) takes the centred one
    coarse = [(a, sh) for a in angles for sh in
              ([(fu / offsets, fv / offsets) for fu, fv in np.ndindex(offsets, offsets)] if offsets > 1 else [])
              + [centred_shift(mod, a)]]

    def fine():
        done = {(u / offsets, v / offsets) for u, v in np.ndindex(offsets, offsets)}
        return [(best[1], (fu / refine_offsets, fv / refine_offsets))
                for fu, fv in np.ndindex(refine_offsets, refine_offsets)
                if (fu / refine_offsets, fv / refine_offsets) not in done] if refine_offsets > offsets else []

    for stage in (lambda: coarse, fine):
        for ang, sh in stage():
            n, exact = first_chart(ang, sh, None if best is None else best[0])
            tilings.append({"angle_deg": float(np.degrees(ang)), "shift_cells": [float(sh[0]), float(sh[1])],
                            "modules": n, "exact": exact, "island": island, "seed": seed})
            if best is None or n > best[0]:
                best = (n, ang, sh)
    return best, tilings


def _first_chart(lm0, mod, r_try, radius, check, max_strain, avoid, ang, sh, beat) -> tuple[int, bool]:
    """Modules of the lattice (angle, shift) the first chart (``lm0``, ``r_try`` metres) keeps, and
    whether that count is exact. The modules are tried from the rim inwards, in chunks: the rim is
    where the map strains and the region ends, so the rejections come first, and a try stops as soon
    as it cannot keep more than ``beat`` modules (the best so far; ties go to the earlier try, so a
    stopped try could not have won) and returns that upper bound."""
    reach = float(np.linalg.norm(mod.taxels, axis=1).max()) + 0.5 * mod.pitch
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


def _seam_modules(g, mod, ang, sh, extent, radius, check, max_strain, avoid):
    """``(poses (S, 3), chart (S,))``: the modules the seam pass adds where the growth ``g``'s fronts
    meet, from the island's lattice (angle ``ang``, shift ``sh``) shifted by :data:`SEAM_SHIFTS`."""
    # a chart whose map no face of the region contradicts has an infinite trusted radius (the
    # UR10 forearm from three anchors): its seam candidates still lie in the island's lattice,
    # within ``extent`` of the lattice origin
    return close_seam(g, lambda s2, c, r: lattice_patch(mod, ang, (sh[0] + s2[0], sh[1] + s2[1]), c,
                                                        min(r, float(np.linalg.norm(c)) + extent), radius),
                      check, max_strain, SEAM_SHIFTS, avoid=avoid)
