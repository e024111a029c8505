"""Flat patches of modules: one triangle, the hexagon of 6, a strip of N, a tiling of a region.

A :class:`Patch` lives in the flat (unrolled) domain of a flexible PCB: every
taxel has flat coordinates in metres, a module and a sensor number. Placing it
on a surface (:mod:`vtcore.layout.conform`) turns it into a
:class:`~vtcore.layout.Layout`.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..errors import InputError
from ..tolerances import LENGTH_TOL
from .model import Layout
from .modules import PITCH, ModuleType, get_module, taxel_uids


@dataclass
class Patch:
    """Modules laid out in the flat domain.

    module : the :class:`ModuleType` of every module.
    poses : (M, 3) float, per module ``(angle_rad, x, y)``: rotation of the module
        frame and position of its origin, metres.
    flat : (N, 2) float, metres, taxel centres (module-major order).
    module_ids : (N,) int, 0-based module index. sensors : (N,) int.
    roles : (N,) str. kind : "triangle", "hexagon", "strip:N", "fill".
    """

    module: ModuleType
    poses: np.ndarray
    flat: np.ndarray
    module_ids: np.ndarray
    sensors: np.ndarray
    roles: np.ndarray
    kind: str = ""
    meta: dict = field(default_factory=dict)

    def __len__(self) -> int:
        return len(self.flat)

    @property
    def n_modules(self) -> int:
        return len(self.poses)

    @property
    def taxel_ids(self) -> np.ndarray:
        return taxel_uids(self.module, self.module_ids, self.sensors)

    @property
    def module_edges(self) -> np.ndarray:
        """(E, 2) int, taxel index pairs of every module's own graph (the edges whose strain counts)."""
        counts = np.bincount(self.module_ids, minlength=self.n_modules)
        starts = np.concatenate([[0], np.cumsum(counts)[:-1]])
        e = self.module.edges
        # modules may have lost taxels (subset); only keep edges of modules that are complete
        full = np.flatnonzero(counts == len(self.module))
        return (starts[full, None, None] + e[None]).reshape(-1, 2)

    def outlines(self) -> np.ndarray:
        """(M, m, 2) metres: every module's outline in the flat domain."""
        return np.stack([self.module.placed_outline(a, (x, y)) for a, x, y in self.poses]) \
            if len(self.poses) else np.zeros((0, len(self.module.outline), 2))

    def centred(self) -> "Patch":
        """The patch translated so that the mean of its taxels is the origin."""
        c = self.flat.mean(axis=0)
        poses = self.poses.copy()
        poses[:, 1:] -= c
        return Patch(self.module, poses, self.flat - c, self.module_ids, self.sensors, self.roles,
                     self.kind, dict(self.meta))

    def select_modules(self, keep) -> "Patch":
        """The patch with only the modules where ``keep`` (M,) is true, renumbered 0..M'-1."""
        keep = np.asarray(keep, dtype=bool)
        new = np.cumsum(keep) - 1
        t = keep[self.module_ids]
        return Patch(self.module, self.poses[keep], self.flat[t], new[self.module_ids[t]],
                     self.sensors[t], self.roles[t], self.kind, dict(self.meta))

    def flat_layout(self, z: float = 0.0) -> Layout:
        """The patch lying in the plane ``z`` with normals +z (the flat end-effector case)."""
        pos = np.column_stack([self.flat, np.full(len(self), z)])
        nrm = np.tile([0.0, 0.0, 1.0], (len(self), 1))
        return self.to_layout(pos, nrm)

    def to_layout(self, positions, normals, meta: dict | None = None) -> Layout:
        # id_scheme lets a writer number iCub taxels by slot whatever the module's name;
        # module_mirror says the modules are mirror images (skinGui's mirror column)
        m = {"module_type": self.module.name, "module_mirror": bool(self.module.mirrored),
             "id_scheme": self.module.id_scheme, "patch": self.kind, "pitch_m": self.module.pitch,
             "module_poses": self.poses.tolist(), **self.meta, **(meta or {})}
        return Layout(positions, normals, self.taxel_ids, self.module_ids, flat=self.flat.copy(),
                      roles=self.roles.copy(), meta=m)


def patch_from_poses(module: str | ModuleType, poses, kind: str = "", extra: dict | None = None,
                     shared_sites: bool = True) -> Patch:
    """Place copies of ``module`` at ``poses`` (M, 3) ``(angle, x, y)`` in the flat domain.

    ``shared_sites=False``: the caller knows no two taxels of different modules coincide (poses of
    the module type's own tiling when :func:`tiling_shares_sites` says so): the search is skipped."""
    mod = get_module(module)
    poses = np.asarray(poses, dtype=np.float64).reshape(-1, 3)
    k = len(mod)
    if len(poses):
        c, s = np.cos(poses[:, 0]), np.sin(poses[:, 0])
        rot = np.stack([np.stack([c, -s], -1), np.stack([s, c], -1)], -2)  # (M, 2, 2)
        flat = (np.einsum("mij,kj->mki", rot, mod.taxels) + poses[:, None, 1:]).reshape(-1, 2)
    else:
        flat = np.zeros((0, 2))
    m = len(poses)
    mids, sensors, roles = np.repeat(np.arange(m), k), np.tile(mod.sensors, m), np.tile(mod.roles, m)
    meta = dict(extra or {})
    if shared_sites and len(flat) > 1:
        # sites shared by two modules (the hub-side taxel of cyskin11 is another module's corner
        # or the hexagon centre) are taxels of the first module only
        pairs = coincident_pairs(flat, LENGTH_TOL)
        if len(pairs):
            drop = np.zeros(len(flat), bool)
            drop[pairs.max(axis=1)] = True
            flat, mids, sensors, roles = flat[~drop], mids[~drop], sensors[~drop], roles[~drop]
            meta["shared_sites_dropped"] = int(drop.sum())
    return Patch(mod, poses, flat, mids, sensors, roles, kind, meta)


def coincident_pairs(points: np.ndarray, tol: float) -> np.ndarray:
    """(P, 2) int64 index pairs ``i < j`` of ``points`` (n, 2) metres at most ``tol`` apart: the pairs
    ``cKDTree.query_pairs(tol)`` finds (in another order), for a ``tol`` far below the spacing.

    A fill's lattice has ~10^5-10^6 taxels and no or few coincident ones; a k-d tree of them took
    ~0.3 s of CPU at 800k taxels (a 10,000-module fill builds ~85 lattices), this ~0.1 s. Here: one sort
    of the points' cells on a grid of ``h = 1000 tol`` (a pair within ``tol`` lies in one cell, or
    straddles a cell border with both points within ``tol`` of it), and a k-d tree of the few points
    that near a border."""
    pts = np.asarray(points, dtype=np.float64).reshape(-1, 2)
    h = 1000.0 * tol
    bound = float(np.abs(pts).max()) if len(pts) else 0.0  # nan or inf too: the plain way
    if tol <= 0 or not bound < 2.0 ** 30 * h:
        from scipy.spatial import cKDTree  # non-finite or huge coordinates: the plain way

        return cKDTree(pts).query_pairs(tol, output_type="ndarray")
    g = pts / h
    cell = np.floor(g)
    c = cell.astype(np.int64)
    key = c[:, 0] * (2 ** 32) + c[:, 1]
    order = np.argsort(key)
    ks = key[order]
    out = []
    k = 1
    while k < len(ks):  # runs of equal cells: every pair in a run, one offset at a time
        same = ks[k:] == ks[:-k]
        if not same.any():
            break
        out.append(np.column_stack([order[:-k][same], order[k:][same]]))
        k += 1
    frac = g - cell
    near = (frac < tol / h) | (frac > 1.0 - tol / h)
    edge = np.flatnonzero(near[:, 0] | near[:, 1])
    if len(edge) > 1:
        from scipy.spatial import cKDTree

        e = cKDTree(pts[edge]).query_pairs(tol, output_type="ndarray")
        out.append(edge[e])
    if not out:
        return np.zeros((0, 2), np.int64)
    p = np.sort(np.concatenate(out), axis=1)
    p = np.unique(p[:, 0] * len(pts) + p[:, 1])
    p = np.column_stack([p // len(pts), p % len(pts)])
    return p[np.linalg.norm(pts[p[:, 0]] - pts[p[:, 1]], axis=1) <= tol]


_TILINGS_SHARING: dict = {}  #: module type's tiling (bytes) -> whether its modules share taxel sites


def tiling_shares_sites(module: ModuleType) -> bool:
    """Whether two modules of ``module``'s plane tiling (:func:`tile_poses`, any turn and shift of it)
    can share a taxel site (cyskin11's hub-side taxel): False when the closest two taxels of different
    modules of a piece of the tiling are farther apart than a thousand times the tolerance, so that no
    rounding of a turned or shifted copy brings them within it (cyskin10, iCub's)."""
    key = b"".join(np.ascontiguousarray(a, np.float64).tobytes() for a in
                   (module.taxels, np.array([[a, *c] for a, c in module.strip]), module.strip_period, module.fill_row))
    if key not in _TILINGS_SHARING:
        r = 4 * module.radius
        p = patch_from_poses(module, tile_poses(module, [-r, -r], [r, r]))
        from scipy.spatial import cKDTree

        close = cKDTree(p.flat).query_pairs(1000 * LENGTH_TOL, output_type="ndarray")
        _TILINGS_SHARING[key] = bool(len(close) or p.meta.get("shared_sites_dropped"))
    return _TILINGS_SHARING[key]


def strip_poses(module: ModuleType, n: int) -> np.ndarray:
    """(n, 3) poses of a strip of ``n`` modules alternating as the module type's strip says."""
    per = len(module.strip)
    idx = np.arange(n)
    base = np.array([[a, *c] for a, c in module.strip])
    out = base[idx % per].copy()
    out[:, 1:] += (idx // per)[:, None] * module.strip_period
    return out


def tile_poses(module: ModuleType, lo, hi) -> np.ndarray:
    """Poses of the module type's plane tiling whose origins fall in the box ``lo..hi`` (2,) metres,
    with a margin of one module radius so that a region test can decide at the edges."""
    lo = np.asarray(lo, float) - module.radius
    hi = np.asarray(hi, float) + module.radius
    period, row = module.strip_period, module.fill_row
    basis = np.column_stack([period, row])
    corners = np.array([[lo[0], lo[1]], [hi[0], lo[1]], [lo[0], hi[1]], [hi[0], hi[1]]])
    uv = np.linalg.solve(basis, corners.T).T
    umin, vmin = np.floor(uv.min(axis=0)) - 1
    umax, vmax = np.ceil(uv.max(axis=0)) + 1
    u, v = np.meshgrid(np.arange(umin, umax + 1), np.arange(vmin, vmax + 1), indexing="ij")
    cells = np.column_stack([u.ravel(), v.ravel()]) @ basis.T  # (C, 2)
    base = np.array([[a, *c] for a, c in module.strip])  # (P, 3)
    poses = np.repeat(base[None], len(cells), axis=0)
    poses[:, :, 1:] += cells[:, None, :]
    poses = poses.reshape(-1, 3)
    inside = np.all((poses[:, 1:] >= lo) & (poses[:, 1:] <= hi), axis=1)
    return poses[inside]


def fill_patch(module: str | ModuleType, inside, lo, hi, *, angles=(0.0, np.pi / 6, np.pi / 3, np.pi / 2),
               offsets: int = 4, shift=None) -> Patch:
    """Tile a flat region with whole modules, no overlap (the module type's plane tiling).

    inside : callable ``(n, 2) metres -> (n,) bool``, the region in the flat domain.
    lo, hi : (2,) metres, a box that contains the region.
    The tiling is tried at each of ``angles`` and ``offsets x offsets`` shifts
    within one tiling cell; the one that keeps the most whole modules wins (ties:
    the first). shift : (2,) fractions of a tiling cell: try only that shift instead.
    Returns the patch with only the modules whose every taxel is inside.
    """
    mod = get_module(module)
    lo, hi = np.asarray(lo, float), np.asarray(hi, float)
    centre = (lo + hi) / 2
    half = np.max(hi - lo) * 0.75
    base = tile_poses(mod, -np.full(2, half), np.full(2, half))
    best, best_n = None, -1
    steps = np.arange(offsets) / max(offsets, 1)
    shifts = [tuple(map(float, shift))] if shift is not None else [(fu, fv) for fu in steps for fv in steps]
    for ang in angles:
        c, s = np.cos(ang), np.sin(ang)
        rot = np.array([[c, -s], [s, c]])
        for fu, fv in shifts:
            d = fu * mod.strip_period + fv * mod.fill_row
            poses = base.copy()
            poses[:, 0] += ang
            poses[:, 1:] = (poses[:, 1:] + d) @ rot.T + centre
            p = patch_from_poses(mod, poses, "fill")
            ok = np.asarray(inside(p.flat), dtype=bool)
            whole = np.bincount(p.module_ids, weights=ok, minlength=p.n_modules) == len(mod)
            if whole.sum() > best_n:
                best, best_n = p.select_modules(whole), int(whole.sum())
    best.meta["fill_candidates"] = len(angles) * len(shifts)
    return best


def make_patch(kind: str, module: str | ModuleType = "cyskin10", *, center: bool = False,
               mirror: bool = False) -> Patch:
    """A flat patch: ``"triangle"``, ``"hexagon"`` or ``"strip:N"``.

    ``mirror=True`` builds it of mirror-image modules (skinGui's ``mirror`` column, see
    :meth:`~vtcore.layout.modules.ModuleType.mirror`): the mirror image of the whole patch.

    ``center=True`` adds the taxel at the centre of a CySkin hexagon to module 0
    (real planar hexagons have 61 taxels; seed 001 uses 60 and excludes it).
    The patch is centred on the mean of its taxels except the hexagon, which is
    centred on its centre site.
    """
    mod = get_module(module, mirror=mirror)
    kind = str(kind).strip()
    if kind == "triangle":
        return patch_from_poses(mod, [[0.0, 0.0, 0.0]], "triangle")
    if kind == "hexagon":
        p = patch_from_poses(mod, [[a, *c] for a, c in mod.hexagon], "hexagon")
        if center:
            p = Patch(mod, p.poses, np.vstack([np.zeros((1, 2)), p.flat]),
                      np.concatenate([[0], p.module_ids]),
                      np.concatenate([[len(mod) + 1], p.sensors]),
                      np.concatenate([np.array(["pressure"], dtype=object), p.roles]), "hexagon",
                      {"center_taxel": True})
        return p
    if kind.startswith("strip"):
        try:
            n = int(kind.split(":", 1)[1])
        except (IndexError, ValueError):
            raise InputError(f"strip patches are written 'strip:N' with N >= 1 modules, got {kind!r}",
                             key="patch") from None
        if n < 1:
            raise InputError(f"a strip needs at least one module, got {kind!r}", key="patch")
        return patch_from_poses(mod, strip_poses(mod, n), f"strip:{n}").centred()
    raise InputError(f"unknown patch {kind!r}; use triangle, hexagon, strip:N or fill", key="patch")


def hexagon_flat(pitch: float = PITCH, rings: int = 4) -> tuple[np.ndarray, np.ndarray]:
    """Flat hexagonal CySkin patch of seed 001 (kept for older callers).

    Returns ``flat (60, 2)`` metres and ``module_ids (60,)``: the 61 sites of a
    hexagonal lattice of radius 4 at ``pitch`` without the centre, 6 modules of 10.
    """
    if rings != 4:
        raise InputError(f"the CySkin hexagon has 4 rings, got {rings}", key="rings")
    p = make_patch("hexagon", "cyskin10")
    scale = pitch / PITCH
    return p.flat * scale, p.module_ids.copy()


def wrap_on_sphere(flat: np.ndarray, radius: float) -> tuple[np.ndarray, np.ndarray]:
    """Wrap flat patch coordinates onto a sphere cap without stretching radial lines.

    The azimuthal-equidistant map (the sphere's exponential map at its pole)
    keeps geodesic distance and direction from the patch centre. The sphere's
    pole sits at the origin with outward normal +z (centre at ``(0, 0, -radius)``).

    flat : (N, 2) metres. radius : metres (``inf`` gives a plane).
    Returns positions (N, 3) metres and unit normals (N, 3).
    """
    flat = np.asarray(flat, dtype=np.float64)
    if not np.isfinite(radius):
        pos = np.column_stack([flat, np.zeros(len(flat))])
        return pos, np.tile([0.0, 0.0, 1.0], (len(flat), 1))
    r = np.hypot(flat[:, 0], flat[:, 1])
    theta = r / radius
    phi = np.arctan2(flat[:, 1], flat[:, 0])
    normals = np.column_stack([np.sin(theta) * np.cos(phi), np.sin(theta) * np.sin(phi), np.cos(theta)])
    positions = radius * normals - np.array([0.0, 0.0, radius])
    return positions, normals
