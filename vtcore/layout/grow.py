"""Cover a surface beyond one chart: grow the skin chart by chart, closing the seam with whole modules.

A single log map is only trusted up to the cut locus (half way round a cylinder, less on
strongly curved parts). Growth keeps ONE flat lattice (the patch's, or the fill tiling) and
maps it through a sequence of charts, each a log map at a module already placed:

1. Chart 0 is the log map at ``at`` with the patch's x axis along ``direction``.
2. Each chart maps the lattice modules that lie wholly within its trusted radius (the
   geodesic distance to the first folded or stretched face of its map) and are nearer its
   origin than the chart that last tried them.
3. New charts are centred on placed modules at the frontier (at most one per ``spacing``);
   a new chart's x axis is the image of the lattice x axis at that module (the push-forward
   of the flat axis through the parent chart's exp, which is the parallel transport along
   the radial geodesic on a developable surface), so the lattice continues across charts
   without a jump.
4. Where growth fronts meet (round a closed link), the lattice does not close up: modules
   that would overlap placed ones are left out and the seam pass tries the lattice shifted
   by fractions of a tiling cell in every chart, keeping each shifted module that fits
   whole without overlap. What is left is a gap narrower than one module.

On non-developable surfaces each chart carries the strain its own log map forces (the
same as one log map of the chart's radius), and the lattice bends where charts join: the
modules still never overlap and never exceed ``max_strain``; see docs/layout.md.
"""

from __future__ import annotations

from dataclasses import dataclass


import numpy as np
from scipy.spatial import cKDTree

from ..errors import InputError
from .._progress import keep_going
from .logmap import LogMap, PreparedSurface
from .patches import Patch
from .report import OVERLAP_FRACTION, arc_lengths


@dataclass
class Chart:
    """One log map of the growth: origin in the lattice's flat frame (2,) and on the surface (3,)."""

    origin: np.ndarray
    at: np.ndarray
    direction: np.ndarray
    logmap: LogMap
    radius: float


@dataclass
class Growth:
    """What :func:`grow` placed.

    positions, normals : (N, 3) for every taxel of the lattice patch (nan where not placed).
    face : (N,) int, face of ``prepared.surface`` under each taxel (-1 where not placed).
    found : (N,) bool. chart : (M,) int, the chart that placed each module (-1: none).
    kept : (M,) bool, modules placed and accepted. seam : (M,) bool, modules added by the seam pass.
    frames : (M, 3, 3) rows origin, x axis, normal of each placed module on the surface.
    charts : list of :class:`Chart`.
    """

    positions: np.ndarray
    normals: np.ndarray
    face: np.ndarray
    found: np.ndarray
    chart: np.ndarray
    kept: np.ndarray
    seam: np.ndarray
    frames: np.ndarray
    charts: list
    reasons: dict
    seam_at: np.ndarray  # (S, 2) flat centres of lattice modules dropped where growth fronts met

    def reasons_text(self) -> str:
        """What was left out and why, e.g. ``"3 off the surface, 2 strained, 5 overlapping"``."""
        words = {"off": "off the surface", "rules": "on a sharp or open edge", "strain": "strained",
                 "overlap": "overlapping", "existing": "over modules already on the skin"}
        out = [f"{n} {words[k]}" for k, n in self.reasons.items() if n]
        return ", ".join(out) if out else "nothing"


def taxel_index(counts: np.ndarray, starts: np.ndarray, modules: np.ndarray) -> np.ndarray:
    """Indices of the taxels of ``modules`` (module-major patch with per-module counts and starts)."""
    c = counts[modules]
    return np.repeat(starts[modules], c) + (np.arange(int(c.sum())) - np.repeat(np.cumsum(c) - c, c))


def module_strain(patch: Patch, pos: np.ndarray, nrm: np.ndarray, modules: np.ndarray) -> np.ndarray:
    """(len(modules),) max |strain| of each listed module's edges, where ``pos``, ``nrm`` (N, 3)
    hold the patch's taxels on the surface (missing or torn edges count as strain 1)."""
    e = patch.module_edges
    if not len(e) or not len(modules):
        return np.zeros(len(modules))
    inset = np.zeros(patch.n_modules, bool)
    inset[modules] = True
    e = e[inset[patch.module_ids[e[:, 0]]]]
    i, j = e[:, 0], e[:, 1]
    lf = np.linalg.norm(patch.flat[i] - patch.flat[j], axis=1)
    ls = arc_lengths(pos[i], pos[j], nrm[i], nrm[j])
    s = np.abs(np.nan_to_num(ls / np.where(lf > 0, lf, np.nan) - 1.0, nan=1.0))
    ms = np.zeros(patch.n_modules)
    np.maximum.at(ms, patch.module_ids[i], s)
    return ms[modules]


def grow(prepared: PreparedSurface, at, direction, patch: Patch, *, check=None, max_strain: float | None = None,
         max_charts: int = 400, chart_radius: float | None = None, progress=None,
         first: LogMap | None = None, avoid: np.ndarray | None = None,
         faces: np.ndarray | None = None, min_gain: int = 1) -> Growth:
    """Map the modules of ``patch`` (a flat lattice, origin at ``at``) chart by chart.

    prepared : the surface. at : (3,) metres. direction : (3,) or None, the lattice x axis at ``at``.
    check : None to place every module (``place``: nothing is left out, what goes wrong is
        reported), or a callable ``(chart, patch, modules (K,), taxel_faces (T,), taxel_module (T,)
        in 0..K-1) -> (K,) bool`` of extra rules (faces are of ``chart.logmap.mesh``) (region, creases) for ``fill``, which also drops modules that strain more than
        ``max_strain``, fall off the surface or overlap a module already placed.
    chart_radius : metres, cap on every chart's radius (default: each chart's trusted radius).
    progress : None or ``progress(fraction) -> bool`` called after each chart; False stops the
        growth (``vtcore.errors.Cancelled`` is raised, nothing is returned).
    first : the log map at ``at`` on ``prepared`` if already solved (chart 0).
    avoid : (P, 3) taxel positions already on the skin: no module is placed over them.
    faces : (F,) bool of ``prepared.mesh``, the faces taxels may land on (a chart's trusted
        radius only looks at those).
    """
    mod = patch.module
    M, N = patch.n_modules, len(patch)
    counts = np.bincount(patch.module_ids, minlength=M)
    starts = np.concatenate([[0], np.cumsum(counts)[:-1]]).astype(np.int64)
    centre = patch.poses[:, 1:]
    pos, nrm = np.full((N, 3), np.nan), np.full((N, 3), np.nan)
    face, found = np.full(N, -1, np.int64), np.zeros(N, bool)
    chart_of = np.full(M, -1, np.int64)
    tried = np.full(M, np.inf)  # flat distance to the origin of the chart that last tried the module
    gone = np.zeros(M, bool)  # left out for good (off the surface, overlapping, against the rules)
    kept = np.zeros(M, bool)
    status = np.full(M, -1, np.int8)  # on the surface? -1 unknown, 0 no, 1 yes (for seeding)
    frames = np.full((M, 3, 3), np.nan)
    min_gap = OVERLAP_FRACTION * mod.pitch
    # a chart maps a module when all its taxels are within the chart's trusted radius
    reach = float(np.linalg.norm(mod.taxels, axis=1).max()) + 0.5 * mod.pitch
    charts: list[Chart] = []
    reasons = {"off": 0, "rules": 0, "strain": 0, "overlap": 0, "existing": 0}
    seam_at = []  # flat centres of modules left out for overlapping another chart's: the seam
    avoid = np.zeros((0, 3)) if avoid is None else np.asarray(avoid, float).reshape(-1, 3)
    queue = [(np.zeros(2), np.asarray(at, float), direction)]
    ctree = cKDTree(centre) if M else None
    while queue and len(charts) < max_charts:
        o, a3, d3 = queue.pop(0)
        if first is not None and not charts:
            lm = first
        else:
            try:
                lm = LogMap(None, a3, d3, prepared=prepared)
            except InputError as exc:
                if not charts or exc.key != "direction":
                    raise
                # the lattice axis carried to this seed lies along the surface normal there (a
                # sliver of a decimated mesh tilts the pushed-forward frame): another seed on the
                # same front maps these modules, so this one is dropped, not the whole fill (modules
                # no other chart reaches stay unplaced and are reported as such)
                continue
        R = lm.trusted_radius(faces=faces)
        if chart_radius is not None:
            R = min(R, chart_radius)
        if not charts:
            R = max(R, reach + mod.pitch)  # chart 0 always maps the module at 'at'
        c = len(charts)
        charts.append(Chart(o, lm.at, lm.t1, lm, R))
        d = np.linalg.norm(centre - o, axis=1)
        elig = ~kept & ~gone & (d + reach <= R) & (d < tried - 1e-9)
        mods = np.flatnonzero(elig)
        mods = mods[np.argsort(d[mods], kind="stable")]
        if not len(mods):
            continue
        ti = taxel_index(counts, starts, mods)
        p_, n_, f_, ok_ = lm.exp(patch.flat[ti] - o, fallback=check is None)
        tp, tn = pos.copy(), nrm.copy()
        tp[ti], tn[ti] = p_, n_
        tried[mods] = d[mods]
        keep = np.ones(len(mods), bool)
        if check is not None:
            tmod = np.repeat(np.arange(len(mods)), counts[mods])
            whole = np.bincount(tmod, weights=ok_, minlength=len(mods)) == counts[mods]
            rules = np.asarray(check(charts[c], patch, mods, f_, tmod), bool)
            gone[mods[~whole | ~rules]] = True
            reasons["off"] += int((~whole).sum())
            reasons["rules"] += int((whole & ~rules).sum())
            keep &= whole & rules
            if max_strain is not None:
                strained = keep & (module_strain(patch, tp, tn, mods) > max_strain)  # may fit in a nearer chart
                reasons["strain"] += int(strained.sum())
                keep &= ~strained
            # overlaps with modules already placed (other charts, or the skin there before): for good
            if len(avoid) and keep.any():
                hit = cKDTree(avoid).query_ball_point(p_, min_gap, return_length=True) > 0
                bad = np.bincount(tmod, weights=hit, minlength=len(mods)) > 0
                gone[mods[bad & keep]] = True
                reasons["existing"] += int((bad & keep).sum())
                keep &= ~bad
            placed = pos[np.isfinite(pos[:, 0])]
            if len(placed) and keep.any():
                hit = cKDTree(placed).query_ball_point(p_, min_gap, return_length=True) > 0
                bad = np.bincount(tmod, weights=hit, minlength=len(mods)) > 0
                gone[mods[bad & keep]] = True
                reasons["overlap"] += int((bad & keep).sum())
                seam_at.extend(centre[mods[bad & keep]].tolist())
                keep &= ~bad
            # overlaps within this chart (past a fold): the module nearer the chart's origin wins
            if keep.sum() > 1:
                kt = keep[tmod]
                pairs = cKDTree(p_[kt]).query_pairs(min_gap, output_type="ndarray")
                if len(pairs):
                    mt = tmod[kt]
                    a, b = mt[pairs[:, 0]], mt[pairs[:, 1]]
                    for x, y in sorted({(min(u, v), max(u, v)) for u, v in zip(a, b) if u != v}):
                        if keep[x] and keep[y]:  # mods are sorted by distance: y is the farther
                            keep[y] = False
                            gone[mods[y]] = True
                            reasons["overlap"] += 1
        km = mods[keep]
        if not len(km):
            continue
        kti = taxel_index(counts, starts, km)
        sel = np.isin(ti, kti)
        pos[ti[sel]], nrm[ti[sel]], face[ti[sel]], found[ti[sel]] = p_[sel], n_[sel], f_[sel], ok_[sel]
        kept[km], chart_of[km] = True, c
        # each placed module's frame on the surface: origin, lattice x axis, normal
        eps = 0.5 * mod.pitch
        probe = np.concatenate([centre[km], centre[km] + [eps, 0.0], centre[km] - [eps, 0.0]]) - o
        fp, fn, _, _ = lm.exp(probe)
        k = len(km)
        x = fp[k:2 * k] - fp[2 * k:]
        x -= fn[:k] * np.einsum("ij,ij->i", x, fn[:k])[:, None]
        x /= np.maximum(np.linalg.norm(x, axis=1, keepdims=True), 1e-300)
        frames[km] = np.stack([fp[:k], x, fn[:k]], axis=1)
        if progress is not None:
            # the share of charts done among those known so far (the queue grows as it goes)
            keep_going(progress, min(0.95, len(charts) / (len(charts) + len(queue) + 1)), "the fill")
        # new charts at the frontier: placed modules (of any chart) next to modules still to try
        # that lie on the surface; seeds at least ``spacing`` apart (each chart costs a solve)
        spacing = max(0.7 * (R - reach), mod.pitch)
        pending = ~kept & ~gone
        if not pending.any():
            continue
        hood = 2 * reach + mod.pitch
        # a pending module counts once this chart's map, even past its trusted radius, finds its
        # centre on the surface (lattice modules past an open edge would seed charts for nothing)
        near_km = ctree.query_ball_point(centre[km], hood)
        test = np.unique(np.concatenate([np.asarray(nb, np.int64) for nb in near_km]))
        test = test[pending[test] & (status[test] < 0)]
        if len(test):
            status[test] = lm.exp(centre[test] - o, fallback=False, on_surface=False)[3].astype(np.int8)
        want = pending & (status == 1)
        if not want.any():
            continue
        # seeds: the centres of wanted modules inside this chart's trusted disc (a chart there maps
        # the module whole), else placed modules next to wanted ones; apart in the lattice (flat)
        # and on the surface (3-D: round a closed link the lattice goes on, the surface does not)
        inner = np.flatnonzero(want & (d <= R - 0.5 * mod.pitch))
        inner = inner[np.argsort(-d[inner], kind="stable")]  # farthest first: fewer charts
        near_want = cKDTree(centre[want]).query_ball_point(centre[kept], hood, return_length=True) > 0
        front = np.flatnonzero(kept)[near_want]
        front = front[np.argsort(np.linalg.norm(centre[front], axis=1), kind="stable")]
        cand = np.concatenate([inner, front])
        if not len(cand):
            continue
        eps = 0.5 * mod.pitch
        cen = centre[cand]
        k = len(cand)
        fp, fn, _, _ = lm.exp(np.concatenate([cen, cen + [eps, 0.0], cen - [eps, 0.0]]) - o, fallback=False)
        x = fp[k:2 * k] - fp[2 * k:]
        x -= fn[:k] * np.einsum("ij,ij->i", x, fn[:k])[:, None]
        src = np.concatenate([np.zeros(len(inner), bool), np.ones(len(front), bool)])
        origins = [(ch.origin, ch.at) for ch in charts] + [(q[0], q[1]) for q in queue]
        if min_gain > 1:
            # a chart costs a solve: seed one only where it can add min_gain wanted modules (the
            # few strained modules left along a region's rim would each cost a chart for one module)
            wt = cKDTree(centre[want])
            gain = wt.query_ball_point(centre[cand], hood, return_length=True)
            ok = gain >= min(min_gain, int(want.sum()))
            cand, src, fp, x = cand[ok], src[ok], fp[:k][ok], x[ok]
        for t, m in enumerate(cand):
            p3, x3 = (frames[m, 0], frames[m, 1]) if src[t] else (fp[t], x[t])
            if all(np.linalg.norm(centre[m] - q2) >= spacing and np.linalg.norm(p3 - q3) >= 0.5 * spacing
                   for q2, q3 in origins):
                queue.append((centre[m].copy(), p3, x3))
                origins.append((centre[m], p3))
    return Growth(pos, nrm, face, found, chart_of, kept, np.zeros(M, bool), frames, charts, reasons,
                  np.asarray(seam_at, float).reshape(-1, 2))


def map_modules(charts: list, patch: Patch, chart_of: np.ndarray):
    """Taxels of ``patch`` on the surface, each module through its chart ``chart_of`` (M,)
    (-1: the chart whose origin is nearest in the flat frame).

    Returns ``(positions (N, 3), normals (N, 3), face (N,), found (N,) bool)``.
    """
    chart_of = np.asarray(chart_of, np.int64).copy()
    if (chart_of < 0).any():
        origins = np.array([c.origin for c in charts])
        miss = np.flatnonzero(chart_of < 0)
        chart_of[miss] = np.argmin(np.linalg.norm(patch.poses[miss, None, 1:] - origins[None], axis=2), axis=1)
    N = len(patch)
    pos, nrm = np.zeros((N, 3)), np.zeros((N, 3))
    face, found = np.zeros(N, np.int64), np.zeros(N, bool)
    tchart = chart_of[patch.module_ids]
    for c in np.unique(tchart):
        t = np.flatnonzero(tchart == c)
        pos[t], nrm[t], face[t], found[t] = charts[c].logmap.exp(patch.flat[t] - charts[c].origin)
    return pos, nrm, face, found


def close_seam(growth: Growth, lattice, check, max_strain: float, shifts,
               avoid: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """The seam pass: in every chart, the lattice shifted by each of ``shifts`` (fractions of a
    tiling cell) is tried where the growth left room; every shifted module that is whole on the
    surface, passes ``check``, strains at most ``max_strain`` and overlaps nothing is added.

    lattice : callable ``(shift (2,), centre (2,), radius) -> Patch`` of lattice modules in the
    flat frame within ``radius`` of ``centre``. check : as for :func:`grow`. Returns
    ``(poses (S, 3), chart (S,))`` of the added modules (flat frame of the lattice).
    """
    taken = [growth.positions[np.isfinite(growth.positions[:, 0])]]
    if avoid is not None and len(avoid):
        taken[0] = np.concatenate([taken[0], np.asarray(avoid, float).reshape(-1, 3)])
    out_poses, out_chart = [], []
    if not len(growth.seam_at):
        return np.zeros((0, 3)), np.zeros(0, np.int64)
    seam_tree = cKDTree(growth.seam_at)
    for c, ch in enumerate(growth.charts):
        for shift in shifts:
            cand = lattice(shift, ch.origin, ch.radius)
            if not cand.n_modules:
                continue
            mod = cand.module
            min_gap = OVERLAP_FRACTION * mod.pitch
            d = np.linalg.norm(cand.poses[:, 1:] - ch.origin, axis=1)
            # only at the seam: within two module radii of a module dropped there
            at_seam = seam_tree.query_ball_point(cand.poses[:, 1:], 2 * mod.radius, return_length=True) > 0
            reach = float(np.linalg.norm(mod.taxels, axis=1).max()) + 0.5 * mod.pitch
            cand = cand.select_modules((d + reach <= ch.radius) & at_seam)
            if not cand.n_modules:
                continue
            d = np.linalg.norm(cand.poses[:, 1:] - ch.origin, axis=1)
            p_, n_, f_, ok_ = ch.logmap.exp(cand.flat - ch.origin, fallback=False)
            tmod, M = cand.module_ids, cand.n_modules
            keep = np.bincount(tmod, weights=ok_, minlength=M) == np.bincount(tmod, minlength=M)
            allp = np.concatenate(taken)
            if len(allp):
                hit = cKDTree(allp).query_ball_point(p_, min_gap, return_length=True) > 0
                keep &= np.bincount(tmod, weights=hit, minlength=M) == 0
            idx = np.flatnonzero(keep)
            if not len(idx):
                continue
            keep[idx] &= module_strain(cand, p_, n_, idx) <= max_strain
            idx = np.flatnonzero(keep)
            if not len(idx):
                continue
            tsel = np.isin(tmod, idx)
            keep[idx] &= np.asarray(check(ch, cand, idx, f_[tsel], np.searchsorted(idx, tmod[tsel])), bool)
            # greedy, nearest the chart origin first, against each other
            for m in np.flatnonzero(keep)[np.argsort(d[keep], kind="stable")]:
                pm = p_[tmod == m]
                if len(taken) > 1 and (cKDTree(np.concatenate(taken[1:])).query_ball_point(
                        pm, min_gap, return_length=True) > 0).any():
                    continue
                taken.append(pm)
                out_poses.append(cand.poses[m])
                out_chart.append(c)
    return np.array(out_poses).reshape(-1, 3), np.array(out_chart, np.int64)


def module_frames(charts: list, patch: Patch, chart_of: np.ndarray) -> np.ndarray:
    """(M, 3, 3) rows origin, lattice x axis, normal of each module of ``patch`` on the surface,
    through its chart (the push-forward of the flat x axis at the module's origin)."""
    M = patch.n_modules
    out = np.full((M, 3, 3), np.nan)
    eps = 0.5 * patch.module.pitch
    for c in np.unique(chart_of):
        m = np.flatnonzero(chart_of == c)
        o = charts[c].origin
        cen = patch.poses[m, 1:]
        fp, fn, _, _ = charts[c].logmap.exp(np.concatenate([cen, cen + [eps, 0.0], cen - [eps, 0.0]]) - o)
        k = len(m)
        x = fp[k:2 * k] - fp[2 * k:]
        x -= fn[:k] * np.einsum("ij,ij->i", x, fn[:k])[:, None]
        x /= np.maximum(np.linalg.norm(x, axis=1, keepdims=True), 1e-300)
        out[m] = np.stack([fp[:k], x, fn[:k]], axis=1)
    return out
