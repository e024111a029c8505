"""The fill's lattice: the module type's plane tiling turned and shifted (:func:`lattice_patch`, bounded
by :data:`MAX_CANDIDATES`), the shift that centres it (:func:`centred_shift`), and which of its modules
cover given points (:func:`modules_covering`). Split from :mod:`.tiling`, which grows the lattice over a
surface, so that each reads in one sitting."""

from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

from ..errors import InputError
from .patches import Patch, patch_from_poses, tile_poses, tiling_shares_sites

MAX_CANDIDATES = 2_000_000  #: lattice modules a fill may consider (each ~10 taxels): ~1 GB of work arrays


_HULLS: dict = {}  #: taxel positions (bytes) -> their hull: qhull took a fifth of a fill's tiling tries


def taxel_hull(mod) -> np.ndarray:
    """(h, 2) metres, counter-clockwise: the convex hull of a module's taxel centres (the part of
    the board that must lie on one smooth piece of surface; the margin round it may overhang)."""
    from scipy.spatial import ConvexHull

    key = np.ascontiguousarray(mod.taxels).tobytes()
    if key not in _HULLS:
        _HULLS[key] = mod.taxels[ConvexHull(mod.taxels).vertices]
    return _HULLS[key]


def modules_covering(points: np.ndarray, patch: Patch, modules: np.ndarray, origin: np.ndarray) -> np.ndarray:
    """(len(modules),) bool: which of ``modules`` of ``patch`` hold one of the flat ``points``
    (n, 2) inside the hull of their taxels; points in the frame of a chart whose origin is
    ``origin`` (2,) in the patch's frame."""
    out = np.zeros(len(modules), bool)
    if not len(points) or not len(modules):
        return out
    mod = patch.module
    cen = patch.poses[modules, 1:] - origin
    rows, idx = _within(cen, points, float(np.linalg.norm(mod.taxels, axis=1).max()))
    if not len(rows):
        return out
    pts = points[idx]
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


def _within(centres: np.ndarray, points: np.ndarray, radius: float) -> tuple[np.ndarray, np.ndarray]:
    """``(rows, points)`` int arrays: every (centre, point) pair of ``centres`` (K, 2) and ``points``
    (n, 2) at most ``radius`` apart, and a few a hair farther (callers test each pair exactly). The
    k nearest centres of each point, k doubling until the farthest is past the radius: the centres
    (modules that do not overlap) are few round a point; ``query_ball_point``'s lists of lists
    took 2 s of a 10,000-module fill."""
    if not len(centres) or not len(points):
        return np.zeros(0, np.int64), np.zeros(0, np.int64)
    bound = radius * (1 + 1e-9) + 1e-12  # inclusive, as query_ball_point: the pairs' own test decides
    tree, k = cKDTree(centres), min(4, len(centres))
    while True:
        d, ms = tree.query(points, k=k, distance_upper_bound=bound)
        d, ms = d.reshape(len(points), -1), ms.reshape(len(points), -1)
        if k >= len(centres) or not np.isfinite(d[:, -1]).any():
            break
        k = min(2 * k, len(centres))
    pt, j = np.nonzero(np.isfinite(d))
    return ms[pt, j], pt


def lattice_patch(mod, angle: float, shift, centre, rad: float, limit: float | None = None) -> Patch:
    """The fill lattice's modules (a Patch in the lattice's flat frame) with origins within
    ``rad`` metres of ``centre`` (2,): the module type's plane tiling turned by ``angle`` and
    shifted by ``shift`` (2,) fractions of a tiling cell; ``limit``: only modules whose taxels are
    all within this distance of the lattice origin. Raises InputError, naming the size, before building
    more than MAX_CANDIDATES modules."""
    if not np.isfinite(rad):  # every size the fill asks for is bounded by its region: this is a bug, said once
        raise InputError(f"the fill's lattice was asked for a region of unbounded size ({rad}); give a radius "
                         "or a smaller region, and report the mesh and the start point", key="region")
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
    # the tiling's own poses: no shared site to search for unless the module type's tiling has some
    # (the search over a lattice of 10^6 taxels cost ~50 ms, 85 lattices in a 10,000-module fill)
    p = patch_from_poses(mod, poses[keep], "fill", shared_sites=tiling_shares_sites(mod))
    if limit is not None and p.n_modules:
        # every taxel within the limit: a module at the rim whose far taxels point along it fits
        far = np.zeros(p.n_modules)
        np.maximum.at(far, p.module_ids, np.linalg.norm(p.flat, axis=1))
        p = p.select_modules(far <= limit)
    return p


def centred_shift(mod, angle: float) -> tuple[float, float]:
    """The lattice shift (fractions of a tiling cell) that puts the middle of the bounding box of the
    taxels of the module nearest the lattice origin (in the lattice's turned frame) on the origin:
    the module then lies centred on the start, across a strip in either axis."""
    near = lattice_patch(mod, angle, (0.0, 0.0), np.zeros(2), 4 * mod.radius)
    if not near.n_modules:
        return 0.0, 0.0
    i = int(np.argmin(np.linalg.norm(near.poses[:, 1:], axis=1)))
    t = near.flat[near.module_ids == i]
    mid = (t.min(axis=0) + t.max(axis=0)) / 2
    c, s = np.cos(angle), np.sin(angle)
    frac = np.linalg.solve(np.column_stack([mod.strip_period, mod.fill_row]), -np.array([[c, s], [-s, c]]) @ mid)
    return float(frac[0]), float(frac[1])
