"""Proximity of the skin's outer surface to posed object meshes.

Two back-ends answer the same two questions and agree within 1e-6 m:

* ``"open3d"``: open3d's :class:`RaycastingScene` (BVH, float32 inside; exact up
  to ~1e-8 m at our scales), for headless runs;
* ``"numpy"``: numpy/scipy only (KD-trees and vectorised triangle tests), so it
  runs inside Blender where open3d is not installed.

The questions:

* :func:`lower_envelope` -- along lines with a common direction ``n`` through
  given points, where does the object's surface start (the smallest ``t`` with
  ``p + t n`` on the surface)? This is the gap between the skin and the object
  measured along the press direction: exact for a rigid object translating
  along ``-n``, and it needs no closed mesh.
* :func:`signed_distance` -- the signed distance of points to a closed mesh,
  positive inside (penetration depth).

Why our own numpy ray/triangle code rather than ``trimesh.ray``: trimesh's
pure-Python ray back-end loops per ray in places and its exact answer depends on
optional embree; the parallel-line case we need reduces to 2-D point-in-triangle
tests that vectorise completely.
"""

from __future__ import annotations

import itertools

import numpy as np
from scipy.spatial import cKDTree

from ..errors import FormatError, InputError
from ..geometry import closest_point_on_triangles, tangent_basis
from .grid import digest

BACKENDS = ("open3d", "numpy")
#: How open meshes are treated: refuse them, close their holes, or use only the
#: ray envelope (which needs no inside/outside).
OPEN_MESH = ("error", "fill", "envelope")


def default_backend() -> str:
    """``"open3d"`` when it can be imported, else ``"numpy"``."""
    try:
        import open3d  # noqa: F401
    except Exception:  # pragma: no cover - depends on the install
        return "numpy"
    return "open3d"


def prepare_mesh(mesh, open_mesh: str = "error", name: str = "object"):
    """Check and normalise a mesh: float64 vertices, outward orientation, closedness.

    mesh : trimesh.Trimesh (any float dtype). open_mesh : one of :data:`OPEN_MESH`.
    Returns a new ``trimesh.Trimesh`` with float64 vertices whose faces point
    outwards (a mesh with inverted normals is turned right way out).
    Raises FormatError for an empty mesh or an open one when ``open_mesh="error"``.
    """
    import trimesh

    if open_mesh not in OPEN_MESH:
        raise InputError(f"open_mesh must be one of {', '.join(OPEN_MESH)}, got {open_mesh!r}", key="open_mesh")
    v = np.asarray(mesh.vertices, dtype=np.float64)
    f = np.asarray(mesh.faces, dtype=np.int64)
    if len(v) == 0 or len(f) == 0:
        raise FormatError(f"{name}: mesh has no triangles")
    if not np.all(np.isfinite(v)):
        raise FormatError(f"{name}: mesh has non-finite vertices")
    m = trimesh.Trimesh(v, f, process=True)
    if not m.is_watertight:
        if open_mesh == "error":
            raise FormatError(
                f"{name}: mesh is open (not watertight: {len(m.faces)} faces, boundary edges present); "
                "signed distance needs a closed mesh. Close it, or set open_mesh = \"fill\" (close holes) or "
                "\"envelope\" (use only the surface along the press direction)")
        if open_mesh == "fill":
            trimesh.repair.fill_holes(m)
            if not m.is_watertight:
                raise FormatError(f"{name}: open_mesh = \"fill\" could not close the mesh; use \"envelope\"")
    if m.is_watertight and m.volume < 0:
        m.invert()  # inverted normals: turn the mesh right way out
    m.metadata.update(getattr(mesh, "metadata", {}) or {})
    return m


def _line_hits_numpy(points, n, v, f):
    """All crossings of the lines ``p + t n`` with the triangles.

    Returns (point index (K,), t (K,)). Triangles seen edge-on (zero projected
    area) are skipped: a line crossing them also crosses a neighbour face.
    """
    n = np.asarray(n, float) / np.linalg.norm(n)
    e1, e2 = tangent_basis(n)  # any orthonormal pair: only the projection matters
    p2 = np.column_stack([points @ e1, points @ e2])
    tri = v[f]                                           # (F, 3, 3)
    t2 = np.stack([tri @ e1, tri @ e2], axis=-1)         # (F, 3, 2)
    a, b, c = t2[:, 0], t2[:, 1], t2[:, 2]
    den = (b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (c[:, 0] - a[:, 0]) * (b[:, 1] - a[:, 1])
    scale = np.ptp(v, axis=0).max() if len(v) else 1.0
    ok = np.abs(den) > 1e-14 * scale**2
    cen = t2.mean(axis=1)
    rad = np.linalg.norm(t2 - cen[:, None, :], axis=-1).max(axis=1)
    idx_f = np.flatnonzero(ok)
    if len(idx_f) == 0 or len(points) == 0:
        return np.zeros(0, int), np.zeros(0)
    tree = cKDTree(p2)
    balls = tree.query_ball_point(cen[idx_f], rad[idx_f] * (1 + 1e-9) + 1e-12 * scale)
    counts = np.fromiter((len(x) for x in balls), int, len(balls))
    if counts.sum() == 0:
        return np.zeros(0, int), np.zeros(0)
    pi = np.fromiter(itertools.chain.from_iterable(balls), int, counts.sum())
    fi = np.repeat(idx_f, counts)
    A, B, C = a[fi], b[fi], c[fi]
    P = p2[pi]
    v0, v1, v2 = B - A, C - A, P - A
    d = den[fi]
    u = (v2[:, 0] * v1[:, 1] - v1[:, 0] * v2[:, 1]) / d
    w = (v0[:, 0] * v2[:, 1] - v2[:, 0] * v0[:, 1]) / d
    tol = 1e-10
    inside = (u >= -tol) & (w >= -tol) & (u + w <= 1 + tol)
    pi, fi, u, w = pi[inside], fi[inside], u[inside], w[inside]
    h = tri[fi] @ n                                       # (K, 3) heights of the vertices along n
    t = h[:, 0] + u * (h[:, 1] - h[:, 0]) + w * (h[:, 2] - h[:, 0]) - points[pi] @ n
    return pi, t


def lower_envelope(points, direction, mesh, backend: str | None = None) -> np.ndarray:
    """Where the object's surface starts along ``p + t n`` (t in metres, ``inf`` if never).

    points : (M, 3) metres. direction : (3,) the line direction ``n`` (need not be unit;
    normalised here). mesh : trimesh.Trimesh (open meshes allowed). backend : see module doc.
    Returns t : (M,) float64, the smallest t over all crossings (negative when ``p``
    is inside the object), ``inf`` where the line misses the object.
    """
    backend = backend or default_backend()
    if backend not in BACKENDS:
        raise InputError(f"backend must be one of {', '.join(BACKENDS)}, got {backend!r}", key="backend")
    pts = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    n = np.asarray(direction, dtype=np.float64).reshape(3)
    n = n / np.linalg.norm(n)
    v = np.asarray(mesh.vertices, dtype=np.float64)
    f = np.asarray(mesh.faces, dtype=np.int64)
    out = np.full(len(pts), np.inf)
    if len(pts) == 0 or len(f) == 0:
        return out
    if backend == "numpy":
        pi, t = _line_hits_numpy(pts, n, v, f)
        np.minimum.at(out, pi, t)
        return out
    import open3d as o3d

    # Start every ray below the whole mesh, shifted to a local origin so float32 keeps ~1e-8 m.
    o = v.mean(axis=0)
    vl, pl = v - o, pts - o
    start = max(0.0, float((pl @ n).max() - (vl @ n).min())) + 1e-3
    scene = o3d.t.geometry.RaycastingScene()
    scene.add_triangles(o3d.core.Tensor(vl.astype(np.float32)), o3d.core.Tensor(f.astype(np.uint32)))
    rays = np.hstack([pl - start * n, np.broadcast_to(n, pl.shape)]).astype(np.float32)
    ans = scene.cast_rays(o3d.core.Tensor(rays))
    hit = ans["t_hit"].numpy().astype(np.float64)
    ok = np.isfinite(hit)
    # Recompute t in float64 from the hit triangle's plane: removes float32 rounding of t_hit.
    prim = ans["primitive_ids"].numpy().astype(np.int64)
    if ok.any():
        tri = v[f[prim[ok]]]
        nrm = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
        denom = nrm @ n
        good = np.abs(denom) > 1e-30
        t = hit[ok] - start
        t_exact = np.einsum("ij,ij->i", nrm, tri[:, 0] - pts[ok]) / np.where(good, denom, 1.0)
        t = np.where(good, t_exact, t)
        out[ok] = t
    return out


# An oblique direction for inside tests: lines along it almost never graze an
# edge or vertex of meshes built on axis-aligned or regular grids.
_PARITY_DIR = np.array([0.2672612419124244, 0.5345224838248488, 0.8017837257372732]) + \
    np.array([0.0123, -0.0071, 0.0031])


def signed_distance(points, mesh, backend: str | None = None) -> np.ndarray:
    """Signed distance of points to a closed mesh, metres, **positive inside** (penetration).

    points : (M, 3) metres. mesh : closed trimesh.Trimesh (see :func:`prepare_mesh`).
    Returns (M,) float64.
    """
    backend = backend or default_backend()
    if backend not in BACKENDS:
        raise InputError(f"backend must be one of {', '.join(BACKENDS)}, got {backend!r}", key="backend")
    pts = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    v = np.asarray(mesh.vertices, dtype=np.float64)
    f = np.asarray(mesh.faces, dtype=np.int64)
    if len(pts) == 0:
        return np.zeros(0)
    if backend == "open3d":
        import open3d as o3d

        o = v.mean(axis=0)
        scene = o3d.t.geometry.RaycastingScene()
        scene.add_triangles(o3d.core.Tensor((v - o).astype(np.float32)), o3d.core.Tensor(f.astype(np.uint32)))
        q = o3d.core.Tensor((pts - o).astype(np.float32))
        ans = scene.compute_closest_points(q)
        prim = ans["primitive_ids"].numpy().astype(np.int64)
        # Distance recomputed in float64 on the closest triangle that open3d found.
        tri = v[f[prim]]
        cp = closest_point_on_triangles(tri, pts)
        dist = np.linalg.norm(pts - cp, axis=1)
        occ = scene.compute_occupancy(q, nsamples=3).numpy().astype(bool)
        return np.where(occ, dist, -dist)
    # numpy: exact candidate set from KD-trees, then closest points on candidates.
    tri = v[f]
    cen = tri.mean(axis=1)
    rmax = float(np.linalg.norm(tri - cen[:, None, :], axis=-1).max())
    ub, _ = cKDTree(v).query(pts)                        # distance to the nearest vertex bounds d
    ctree = cKDTree(cen)
    balls = ctree.query_ball_point(pts, ub + rmax * (1 + 1e-9) + 1e-12)
    counts = np.fromiter((len(x) for x in balls), int, len(balls))
    fi = np.fromiter(itertools.chain.from_iterable(balls), int, counts.sum())
    pi = np.repeat(np.arange(len(pts)), counts)
    cp = closest_point_on_triangles(tri[fi], pts[pi])
    d = np.linalg.norm(pts[pi] - cp, axis=1)
    dist = ub.copy()
    np.minimum.at(dist, pi, d)
    # inside: odd number of crossings of the half-line p + t n, t > 0
    n = _PARITY_DIR / np.linalg.norm(_PARITY_DIR)
    hp, ht = _line_hits_numpy(pts, n, v, f)
    crossings = np.bincount(hp[ht > 0], minlength=len(pts))
    inside = crossings % 2 == 1
    return np.where(inside, dist, -dist)


# --- the posed object, cached along a trajectory ----------------------------------------

_MESH_CACHE: dict = {}


def prepared_mesh(mesh, open_mesh):
    """(checked float64 mesh, lazily built open3d scene holder) for ``mesh``, cached by content."""
    try:  # trimesh keeps a content hash that is cached until the arrays change: ~10 us
        content = hash(mesh)
    except TypeError:
        content = digest(np.asarray(mesh.vertices), np.asarray(mesh.faces))
    key = (id(mesh), content, open_mesh)
    hit = _MESH_CACHE.get(key)
    if hit is None:
        if len(_MESH_CACHE) > 16:
            _MESH_CACHE.clear()
        hit = (prepare_mesh(mesh, open_mesh=open_mesh), {})
        _MESH_CACHE[key] = hit
    return hit


def envelope_posed(points, n, local, scene, pose, backend):
    """lower_envelope of the posed mesh, computed in the object's frame (distances are rigid-invariant),
    so the object's BVH is built once per mesh, not once per pose."""
    r, t = pose[:3, :3], pose[:3, 3]
    # einsum, not @: OpenBLAS threads a (M, 3) x (3, 3) product for large M and its idle
    # threads then spin, doubling the CPU time on a shared machine for no gain
    p_obj = np.einsum("mi,ij->mj", np.asarray(points, float) - t, r)
    n_obj = np.asarray(n, float) @ r
    backend = backend or default_backend()
    if backend == "open3d":
        return _envelope_open3d(p_obj, n_obj, local, scene)
    return lower_envelope(p_obj, n_obj, local, backend)


def _envelope_open3d(pts, n, local, holder):
    import open3d as o3d

    if "scene" not in holder:
        v = np.asarray(local.vertices, float)
        f = np.asarray(local.faces, np.int64)
        o = v.mean(axis=0)
        sc = o3d.t.geometry.RaycastingScene()
        sc.add_triangles(o3d.core.Tensor((v - o).astype(np.float32)), o3d.core.Tensor(f.astype(np.uint32)))
        tri = v[f]
        holder.update(scene=sc, o=o, tri=tri, nrm=np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]),
                      radius=float(np.linalg.norm(v - o, axis=1).max()))
    o = holder["o"]
    n = n / np.linalg.norm(n)
    pl = pts - o
    # start every ray below the mesh's bounding sphere (any start below the mesh is exact: t is
    # recomputed in float64 from the hit triangle's plane); cheaper than projecting the vertices
    start = max(0.0, float(np.einsum("mi,i->m", pl, n).max()) + holder["radius"]) + 1e-3
    rays = np.hstack([pl - start * n, np.broadcast_to(n, pl.shape)]).astype(np.float32)
    # few rays (a footprint of a few thousand cells): one thread; waking open3d's pool costs more
    # than the casting on a loaded machine (0.9 ms wall for 0.2 ms of work at 350 rays)
    ans = holder["scene"].cast_rays(o3d.core.Tensor(rays), nthreads=1 if len(rays) < 20000 else 0)
    hit = ans["t_hit"].numpy().astype(np.float64)
    out = np.full(len(pts), np.inf)
    ok = np.isfinite(hit)
    if ok.any():
        prim = ans["primitive_ids"].numpy().astype(np.int64)[ok]
        nrm, a = holder["nrm"][prim], holder["tri"][prim, 0]
        den = np.einsum("mi,i->m", nrm, n)
        good = np.abs(den) > 1e-30
        exact = np.einsum("ij,ij->i", nrm, a - pts[ok]) / np.where(good, den, 1.0)
        out[ok] = np.where(good, exact, hit[ok] - start)  # float64 plane intersection
    return out

