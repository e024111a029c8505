"""Queries on a triangle mesh's surface: closest points, the exact snap of one point, normals.

mesh : trimesh.Trimesh in metres. Triangle-level geometry (closest point on a triangle,
barycentric coordinates, tangent bases) is in :mod:`vtcore.geometry`.
"""

from __future__ import annotations

import weakref
from collections import OrderedDict

import numpy as np

from ..errors import InputError
from ..geometry import closest_point_on_triangles, tangent_basis
from .repair import longest_edges, recall, remember

#: open3d raycasting scenes of the last few meshes queried: building one (its BVH) costs ~0.1 s
#: per 50k faces, and a fill queries the same surface dozens of times
_SCENES: OrderedDict = OrderedDict()
_SCENES_KEPT = 4


def _raycasting_scene(mesh):
    """The open3d RaycastingScene of ``mesh``, from a small cache keyed by the object and the
    hash of its data (trimesh re-hashes when vertices or faces change, so a mutated mesh gets a
    new scene)."""
    import open3d as o3d  # C++ BVH: far faster than trimesh's for many points

    key = id(mesh)
    stamp = hash(mesh)
    hit = _SCENES.get(key)
    if hit is not None and hit[0]() is mesh and hit[1] == stamp:
        _SCENES.move_to_end(key)
        return hit[2]
    scene = o3d.t.geometry.RaycastingScene()
    tm = o3d.t.geometry.TriangleMesh()
    tm.vertex.positions = o3d.core.Tensor(np.asarray(mesh.vertices, np.float32))
    tm.triangle.indices = o3d.core.Tensor(np.asarray(mesh.faces, np.int32))
    scene.add_triangles(tm)
    _SCENES[key] = (weakref.ref(mesh), stamp, scene)
    while len(_SCENES) > _SCENES_KEPT:
        _SCENES.popitem(last=False)
    return scene


def closest_points(mesh, points: np.ndarray):
    """Closest points on ``mesh``: ``(points (n,3), face (n,), distance (n,))``."""
    points = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    try:
        scene = _raycasting_scene(mesh)
        import open3d as o3d

        ans = scene.compute_closest_points(o3d.core.Tensor(points.astype(np.float32)))
        face = ans["primitive_ids"].numpy().astype(np.int64)
        # refine in float64 on the found face (open3d works in float32)
        cp = closest_on_faces(mesh, points, face)
    except ImportError:  # inside Blender: the extension does not bundle open3d
        face = nearest_faces(mesh, points)
        cp = closest_on_faces(mesh, points, face)
    return cp, face, np.linalg.norm(cp - points, axis=1)


def faces_at(mesh, points: np.ndarray) -> np.ndarray:
    """(n,) the face of ``mesh`` nearest each of ``points`` (n, 3), as ``closest_points(mesh,
    points)[1]``, at once for the points that are some face's own centre (bit for bit, the centre
    of only that face): the faces of a part of ``mesh`` cut out or split apart (the fill's coverage
    asks this of every face of its surface: 1M closest-point queries cost ~2.5 s of CPU on a 1M-face
    scan, the look-up ~0.3 s); the others by :func:`closest_points`."""
    points = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    cen = np.ascontiguousarray(np.asarray(mesh.triangles_center, dtype=np.float64))
    out = np.full(len(points), -1, np.int64)
    if len(points) and len(cen):
        key = _point_keys(cen)
        order = np.argsort(key, kind="stable")
        ks = key[order]
        unique = np.ones(len(ks), bool)  # a centre two faces share answers nothing here
        unique[1:] &= ks[1:] != ks[:-1]
        unique[:-1] &= ks[:-1] != ks[1:]
        pk = _point_keys(points)
        i = np.minimum(np.searchsorted(ks, pk), len(ks) - 1)
        f = order[i]
        hit = (ks[i] == pk) & unique[i] & (cen[f] == points).all(axis=1)
        out[hit] = f[hit]
    rest = np.flatnonzero(out < 0)
    if len(rest):
        out[rest] = closest_points(mesh, points[rest])[1]
    return out


def _point_keys(points: np.ndarray) -> np.ndarray:
    """(n,) uint64 hash of the bits of each row of ``points`` (n, 3) float64 (equal rows, equal keys)."""
    b = np.ascontiguousarray(points, dtype=np.float64).view(np.uint64).reshape(-1, 3)
    with np.errstate(over="ignore"):
        return b[:, 0] ^ (b[:, 1] * np.uint64(0x9E3779B97F4A7C15)) ^ (b[:, 2] * np.uint64(0xC2B2AE3D27D4EB4F))


def nearest_faces(mesh, points: np.ndarray, max_pairs: int = 2_000_000) -> np.ndarray:
    """(n,) the face of ``mesh`` nearest each of ``points`` (n, 3), exactly (float64; ties: the
    lowest face index), without open3d.

    Not trimesh.proximity.closest_point: among faces within its merge tolerance of each other it
    prefers one whose normal faces the point, and on a 1 mm cylinder mesh it answered faces up
    to 0.1 mm farther than the nearest; its r-tree search also took 60 us a point. Here the face
    under the nearest centre bounds the distance ``D``, and every face whose bounding ball (at
    its centre, radius to its farthest corner) comes within ``D`` is tested: k-d trees of face
    centres, one per size class of the balls so that a few long CAD slivers do not widen every
    query. Candidates are taken ``max_pairs`` (point, face) pairs at a time: a point far from
    the surface can have every face as a candidate."""
    points = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    V, F = np.asarray(mesh.vertices), np.asarray(mesh.faces)
    index = recall(mesh, "face_balls")
    if index is None:
        index = remember(mesh, "face_balls", _face_balls(V, F))
    everyone, classes = index
    _, near = everyone.query(points)
    bound = np.linalg.norm(closest_point_on_triangles(V[F[near]], points) - points, axis=1)
    out = np.asarray(near, np.int64).copy()
    best = bound.copy()
    step = max(1, min(len(points), max_pairs // 64))
    for s in range(0, len(points), step):
        p, r = points[s:s + step], bound[s:s + step] * (1 + 1e-12) + 1e-300
        for members, tree, radius in classes:
            counts = tree.query_ball_point(p, r + radius, return_length=True)
            ends = np.cumsum(counts)
            i = 0
            while i < len(p):  # points i..j-1 share at most max_pairs pairs (or one point has more)
                j = max(i + 1, int(np.searchsorted(ends, ends[i] - counts[i] + max_pairs, side="right")))
                hits = tree.query_ball_point(p[i:j], r[i:j] + radius)
                if ends[j - 1] - ends[i] + counts[i]:
                    ids = members[np.concatenate([np.asarray(h, np.int64) for h in hits])]
                    owner = np.repeat(np.arange(s + i, s + j), counts[i:j])
                    d = np.linalg.norm(closest_point_on_triangles(V[F[ids]], points[owner]) - points[owner], axis=1)
                    order = np.lexsort((ids, d, owner))
                    first = order[np.r_[True, owner[order][1:] != owner[order][:-1]]]
                    o, f, dd = owner[first], ids[first], d[first]
                    better = (dd < best[o]) | ((dd == best[o]) & (f < out[o]))
                    out[o[better]], best[o[better]] = f[better], dd[better]
                i = j
    return out


def _face_balls(V: np.ndarray, F: np.ndarray):
    """The search structure of :func:`nearest_faces`: the k-d tree of the face centres, and per
    size class (radius within a factor 4) the member faces, their centres' tree, the largest radius."""
    from scipy.spatial import cKDTree

    T = V[F]
    c = T.mean(axis=1)
    rad = np.linalg.norm(T - c[:, None], axis=2).max(axis=1)
    top = max(float(rad.max()), 1e-300)
    cls = np.minimum(np.floor(np.log(top / np.maximum(rad, 1e-300)) / np.log(4.0)), 6).astype(np.int64)
    classes = []
    for k in np.unique(cls):
        members = np.flatnonzero(cls == k)
        classes.append((members, cKDTree(c[members]), float(rad[members].max())))
    return cKDTree(c), classes


def face_longest_edges(mesh) -> np.ndarray:
    """(F,) metres, the longest edge of each face; cached on the mesh object with the hash of its
    data (a fill snaps each chart's origin: recomputing this was most of the snap's cost)."""
    out = recall(mesh, "longest_edges")
    if out is None:
        out = remember(mesh, "longest_edges", longest_edges(mesh.vertices, mesh.faces))
    return out


def snap(mesh, point) -> tuple[np.ndarray, np.ndarray, np.ndarray, float]:
    """The surface point of ``mesh`` nearest one ``point`` (3,), exactly and reproducibly.

    Every face is tested in float64 (one point: O(F), milliseconds at 100k faces) and ties go to
    the lowest face index, so the answer does not depend on a BVH's traversal order or on which
    proximity back-end is installed. Returns ``(point (1, 3), face (1,), distance (1,), spread)``
    where ``spread`` (metres) is how far apart the equally near surface points are: large when
    ``point`` is equally near several parts of the surface (the centre of a sphere).
    """
    p = np.asarray(point, dtype=np.float64).reshape(3)
    V = np.asarray(mesh.vertices)
    F = np.asarray(mesh.faces)
    if not len(F):
        raise InputError("the mesh has no faces", key="mesh")
    scale = recall(mesh, "extent")  # np.ptp over (V, 3) was a fifth of a snap at 200k faces
    if scale is None:
        scale = remember(mesh, "extent", max(float(np.ptp(V, axis=0).max()), 1e-300))
    # only faces that can be the nearest are tested exactly: a face within distance D of p has
    # every vertex within D + its longest edge, and D <= the distance to the nearest vertex
    # (one pass over V and F instead of the exact closest-point test on all F faces, which took
    # seconds per fill at 100k faces when every chart snapped its origin)
    dv = np.linalg.norm(V - p, axis=1)
    # only vertices of faces count (an unreferenced one may be nearer); three column minima, not
    # a reduction along the short axis of (F, 3)
    dfv = np.minimum(np.minimum(dv[F[:, 0]], dv[F[:, 1]]), dv[F[:, 2]])
    cand = np.flatnonzero(dfv <= dfv.min() + face_longest_edges(mesh) + 1e-9 * scale)
    near = closest_point_on_triangles(V[F[cand]], np.broadcast_to(p, (len(cand), 3)).copy())
    d = np.linalg.norm(near - p, axis=1)
    dmin = float(d.min())
    tie = np.flatnonzero(d <= dmin + 1e-9 * scale)  # cand is sorted: ties go to the lowest face index
    f = int(tie[0])
    spread = float(np.linalg.norm(near[tie] - near[f], axis=1).max())
    return near[f][None], np.array([int(cand[f])]), np.array([dmin]), spread


def closest_on_faces(mesh, points, face):
    """Closest point on the given face of each point (float64)."""
    tri = np.asarray(mesh.vertices)[np.asarray(mesh.faces)[face]]
    return closest_point_on_triangles(tri, points)


CREASE_DEG = 30.0  #: faces meeting at a sharper angle than this are not averaged into one normal


def corner_normals(mesh, crease_deg: float = CREASE_DEG) -> np.ndarray:
    """(F, 3, 3) unit normal at each corner of each face, crease-aware.

    A corner takes the mesh's vertex normal, except at a vertex where faces meet at more than
    ``crease_deg`` degrees: there it averages (area-weighted) only the faces round the vertex
    within ``crease_deg`` of its own face, so a normal is never interpolated across a sharp edge
    (the issue saw a taxel 81 degrees off the face it lay on). Cached on the mesh object with the
    hash of its data (a mesh changed in place gets new normals).
    """
    cached = recall(mesh, "corner_normals")  # kept with the hash of the mesh's data
    if cached is not None and cached[0] == crease_deg:
        return cached[1]
    F = np.asarray(mesh.faces, dtype=np.int64)
    nf, nv = len(F), len(mesh.vertices)
    fn = np.asarray(mesh.face_normals)
    area = np.asarray(mesh.area_faces)
    vert = F.ravel()  # corner c = 3 * face + k
    cface = np.repeat(np.arange(nf), 3)
    vn = np.asarray(mesh.vertex_normals)
    nrm = vn[vert]  # a new array (fancy indexing), changed below at sharp corners only
    # only where some face round a vertex is more than half the crease angle off the vertex
    # normal can two faces there be more than the crease angle apart (triangle inequality on
    # angles): the per-corner test below runs on those few vertices, not on all 3F corners
    off_vn = np.einsum("ij,ij->i", np.repeat(fn, 3, axis=0), nrm) < np.cos(np.radians(crease_deg / 2))
    suspect = np.zeros(nv, bool)
    suspect[vert[off_vn]] = True
    corners = np.flatnonzero(suspect[vert])
    if len(corners):
        cv = vert[corners]
        # ``corners`` holds every corner of each suspect vertex: grouping them by vertex (stable,
        # so by corner index within a vertex) lists the faces round each, without sorting all 3F
        order = np.argsort(cv, kind="stable")
        verts, starts, counts = np.unique(cv[order], return_index=True, return_counts=True)
        at = np.searchsorted(verts, cv)
        cnt = counts[at]
        rows = np.repeat(np.arange(len(corners)), cnt)
        off = np.arange(int(cnt.sum())) - np.repeat(np.cumsum(cnt) - cnt, cnt)
        g = cface[corners[order]][np.repeat(starts[at], cnt) + off]  # faces round each corner's vertex
        cos = np.einsum("ij,ij->i", fn[cface[corners]][rows], fn[g])
        near = cos >= np.cos(np.radians(crease_deg))
        sharp = np.bincount(rows, weights=~near, minlength=len(corners)) > 0
        w = area[g[near]]
        acc = np.column_stack([np.bincount(rows[near], weights=w * fn[g[near], k], minlength=len(corners))
                               for k in range(3)])
        sc, a = corners[sharp], acc[sharp]
        la = np.linalg.norm(a, axis=1, keepdims=True)
        nrm[sc] = np.where(la > 1e-300, a / np.maximum(la, 1e-300), fn[cface[sc]])
    out = nrm.reshape(nf, 3, 3)
    remember(mesh, "corner_normals", (crease_deg, out))
    return out


def surface_normals(mesh, face: np.ndarray, bary: np.ndarray) -> np.ndarray:
    """(n, 3) unit normals at points on ``face`` (n,) with barycentric ``bary`` (n, 3):
    the crease-aware corner normals (:func:`corner_normals`) interpolated over the face."""
    cn = corner_normals(mesh)[np.asarray(face)]
    n = np.einsum("nk,nkj->nj", bary, cn)
    norm = np.linalg.norm(n, axis=1, keepdims=True)
    fn = np.asarray(mesh.face_normals)[face]
    return np.where(norm > 1e-12, n / np.maximum(norm, 1e-300), fn)


def footprint_faces(mesh, origins: np.ndarray, z: np.ndarray, radius: float, rim: int = 12,
                    x_hint=(1.0, 0.0, 0.0), y_hint=(0.0, 1.0, 0.0)) -> np.ndarray:
    """(N, 1 + rim) the faces of ``mesh`` under each taxel's footprint: under its origin (N, 3)
    and under ``rim`` points round a disc of ``radius`` metres in the plane normal to ``z`` (N, 3),
    brought onto the mesh. The rim starts from ``x_hint`` projected on that plane (``y_hint`` where
    ``z`` is near ``x_hint``), so the result does not depend on where the taxel is."""
    z = np.asarray(z, dtype=np.float64).reshape(-1, 3)
    z = z / np.maximum(np.linalg.norm(z, axis=1, keepdims=True), 1e-300)
    origins = np.asarray(origins, dtype=np.float64).reshape(-1, 3)
    hx, hy = np.asarray(x_hint, dtype=np.float64), np.asarray(y_hint, dtype=np.float64)
    helper = np.where(np.abs(z @ hx)[:, None] < 0.9, hx, hy)
    t1 = helper - z * np.einsum("ij,ij->i", helper, z)[:, None]
    t1 /= np.linalg.norm(t1, axis=1, keepdims=True)
    t2 = np.cross(z, t1)
    phi = 2 * np.pi * np.arange(rim) / rim
    ring = (np.cos(phi)[None, :, None] * t1[:, None] + np.sin(phi)[None, :, None] * t2[:, None]) * radius
    pts = np.concatenate([origins[:, None], origins[:, None] + ring], axis=1)  # (N, 1 + rim, 3)
    _, under, _ = closest_points(mesh, pts.reshape(-1, 3))
    return under.reshape(len(origins), 1 + rim)


#: degrees: a smoothed taxel normal leaning more than this from the face under it is brought to the
#: faces under its footprint (:func:`rest_normals`); below the placement report's 5 degrees so that
#: every normal ends within 5 degrees of the surface under it with a margin. On a fine mesh (a
#: 48-chord tube leans at most 3.75 degrees) a taxel's disc spans the chords its smoothed normal lies
#: between, so the nearest direction they allow is that normal itself: smooth normals stay smooth.
REST_LEAN_DEG = 3.0


def nearest_in_footprint(under: np.ndarray, z: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The direction nearest each ``z`` (N, 3, unit) among the normals ``under`` (N, K, 3, unit) of
    the faces under a taxel and the great-circle arcs between every pair of them (where a flexible
    taxel lying across those faces can point). Returns ``(direction (N, 3), cos (N,))``: the
    direction, and the cosine of its angle to ``z``. Three or more faces meeting at a vertex span a
    cone whose inside is not searched (its edges are), so the angle is an upper bound there."""
    cos = np.einsum("nkj,nj->nk", under, z)
    pick = cos.argmax(axis=1)
    best = cos[np.arange(len(z)), pick]
    out = under[np.arange(len(z)), pick]
    i, j = np.triu_indices(under.shape[1], 1)
    a, b = under[:, i], under[:, j]  # (N, P, 3): the arcs between every pair of normals
    m = np.cross(a, b)
    lm = np.linalg.norm(m, axis=2, keepdims=True)
    m = m / np.maximum(lm, 1e-300)
    zz = np.broadcast_to(z[:, None], a.shape)
    zp = zz - np.einsum("npj,npj->np", zz, m)[..., None] * m  # z projected onto the arc's plane
    inside = ((np.einsum("npj,npj->np", np.cross(a, zp), m) >= 0)
              & (np.einsum("npj,npj->np", np.cross(zp, b), m) >= 0) & (lm[..., 0] > 1e-9))
    lp = np.linalg.norm(zp, axis=2)
    arc = np.where(inside, lp, -1.0)  # cos of the angle between z and the arc's nearest point
    k = arc.argmax(axis=1) if arc.shape[1] else np.zeros(len(z), np.int64)
    on_arc = arc.shape[1] > 0
    if on_arc:
        better = arc[np.arange(len(z)), k] > best
        best = np.where(better, arc[np.arange(len(z)), k], best)
        hit = zp[np.arange(len(z)), k] / np.maximum(lp[np.arange(len(z)), k], 1e-300)[:, None]
        out = np.where(better[:, None], hit, out)
    return out, best


def rest_normals(mesh, points: np.ndarray, normals: np.ndarray, face: np.ndarray, radius: float,
                 lean_deg: float) -> np.ndarray:
    """(N, 3) taxel normals true to the faces a taxel rests on.

    The interpolated normals (:func:`surface_normals`) are smoothed over whole faces round a vertex:
    on a coarse mesh (a collision hull's facets meeting at 10 to 30 degrees) that spreads wider than
    a taxel, so a taxel near a hull edge leans towards the next facet by more than any face under it
    does (issue 25: 8 degrees off every normal under a 4 mm disc on UR10's wrist-3 hull). Where a
    normal (N, 3) leans more than ``lean_deg`` degrees from its face's (``face`` (N,) on ``mesh``,
    ``points`` (N, 3) on it), it becomes the direction nearest it that the faces under the taxel's
    footprint (disc of ``radius`` metres) allow (:func:`nearest_in_footprint`): the face's own normal
    on one facet, a direction between two facets where the disc lies across their edge. Elsewhere
    (fine or smooth meshes) the smoothed normal is kept as it is."""
    normals = np.asarray(normals, dtype=np.float64).reshape(-1, 3)
    if not len(normals):
        return normals
    fn = np.asarray(mesh.face_normals)
    lean = np.einsum("ij,ij->i", fn[np.asarray(face)], normals) < np.cos(np.radians(lean_deg))
    if not lean.any():
        return normals
    idx = np.flatnonzero(lean)
    z = normals[idx] / np.linalg.norm(normals[idx], axis=1, keepdims=True)
    under = footprint_faces(mesh, np.asarray(points, dtype=np.float64).reshape(-1, 3)[idx], z, radius)
    out = normals.copy()
    out[idx] = nearest_in_footprint(fn[under], z)[0]
    return out


def normal_deviation(mesh, points: np.ndarray, normals: np.ndarray) -> np.ndarray:
    """(n,) degrees between ``normals`` (n, 3) and the normal of the face of ``mesh`` nearest
    each point (n, 3)."""
    _, face, _ = closest_points(mesh, points)
    fn = np.asarray(mesh.face_normals)[face]
    c = np.einsum("ij,ij->i", fn, normals) / np.maximum(np.linalg.norm(normals, axis=1), 1e-300)
    return np.degrees(np.arccos(np.clip(c, -1.0, 1.0)))


def at_notes(cp: np.ndarray, dist: float, spread: float) -> list:
    """Warnings about the requested point 'at' (metres): off the surface, or ambiguous."""
    out = []
    where = ", ".join(f"{1e3 * c:.2f}" for c in cp)
    if spread > 1e-6:
        out.append(f"'at' is equally near several parts of the surface ({1e3 * spread:.1f} mm apart; "
                   f"e.g. the centre of a sphere): the patch is centred on the first, ({where}) mm; "
                   "put 'at' on the surface to choose")
    elif dist > 1e-3:
        out.append(f"'at' is {1e3 * dist:.1f} mm off the surface; the patch is centred on the nearest surface "
                   f"point ({where}) mm")
    return out


def frame_at(normal: np.ndarray, direction) -> tuple[np.ndarray, np.ndarray]:
    """The patch frame ``(t1, t2)`` (3,) each at a surface point with ``normal`` (3,):
    ``t1`` is ``direction`` (3,) projected onto the tangent plane (None: world x, or y)."""
    try:
        return tangent_basis(normal, direction)
    except ValueError:
        raise InputError("direction is parallel to the surface normal at 'at'; give an in-plane direction",
                         key="direction") from None
