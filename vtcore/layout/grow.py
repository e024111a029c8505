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


@dataclass
class _GrowState:
    """What :func:`grow` knows while it goes, over M modules and N taxels of the lattice patch.

    counts, starts : (M,) taxels of each module and its first taxel; centre : (M, 2) flat module
    centres; pos, nrm : (N, 3) placed taxels (nan: not yet); face, found : (N,); chart_of : (M,);
    tried : (M,) flat distance to the origin of the chart that last tried each module; gone : (M,)
    left out for good (off the surface, overlapping, against the rules); kept : (M,); status : (M,)
    int8 on the surface? (-1 unknown, 0 no, 1 yes, for seeding); frames : (M, 3, 3); reasons : counts
    by reason; seam_at : flat centres of modules left out for overlapping another chart's (the seam);
    reach : m, a module's radius plus half a pitch; min_gap : m, closest two taxels may come;
    avoid : (P, 3) taxels already on the skin; ctree : KD-tree of ``centre``.
    """

    counts: np.ndarray
    starts: np.ndarray
    centre: np.ndarray
    pos: np.ndarray
    nrm: np.ndarray
    face: np.ndarray
    found: np.ndarray
    chart_of: np.ndarray
    tried: np.ndarray
    gone: np.ndarray
    kept: np.ndarray
    status: np.ndarray
    frames: np.ndarray
    reasons: dict
    seam_at: list
    reach: float
    min_gap: float
    avoid: np.ndarray
    ctree: cKDTree | None

    @classmethod
    def start(cls, patch: Patch, avoid) -> "_GrowState":
        mod = patch.module
        M, N = patch.n_modules, len(patch)
        counts = np.bincount(patch.module_ids, minlength=M)
        starts = np.concatenate([[0], np.cumsum(counts)[:-1]]).astype(np.int64)
        centre = patch.poses[:, 1:]
        # a chart maps a module when all its taxels are within the chart's trusted radius
        reach = float(np.linalg.norm(mod.taxels, axis=1).max()) + 0.5 * mod.pitch
        return cls(counts, starts, centre, np.full((N, 3), np.nan), np.full((N, 3), np.nan),
                   np.full(N, -1, np.int64), np.zeros(N, bool), np.full(M, -1, np.int64), np.full(M, np.inf),
                   np.zeros(M, bool), np.zeros(M, bool), np.full(M, -1, np.int8), np.full((M, 3, 3), np.nan),
                   {"off": 0, "rules": 0, "strain": 0, "overlap": 0, "existing": 0}, [], reach,
                   OVERLAP_FRACTION * mod.pitch,
                   np.zeros((0, 3)) if avoid is None else np.asarray(avoid, float).reshape(-1, 3),
                   cKDTree(centre) if M else None)


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
    st = _GrowState.start(patch, avoid)
    charts: list[Chart] = []
    queue = [(np.zeros(2), np.asarray(at, float), direction)]
    while queue and len(charts) < max_charts:
        o, a3, d3 = queue.pop(0)
        opened = _open_chart(prepared, a3, d3, first if not charts else None, bool(charts), faces, chart_radius,
                             st.reach + mod.pitch)
        if opened is None:
            continue
        lm, R = opened
        c = len(charts)
        charts.append(Chart(o, lm.at, lm.t1, lm, R))
        d = np.linalg.norm(st.centre - o, axis=1)
        elig = ~st.kept & ~st.gone & (d + st.reach <= R) & (d < st.tried - 1e-9)
        mods = np.flatnonzero(elig)
        mods = mods[np.argsort(d[mods], kind="stable")]
        if not len(mods):
            continue
        ti = taxel_index(st.counts, st.starts, mods)
        mapped = lm.exp(patch.flat[ti] - o, fallback=check is None)
        st.tried[mods] = d[mods]
        keep = np.ones(len(mods), bool)
        if check is not None:
            keep = _judge(st, charts[c], patch, mods, ti, mapped, check, max_strain)
        km = mods[keep]
        if not len(km):
            continue
        _place(st, lm, o, c, km, ti, mapped, mod.pitch)
        if progress is not None:
            # the share of charts done among those known so far (the queue grows as it goes)
            keep_going(progress, min(0.95, len(charts) / (len(charts) + len(queue) + 1)), "the fill")
        _seed_charts(st, lm, o, d, R, km, charts, queue, mod.pitch, min_gain)
    return Growth(st.pos, st.nrm, st.face, st.found, st.chart_of, st.kept, np.zeros(patch.n_modules, bool),
                  st.frames, charts, st.reasons, np.asarray(st.seam_at, float).reshape(-1, 2))


def _open_chart(prepared: PreparedSurface, a3, d3, first: LogMap | None, later: bool, faces, chart_radius,
                min_first: float):
    """``(log map, trusted radius m)`` of a chart at ``a3`` (3,) with x axis ``d3``, or None when a
    later chart's axis lies along the surface normal there. Chart 0 (``later`` False) reuses
    ``first`` if given and always reaches ``min_first`` (it maps the module at ``at``)."""
    if first is not None:
        lm = first
    else:
        try:
            lm = LogMap(None, a3, d3, prepared=prepared)
        except InputError as exc:
            if not later or exc.key != "direction":
                raise
            # the lattice axis carried to this seed lies along the surface normal there (a
            # sliver of a decimated mesh tilts the pushed-forward frame): another seed on the
            # same front maps these modules, so this one is dropped, not the whole fill (modules
            # no other chart reaches stay unplaced and are reported as such)
            return None
    R = lm.trusted_radius(faces=faces)
    if chart_radius is not None:
        R = min(R, chart_radius)
    if not later:
        R = max(R, min_first)  # chart 0 always maps the module at 'at'
    return lm, R


def _judge(st: _GrowState, chart: Chart, patch: Patch, mods, ti, mapped, check, max_strain) -> np.ndarray:
    """``(K,) bool``: which of the chart's modules ``mods`` (nearest first) to keep, for ``fill``:
    whole on the surface, passing ``check``, not over ``max_strain`` (may fit in a nearer chart
    later), not over the skin already there nor a placed module (both for good), not over a module
    of this chart nearer its origin (past a fold). Counts every reason in ``st.reasons``."""
    p_, n_, f_, ok_ = mapped
    counts, gone, reasons = st.counts, st.gone, st.reasons
    keep = np.ones(len(mods), bool)
    tmod = np.repeat(np.arange(len(mods)), counts[mods])
    whole = np.bincount(tmod, weights=ok_, minlength=len(mods)) == counts[mods]
    rules = np.asarray(check(chart, patch, mods, f_, tmod), bool)
    gone[mods[~whole | ~rules]] = True
    reasons["off"] += int((~whole).sum())
    reasons["rules"] += int((whole & ~rules).sum())
    keep &= whole & rules
    if max_strain is not None:
        tp, tn = st.pos.copy(), st.nrm.copy()
        tp[ti], tn[ti] = p_, n_
        strained = keep & (module_strain(patch, tp, tn, mods) > max_strain)  # may fit in a nearer chart
        reasons["strain"] += int(strained.sum())
        keep &= ~strained
    # overlaps with modules already placed (other charts, or the skin there before): for good
    if len(st.avoid) and keep.any():
        hit = cKDTree(st.avoid).query_ball_point(p_, st.min_gap, return_length=True) > 0
        bad = np.bincount(tmod, weights=hit, minlength=len(mods)) > 0
        gone[mods[bad & keep]] = True
        reasons["existing"] += int((bad & keep).sum())
        keep &= ~bad
    placed = st.pos[np.isfinite(st.pos[:, 0])]
    if len(placed) and keep.any():
        hit = cKDTree(placed).query_ball_point(p_, st.min_gap, return_length=True) > 0
        bad = np.bincount(tmod, weights=hit, minlength=len(mods)) > 0
        gone[mods[bad & keep]] = True
        reasons["overlap"] += int((bad & keep).sum())
        st.seam_at.extend(st.centre[mods[bad & keep]].tolist())
        keep &= ~bad
    # overlaps within this chart (past a fold): the module nearer the chart's origin wins
    if keep.sum() > 1:
        kt = keep[tmod]
        pairs = cKDTree(p_[kt]).query_pairs(st.min_gap, output_type="ndarray")
        if len(pairs):
            mt = tmod[kt]
            a, b = mt[pairs[:, 0]], mt[pairs[:, 1]]
            for x, y in sorted({(min(u, v), max(u, v)) for u, v in zip(a, b) if u != v}):
                if keep[x] and keep[y]:  # mods are sorted by distance: y is the farther
                    keep[y] = False
                    gone[mods[y]] = True
                    reasons["overlap"] += 1
    return keep


def _place(st: _GrowState, lm: LogMap, o, c: int, km, ti, mapped, pitch: float) -> None:
    """Write the taxels of the kept modules ``km`` (mapped by chart ``c``, origin ``o`` (2,)) and each
    module's frame on the surface: origin, lattice x axis, normal."""
    p_, n_, f_, ok_ = mapped
    kti = taxel_index(st.counts, st.starts, km)
    sel = np.isin(ti, kti)
    st.pos[ti[sel]], st.nrm[ti[sel]], st.face[ti[sel]], st.found[ti[sel]] = p_[sel], n_[sel], f_[sel], ok_[sel]
    st.kept[km], st.chart_of[km] = True, c
    eps = 0.5 * pitch
    centre = st.centre
    probe = np.concatenate([centre[km], centre[km] + [eps, 0.0], centre[km] - [eps, 0.0]]) - o
    fp, fn, _, _ = lm.exp(probe)
    k = len(km)
    x = fp[k:2 * k] - fp[2 * k:]
    x -= fn[:k] * np.einsum("ij,ij->i", x, fn[:k])[:, None]
    x /= np.maximum(np.linalg.norm(x, axis=1, keepdims=True), 1e-300)
    st.frames[km] = np.stack([fp[:k], x, fn[:k]], axis=1)


def _seed_charts(st: _GrowState, lm: LogMap, o, d, R: float, km, charts: list, queue: list, pitch: float,
                 min_gain: int) -> None:
    """Queue new charts at the frontier of chart ``lm`` (origin ``o``, radius ``R``, flat distance ``d``
    (M,) of every module to ``o``): placed modules (of any chart) next to modules still to try that
    lie on the surface; seeds at least ``spacing`` apart (each chart costs a solve)."""
    centre, kept, status = st.centre, st.kept, st.status
    reach = st.reach
    spacing = max(0.7 * (R - reach), pitch)
    pending = ~kept & ~st.gone
    if not pending.any():
        return
    hood = 2 * reach + pitch
    # a pending module counts once this chart's map, even past its trusted radius, finds its
    # centre on the surface (lattice modules past an open edge would seed charts for nothing)
    near_km = st.ctree.query_ball_point(centre[km], hood)
    test = np.unique(np.concatenate([np.asarray(nb, np.int64) for nb in near_km]))
    test = test[pending[test] & (status[test] < 0)]
    if len(test):
        status[test] = lm.exp(centre[test] - o, fallback=False, on_surface=False)[3].astype(np.int8)
    want = pending & (status == 1)
    if not want.any():
        return
    # seeds: the centres of wanted modules inside this chart's trusted disc (a chart there maps
    # the module whole), else placed modules next to wanted ones; apart in the lattice (flat)
    # and on the surface (3-D: round a closed link the lattice goes on, the surface does not)
    inner = np.flatnonzero(want & (d <= R - 0.5 * pitch))
    inner = inner[np.argsort(-d[inner], kind="stable")]  # farthest first: fewer charts
    near_want = cKDTree(centre[want]).query_ball_point(centre[kept], hood, return_length=True) > 0
    front = np.flatnonzero(kept)[near_want]
    front = front[np.argsort(np.linalg.norm(centre[front], axis=1), kind="stable")]
    cand = np.concatenate([inner, front])
    if not len(cand):
        return
    eps = 0.5 * pitch
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
        p3, x3 = (st.frames[m, 0], st.frames[m, 1]) if src[t] else (fp[t], x[t])
        if all(np.linalg.norm(centre[m] - q2) >= spacing and np.linalg.norm(p3 - q3) >= 0.5 * spacing
               for q2, q3 in origins):
            queue.append((centre[m].copy(), p3, x3))
            origins.append((centre[m], p3))


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
    if not len(growth.seam_at):
        return np.zeros((0, 3)), np.zeros(0, np.int64)
    placed = growth.positions[np.isfinite(growth.positions[:, 0])]
    if avoid is not None and len(avoid):
        placed = np.concatenate([placed, np.asarray(avoid, float).reshape(-1, 3)])
    # the taxels there before the pass in one k-d tree, built once (it was rebuilt for every chart and
    # shift, and for every module added: 4 of the 10,000-module fill's CPU seconds); the pass's own
    # modules, a few hundred, are searched apart
    trees = {"placed": cKDTree(placed) if len(placed) else None, "added": []}
    out_poses, out_chart = [], []
    seam_tree = cKDTree(growth.seam_at)
    for c, ch in enumerate(growth.charts):
        for shift in shifts:
            cand = lattice(shift, ch.origin, ch.radius)
            if not cand.n_modules:
                continue
            mod = cand.module
            d = np.linalg.norm(cand.poses[:, 1:] - ch.origin, axis=1)
            # only at the seam: within two module radii of a module dropped there
            at_seam = seam_tree.query_ball_point(cand.poses[:, 1:], 2 * mod.radius, return_length=True) > 0
            reach = float(np.linalg.norm(mod.taxels, axis=1).max()) + 0.5 * mod.pitch
            cand = cand.select_modules((d + reach <= ch.radius) & at_seam)
            if not cand.n_modules:
                continue
            for _m, pose in _seam_modules(ch, cand, check, max_strain, trees, OVERLAP_FRACTION * mod.pitch):
                out_poses.append(pose)
                out_chart.append(c)
    return np.array(out_poses).reshape(-1, 3), np.array(out_chart, np.int64)


def _overlapping(trees: dict, pts: np.ndarray, min_gap: float, since: int = 0) -> np.ndarray:
    """(n,) bool: which of ``pts`` (n, 3) come within ``min_gap`` of a taxel placed before the seam
    pass (``since`` 0) or of one the pass added (its modules from number ``since`` on)."""
    hit = np.zeros(len(pts), bool)
    if since == 0 and trees["placed"] is not None:
        hit |= trees["placed"].query_ball_point(pts, min_gap, return_length=True) > 0
    added = trees["added"][since:]
    if added:
        hit |= cKDTree(np.concatenate(added)).query_ball_point(pts, min_gap, return_length=True) > 0
    return hit


def _seam_modules(ch: Chart, cand: Patch, check, max_strain: float, trees: dict, min_gap: float):
    """The modules of ``cand`` (one shifted lattice near the seam, in chart ``ch``) the seam pass adds,
    as ``(module, pose (3,))`` nearest the chart's origin first; their taxels join ``trees["added"]``.
    Every taxel is located on the solve mesh first; only the modules found whole are moved to the
    full-resolution surface (the same points :meth:`LogMap.exp` would give them, point by point)."""
    d = np.linalg.norm(cand.poses[:, 1:] - ch.origin, axis=1)
    p_, n_, f_, ok_ = ch.logmap.exp(cand.flat - ch.origin, fallback=False, on_surface=False)
    tmod, M = cand.module_ids, cand.n_modules
    keep = np.bincount(tmod, weights=ok_, minlength=M) == np.bincount(tmod, minlength=M)
    t = keep[tmod]
    p_[t], n_[t] = ch.logmap.to_surface(p_[t], n_[t])
    n_added = len(trees["added"])
    if keep.any():
        keep &= np.bincount(tmod, weights=_overlapping(trees, p_, min_gap) & t, minlength=M) == 0
    idx = np.flatnonzero(keep)
    if not len(idx):
        return []
    keep[idx] &= module_strain(cand, p_, n_, idx) <= max_strain
    idx = np.flatnonzero(keep)
    if not len(idx):
        return []
    tsel = np.isin(tmod, idx)
    keep[idx] &= np.asarray(check(ch, cand, idx, f_[tsel], np.searchsorted(idx, tmod[tsel])), bool)
    # greedy, nearest the chart origin first, against each other (all of them passed the taxels there
    # before this lattice: only the modules added since count)
    out = []
    for m in np.flatnonzero(keep)[np.argsort(d[keep], kind="stable")]:
        pm = p_[tmod == m]
        if _overlapping(trees, pm, min_gap, since=n_added).any():
            continue
        trees["added"].append(pm)
        out.append((m, cand.poses[m]))
    return out


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
