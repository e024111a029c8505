"""Where a design map is evaluated: points spread evenly over the skin-covered surface and a margin.

:func:`sample_surface` spreads low-discrepancy points over every face of the mesh near the skin
(as many per face as its area asks, at least one, so long CAD slivers are covered like small
faces), keeps those within ``cover + margin`` of a taxel, and merges them into one sample per
``spacing``-sized voxel and normal direction (so the two faces of a thin part stay apart). Each
sample carries the area of the points it merged: areas add up to the evaluated surface exactly.
:func:`vertex_samples` hands each mesh vertex the value of its nearest sample on the same side.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import InputError
from ..layout.modules import PITCH

#: cosine below which a taxel faces away from a surface point (about 105 degrees)
FACING_AWAY = -0.25
#: Points a sampling may spread before merging (memory: ~100 bytes each).
MAX_POINTS = 8_000_000
#: R2 low-discrepancy sequence constants (Roberts 2018): even cover of a face with few points.
_G = 1.32471795724474602596
_A1, _A2 = 1.0 / _G, 1.0 / _G ** 2


def cover_radius(pitch: float = PITCH) -> float:
    """Distance from a taxel within which the skin covers the surface, metres: the circumradius of the
    lattice triangle (pitch / sqrt 3), so every point inside a module lattice is covered."""
    return float(pitch / np.sqrt(3.0) * 1.05)


@dataclass
class SurfaceSamples:
    """Evaluation points on a mesh.

    positions, normals : (M, 3) m / unit. areas : (M,) m^2 (sum = evaluated area). distance : (M,) m to
    the nearest taxel. covered : (M,) bool, within ``cover`` of a taxel. spacing, cover, margin : m.
    """

    positions: np.ndarray
    normals: np.ndarray
    areas: np.ndarray
    distance: np.ndarray
    covered: np.ndarray
    spacing: float
    cover: float
    margin: float

    def __len__(self) -> int:
        return len(self.positions)


def _face_points(tri: np.ndarray, counts: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``counts[f]`` points inside each triangle ``tri (F, 3, 3)`` (R2 sequence folded into the
    triangle): (points (P, 3), owning face (P,))."""
    owner = np.repeat(np.arange(len(tri)), counts)
    start = np.repeat(np.cumsum(counts) - counts, counts)
    i = np.arange(len(owner)) - start
    u = np.mod(0.5 + i * _A1, 1.0)
    v = np.mod(0.5 + i * _A2, 1.0)
    flip = u + v > 1
    u[flip], v[flip] = 1 - u[flip], 1 - v[flip]
    single = counts[owner] == 1  # one point: the centroid
    u[single], v[single] = 1 / 3, 1 / 3
    t = tri[owner]
    return t[:, 0] + u[:, None] * (t[:, 1] - t[:, 0]) + v[:, None] * (t[:, 2] - t[:, 0]), owner


def sample_surface(mesh, taxels: np.ndarray, taxel_normals: np.ndarray | None = None, *, spacing: float = 2e-3,
                   margin: float = 10e-3, cover: float | None = None) -> SurfaceSamples:
    """Samples every ``spacing`` metres over the surface of ``mesh`` within ``cover + margin`` of a taxel.

    mesh : trimesh.Trimesh, metres (any triangulation: slivers, duplicates and non-manifold edges are
    fine, degenerate faces are skipped). taxels, taxel_normals : (N, 3) m and unit, the live taxels.
    cover : m, default :func:`cover_radius`. With normals, a point counts only near taxels that do not
    face away from it (normals more than ~105 degrees apart): the margin runs round an edge onto a
    link's side, not through a thin part onto its far face. Raises InputError when nothing of the mesh is near the skin or the
    spacing would spread more than :data:`MAX_POINTS` points.
    """
    from scipy.spatial import cKDTree

    spacing, margin = float(spacing), float(margin)
    if not (np.isfinite(spacing) and spacing > 0):
        raise InputError(f"must be > 0 m, got {spacing}", key="spacing")
    if not (np.isfinite(margin) and margin >= 0):
        raise InputError(f"must be >= 0 m, got {margin}", key="margin")
    cover = cover_radius() if cover is None else float(cover)
    taxels = np.asarray(taxels, float).reshape(-1, 3)
    taxel_normals = None if taxel_normals is None else np.asarray(taxel_normals, float).reshape(-1, 3)
    if not len(taxels):
        raise InputError("the skin has no live taxels", key="layout")
    tree = cKDTree(taxels)
    reach = cover + margin
    tri, area2, nrm = _faces_near(mesh, tree, reach)
    # 2 per spacing^2 of area, counted in floating point first (a spacing of 1e-320 is infinitely many
    # points, 1e308 squared overflowed)
    with np.errstate(over="ignore"):   # infinitely many is refused just below
        per_face = np.maximum(1.0, np.ceil(area2 / spacing / spacing))
    total = float(per_face.sum())
    if not total <= MAX_POINTS:
        raise InputError(f"{total:,.3g} points at a {spacing * 1e3:g} mm spacing exceed {MAX_POINTS:,}: "
                         "use a larger spacing or a smaller margin", key="spacing")
    counts = per_face.astype(np.int64)
    pts, owner = _face_points(tri, counts)
    w = (0.5 * area2 / counts)[owner]
    d_pt, _ = tree.query(pts)
    inside = d_pt <= reach
    pts, owner, w = pts[inside], owner[inside], w[inside]
    n_pt = nrm[owner]
    if taxel_normals is not None and len(pts):
        keep_pt = _facing_the_skin(tree, taxel_normals, pts, n_pt, reach)
        pts, owner, w, n_pt = pts[keep_pt], owner[keep_pt], w[keep_pt], n_pt[keep_pt]
    if not len(pts):
        raise InputError(f"no surface within {reach * 1e3:.3g} mm of a taxel faces the skin's side", key="mesh")
    pos, normals, wsum = _merge_per_voxel(pts, n_pt, w, spacing)
    dist, _ = tree.query(pos)
    return SurfaceSamples(pos, normals, wsum, dist, dist <= cover, spacing, cover, margin)


def _faces_near(mesh, tree, reach: float):
    """The faces of ``mesh`` that may hold a point within ``reach`` m of a taxel (``tree``, a KD-tree of
    the taxels), degenerate ones left out: ``(triangles (F, 3, 3), twice their area (F,), unit normals
    (F, 3))``."""
    V = np.asarray(mesh.vertices, float)
    F = np.asarray(mesh.faces, np.int64)
    tri = V[F]
    cross = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    area2 = np.linalg.norm(cross, axis=1)
    centre = tri.mean(axis=1)
    rad = np.linalg.norm(tri - centre[:, None], axis=2).max(axis=1)
    d_face, _ = tree.query(centre)
    keep = (area2 > 1e-18 * max(float(area2.max(initial=0.0)), 1e-300)) & (d_face - rad <= reach)
    if not keep.any():
        raise InputError(f"no face of the mesh lies within {reach * 1e3:.3g} mm of a taxel: is the layout on "
                         "this mesh, in the same frame and units?", key="mesh")
    return tri[keep], area2[keep], cross[keep] / area2[keep, None]


def _facing_the_skin(tree, taxel_normals: np.ndarray, pts: np.ndarray, n_pt: np.ndarray, reach: float) -> np.ndarray:
    """``(P,) bool``: points (normals ``n_pt``) within ``reach`` of a taxel (of its 16 nearest) whose
    normal does not face away from theirs."""
    kk = min(16, tree.n)
    d_k, i_k = tree.query(pts, k=kk, distance_upper_bound=reach)
    d_k, i_k = d_k.reshape(len(pts), kk), i_k.reshape(len(pts), kk)
    ok = i_k < tree.n
    facing = np.einsum("pkc,pc->pk", taxel_normals[np.where(ok, i_k, 0)], n_pt) > FACING_AWAY
    return (ok & facing).any(axis=1)


def _merge_per_voxel(pts: np.ndarray, n_pt: np.ndarray, w: np.ndarray, spacing: float):
    """Merge the points per ``spacing`` voxel and per dominant normal direction (6 classes, so that
    opposite faces stay apart): ``(positions (S, 3), unit normals (S, 3), area (S,) m^2)``; a sample
    is the merged point nearest the voxel's weighted mean (it lies on the surface)."""
    vox = np.floor(pts / spacing).astype(np.int64)
    ax = np.argmax(np.abs(n_pt), axis=1)
    side = ax * 2 + (n_pt[np.arange(len(ax)), ax] > 0)
    key = np.column_stack([vox, side])
    _, inv = np.unique(key, axis=0, return_inverse=True)
    inv = inv.reshape(-1)
    m = int(inv.max()) + 1
    wsum = np.bincount(inv, w, m)
    mean = np.column_stack([np.bincount(inv, w * pts[:, c], m) for c in range(3)]) / wsum[:, None]
    nsum = np.column_stack([np.bincount(inv, w * n_pt[:, c], m) for c in range(3)])
    off = np.linalg.norm(pts - mean[inv], axis=1)
    order = np.lexsort((off, inv))
    first = order[np.r_[True, inv[order][1:] != inv[order][:-1]]]
    pos = pts[first]
    nn = np.linalg.norm(nsum, axis=1, keepdims=True)
    normals = np.where(nn > 1e-12, nsum / np.maximum(nn, 1e-300), n_pt[first])
    return pos, normals, wsum


def vertex_samples(samples: SurfaceSamples, vertices: np.ndarray, vertex_normals: np.ndarray,
                   k: int = 4) -> tuple[np.ndarray, np.ndarray]:
    """For each mesh vertex (V, 3), the sample whose value it shows: ``(index (V,), evaluated (V,) bool)``.

    The nearest of the ``k`` nearest samples whose normal agrees with the vertex's (same side of a thin
    part); a vertex farther than 1.5 spacings from every sample is not evaluated (index 0, flag False).
    """
    from scipy.spatial import cKDTree

    vertices = np.asarray(vertices, float).reshape(-1, 3)
    k = max(1, min(int(k), len(samples)))
    d, idx = cKDTree(samples.positions).query(vertices, k=k)
    d, idx = d.reshape(len(vertices), k), idx.reshape(len(vertices), k)
    agree = np.einsum("vkc,vc->vk", samples.normals[idx], np.asarray(vertex_normals, float)) > 0
    pick = np.where(agree.any(axis=1), np.argmax(agree, axis=1), 0)
    rows = np.arange(len(vertices))
    out, dist = idx[rows, pick], d[rows, pick]
    ok = dist <= 1.5 * samples.spacing * np.sqrt(3)
    return np.where(ok, out, 0), ok


#: below this curvature (1/m: a radius of 0.5 m) a surface has no direction a finger would follow
FLAT_CURVATURE = 2.0


def flattest_directions(points: np.ndarray, normals: np.ndarray, k: int = 12) -> np.ndarray:
    """(M, 3) unit tangent of least curvature at each point (a cylinder's axis), NaN where the surface
    is flat (both curvatures under :data:`FLAT_CURVATURE`) or curves alike every way (the smaller over
    the larger above 0.8: a sphere): there a finger has no preferred direction.

    The shape operator is fitted per point by least squares to its ``k`` nearest points on the same
    side (normals within 60 degrees): the change of the normal against the change of position, both in
    the point's tangent plane; its eigenvector of the smaller |eigenvalue| is the direction.
    """
    from scipy.spatial import cKDTree

    from ..geometry import tangent_frames

    points = np.asarray(points, float).reshape(-1, 3)
    normals = np.asarray(normals, float).reshape(-1, 3)
    m = len(points)
    out = np.full((m, 3), np.nan)
    if m < 4:
        return out
    k = min(int(k), m)
    _, idx = cKDTree(points).query(points, k=k)
    t1, t2 = tangent_frames(normals)
    dp = points[idx] - points[:, None, :]
    dn = normals[idx] - normals[:, None, :]
    same = np.einsum("mkc,mc->mk", normals[idx], normals) > 0.5
    w = same.astype(float)
    a = np.stack([np.einsum("mkc,mc->mk", dp, t1), np.einsum("mkc,mc->mk", dp, t2)], axis=-1)   # (M, k, 2)
    b = np.stack([np.einsum("mkc,mc->mk", dn, t1), np.einsum("mkc,mc->mk", dn, t2)], axis=-1)
    ata = np.einsum("mk,mki,mkj->mij", w, a, a) + 1e-12 * np.eye(2)
    atb = np.einsum("mk,mki,mkj->mij", w, a, b)
    st = np.linalg.solve(ata, atb)                  # (M, 2, 2): dn = dp @ S^T
    s = 0.5 * (st + np.swapaxes(st, 1, 2))
    vals, vecs = np.linalg.eigh(s)                  # ascending eigenvalues, (M, 2), (M, 2, 2)
    small = np.argmin(np.abs(vals), axis=1)
    big = np.abs(vals).max(axis=1)
    ratio = np.abs(vals).min(axis=1) / np.maximum(big, 1e-300)
    v = vecs[np.arange(m), :, small]                # (M, 2) the flattest direction's coordinates
    d = v[:, :1] * t1 + v[:, 1:] * t2
    ok = (big > FLAT_CURVATURE) & (ratio < 0.8) & (w.sum(axis=1) >= 4)
    out[ok] = d[ok] / np.linalg.norm(d[ok], axis=1, keepdims=True)
    return out
