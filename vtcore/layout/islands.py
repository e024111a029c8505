"""The islands of a fill's region (issue 26): which to fill and from where, where a further growth
starts when room is left, the note on how they were filled, and the one-line error (with a detail
block) when no module fits anywhere. Used by :func:`vtcore.layout.tiling.fill`."""

from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

from ..errors import InputError
from .regions import central_point, feature_distance, free_width, module_width, too_narrow_message


class NoModuleFits(InputError):
    """No whole module fits in the region: the message is one line (why, and what to do);
    ``details`` is a list of lines, one per island (``vtcore layout place --details`` and the
    add-on's report box show them)."""

    def __init__(self, reason: str, details=(), *, key: str = "region"):
        super().__init__(reason, key=key)
        self.details = [str(d) for d in details]


def island_groups(prepared, plabel, parts, clean, samples, mod, at, islands):
    """The islands to fill and where each starts: ``(groups, skipped, widths)``.

    plabel : (F,) the island of each face of ``prepared.mesh`` (-1 outside the region); parts :
    the islands (face indices of ``clean``). An island smaller than the hull of a module's taxels,
    or narrower than a module between the edges no module may straddle (:func:`free_width`), is
    skipped (``skipped``: {island: why}). ``groups``: list of ``(islands, start (3,), own)``, the
    group holding the island nearest ``at`` first, started from ``at`` (``own`` True), the others
    from the most central point of their largest island; with ``islands="one"`` the islands
    connected on the solve surface (within two pitches of each other) form one group.
    ``widths``: (K,) metres, the free width of each island; ``fdist`` (V,) metres from each
    vertex of ``prepared.mesh`` to the nearest edge no module may straddle (:func:`feature_distance`).
    """
    from scipy.spatial import ConvexHull

    hull = ConvexHull(mod.taxels).volume  # 2-D: the area of the taxels' hull
    F = np.asarray(prepared.mesh.faces)
    pairs = samples[0]
    fdist = feature_distance(prepared.path_graph(), pairs.ravel())
    need = module_width(mod)
    pitch_res = mod.pitch  # the solve mesh's vertices are at most a pitch apart: widths are that coarse
    area = np.asarray(clean.area_faces)
    widths, skipped = np.zeros(len(parts)), {}
    for k, f in enumerate(parts):
        widths[k] = free_width(F[plabel == k].ravel(), fdist)
        a = float(area[f].sum())
        if a < hull:
            skipped[k] = f"{1e6 * a:.0f} mm^2, smaller than a module ({1e6 * hull:.0f} mm^2)"
        elif widths[k] + pitch_res < need:
            skipped[k] = f"{1e3 * widths[k]:.1f} mm across, narrower than a module ({1e3 * need:.1f} mm)"
    live = [k for k in range(len(parts)) if k not in skipped]
    if not live:  # nothing can fit: try the widest anyway, so that the error says what was found there
        live = [int(np.argmax(widths))]
        skipped.pop(live[0], None)
    cen = np.asarray(clean.triangles_center)
    nearest = min(live, key=lambda k: float(np.linalg.norm(cen[parts[k]] - at, axis=1).min()))
    if islands == "one":
        import trimesh

        comp = np.full(len(prepared.mesh.vertices), -1, np.int64)
        for c, vs in enumerate(trimesh.graph.connected_components(prepared.mesh.face_adjacency_edges,
                                                                  nodes=np.arange(len(prepared.mesh.vertices)))):
            comp[np.asarray(vs, np.int64)] = c
        where = {k: int(comp[F[np.flatnonzero(plabel == k)[0], 0]]) for k in live}
        buckets = {}
        for k in live:
            buckets.setdefault(where[k], []).append(k)
        sets = sorted(buckets.values(), key=lambda ks: (nearest not in ks, ks[0]))
    else:
        sets = [[nearest]] + [[k] for k in live if k != nearest]
    groups = []
    for ks in sets:
        if nearest in ks:
            groups.append((ks, at, True))
        else:
            groups.append((ks, central_point(clean.submesh([parts[ks[0]]], append=True, repair=False)), False))
    return groups, skipped, widths, fdist


def next_seed(prepared, mask, fdist, placed, tried, mod, modules: int = 1, spacing: float | None = None):
    """``(start (3,), room)`` where the next growth of an island starts and how much room (metres to
    the nearest crease, border or placed taxel) there is, or None: the vertex of ``mask``'s faces
    (of ``prepared.mesh``) farthest from the edges no module may straddle (``fdist`` (V,)), among
    those with room for ``modules`` modules side by side (1: half a module's width from those edges,
    half a width and half a pitch from every ``placed`` taxel (P, 3); 2: a whole width), a module's
    width (or ``spacing`` metres) from every start ``tried``. A growth costs a log map and a tiling search over the island:
    once an island has modules, a seed must have room for two (on a 1,000-module fill the rims'
    gaps for one module each doubled the time for 9 more modules)."""
    F = np.asarray(prepared.mesh.faces)
    V = np.asarray(prepared.mesh.vertices)
    verts = np.unique(F[mask])
    if not len(verts):
        return None
    half = module_width(mod) / 2 * modules
    score = np.minimum(fdist[verts], 1e3)
    ok = score >= half - 0.5 * mod.pitch  # vertices are up to a pitch apart: the middle may lie between
    if placed is not None and len(placed):
        d = cKDTree(placed).query(V[verts], distance_upper_bound=4 * mod.radius)[0]
        ok &= d >= half + 0.5 * mod.pitch
        score = np.minimum(score, d)
    if len(tried):
        ok &= cKDTree(np.asarray(tried)).query(V[verts])[0] >= (module_width(mod) if spacing is None else spacing)
    if not ok.any():
        return None
    i = np.flatnonzero(ok)
    best = i[np.argmax(score[i])]
    return V[verts[best]].copy(), float(score[best])


def islands_note(parts, groups, reports, group_of, skipped) -> str:
    """One note on how the islands of a region were filled (``group_of``: the group of each report)."""
    got = {}
    for g, (ks, _, _) in enumerate(groups):
        n = sum(r.n_modules for r, h in zip(reports, group_of) if h == g)
        for k in ks:
            got[k] = n if len(ks) == 1 else None
    shown = [f"#{k}: {len(f)} faces, " + (f"{got[k]} modules" if got.get(k) is not None else
                                          "shares a lattice" if k in got else "left out")
             for k, f in enumerate(parts[:12])]
    more = f", and {len(parts) - 12} more" if len(parts) > 12 else ""
    small = f"; {len(skipped)} left out as smaller than a module" if skipped else ""
    shared = "; islands within two pitches of each other share one lattice" if any(len(g[0]) > 1 for g in groups) \
        else "; each was filled from its own start"
    return f"the region has {len(parts)} islands ({', '.join(shown)}{more}){small}{shared}"


def no_module_fits(reports, parts, skipped, widths, mod, existing, crease_angle, max_strain) -> NoModuleFits:
    """The one-line error when no module fits anywhere in the region, with a detail line per island."""
    where = "the region" if len(parts) == 1 else f"the region ({len(parts)} islands)"
    width = float(np.max(widths)) if len(widths) else float("inf")
    detail = [r.why for r in reports if r.why] + [f"island #{k}: {why}" for k, why in sorted(skipped.items())][:20]
    line = too_narrow_message(width, mod, f"the widest part of {where}")
    if line is None:
        beside = " beside the modules already on the skin" if existing is not None and len(existing) else ""
        counts = {}
        for r in reports:
            for k, n in r.reasons.items():
                counts[k] = counts.get(k, 0) + n
        main = max(counts, key=counts.get) if any(counts.values()) else None
        advice = {"off": "modules would run off the region or off an open edge of the mesh: select more faces "
                       "round it",
                  "rules": f"modules would cross an open edge, a region border or a crease sharper than "
                           f"{crease_angle:g} deg: raise the crease angle (--crease-angle) if those creases are "
                           "facets of a curved part, or select more faces",
                  "strain": f"modules would stretch more than the strain limit {max_strain:g}: the part is too "
                            "curved there for this module; try a smaller module or raise the limit (--max-strain)",
                  "overlap": "modules would overlap each other", "existing": "remove or move modules already there",
                  None: "give a larger region"}[main]
        across = "no edge, crease or border bounds it" if not np.isfinite(width) else \
            f"{1e3 * width:.1f} mm across at its widest"
        line = (f"no whole {mod.name} module fits in {where}{beside} ({across}; a {mod.name} needs "
                f"{1e3 * module_width(mod):.1f} mm): {advice}")
    return NoModuleFits(line, detail)


__all__ = ["NoModuleFits", "island_groups", "next_seed", "islands_note", "no_module_fits"]
