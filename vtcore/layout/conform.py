"""Conform flat patches to curved surfaces, the way a flexible PCB wraps them.

Placement maps the flat patch domain onto a triangle mesh around a point ``at``
with the patch's x axis along an in-plane ``direction``:

- ``method="logmap"`` (default): the inverse of the surface's logarithmic map
  at ``at`` (the exponential map), computed with the vector heat method
  (Sharp, Soliman, Crane 2019) as implemented by potpourri3d
  (geometry-central). Geodesic distance and direction from ``at`` are kept
  exactly; what strain remains is what the surface's Gaussian curvature forces
  (none on developable surfaces such as cylinders and planes). The mesh is
  cropped to the part within reach of the patch first, so a small patch on a
  large mesh only factors a small system.
- ``method="project"``: the baseline: lay the flat patch in the tangent plane at
  ``at`` and move every taxel to its closest point on the surface. Cheap, but
  distances shrink as the surface curves away (the benchmark shows how much).

Every taxel lands on the surface (on a mesh face) with the interpolated surface
normal, then moves ``offset`` metres along it. Taxels whose flat position maps
outside an open boundary of the mesh are reported (``off_boundary``) and kept at
their closest surface point, never silently dropped.

The :class:`PlacementReport` gives per patch: the strain of module edges against
the flat layout (edge length on the surface, measured as the arc through both
taxels with their normals, over the flat length, minus one: bending is free for a
flexible PCB, stretching is not), module overlaps (taxels of different modules
closer than ``overlap_fraction`` of the pitch), off-boundary taxels, and the
coverage of the chosen region (area of the region under module outlines over the
region's area).
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass, field

import numpy as np
from scipy.spatial import cKDTree

from ..errors import InputError
from .mesh import LayoutWarning
from .model import Layout
from .patches import Patch, fill_patch, make_patch

OVERLAP_FRACTION = 0.75  #: taxels of different modules closer than this many pitches overlap


@dataclass
class PlacementReport:
    """What a placement did to the patch.

    strain : (E,) float, per module edge, (length on the surface / flat length) - 1.
    strain_max : float, max |strain|. strain_mean : float, mean |strain|.
    module_strain : (M,) float, per module max |strain|.
    overlaps : list of (module_a, module_b) pairs of this patch that overlap each other.
    existing_overlaps : list of (existing_module, new_module) pairs: a module of this patch
        overlapping one already on the skin (``place(..., existing=layout)``); new module ids
        are the patch's own (0-based), existing ones as in ``existing.module_ids``.
    off_boundary : (K,) int, taxel indices that fell outside the mapped surface (off an open boundary,
        or past the cut locus of a closed surface where the log map is unreliable).
    coverage : float in [0, 1] or nan, fraction of the region under module outlines.
    surface_distance_max : float, metres, max distance of a taxel (before offset) from the mesh.
    method : "logmap" or "project"; notes : list of str.
    """

    strain: np.ndarray
    module_strain: np.ndarray
    overlaps: list
    off_boundary: np.ndarray
    coverage: float = float("nan")
    surface_distance_max: float = 0.0
    method: str = "logmap"
    seconds: float = 0.0
    notes: list = field(default_factory=list)
    existing_overlaps: list = field(default_factory=list)

    @property
    def strain_max(self) -> float:
        return float(np.abs(self.strain).max()) if len(self.strain) else 0.0

    @property
    def strain_mean(self) -> float:
        return float(np.abs(self.strain).mean()) if len(self.strain) else 0.0

    def as_dict(self) -> dict:
        return {"method": self.method, "strain_max": self.strain_max, "strain_mean": self.strain_mean,
                # every overlapping pair an integrator has to act on: within the patch and with
                # modules already on the skin (the add-on shows this one number)
                "overlaps": len(self.overlaps) + len(self.existing_overlaps),
                "overlaps_within": len(self.overlaps), "overlaps_existing": len(self.existing_overlaps),
                "overlap_pairs": [list(map(int, p)) for p in self.overlaps],
                "existing_overlap_pairs": [list(map(int, p)) for p in self.existing_overlaps],
                "off_boundary": [int(i) for i in self.off_boundary], "coverage": _f(self.coverage),
                "surface_distance_max_m": float(self.surface_distance_max), "seconds": float(self.seconds),
                "notes": list(self.notes)}


def _f(x):
    return None if x is None or not np.isfinite(x) else float(x)


# --- mesh preparation ------------------------------------------------------------------------------
def clean_mesh(mesh):
    """A copy of ``mesh`` fit for the solvers: duplicate vertices merged, degenerate and
    duplicate faces removed, unreferenced vertices dropped. Returns ``(mesh, notes)``."""
    import trimesh

    notes = []
    v = np.asarray(mesh.vertices, dtype=np.float64)
    f = np.asarray(mesh.faces, dtype=np.int64)
    if not len(f):
        raise InputError("the mesh has no faces", key="mesh")
    if not np.isfinite(v).all():
        raise InputError("the mesh has non-finite vertices", key="mesh")
    m = trimesh.Trimesh(v, f, process=True, validate=False)  # merges duplicate vertices
    area = m.area_faces
    scale = max(float(np.ptp(m.vertices, axis=0).max()), 1e-12)
    good = area > 1e-14 * scale ** 2
    fs = np.sort(m.faces, axis=1)
    good &= (fs[:, 0] != fs[:, 1]) & (fs[:, 1] != fs[:, 2])
    if (~good).any():
        notes.append(f"removed {int((~good).sum())} degenerate faces")
    _, first = np.unique(fs, axis=0, return_index=True)
    dup = np.ones(len(fs), bool)
    dup[first] = False
    if (dup & good).any():
        notes.append(f"removed {int((dup & good).sum())} duplicate faces")
    good &= ~dup
    m = trimesh.Trimesh(m.vertices, m.faces[good], process=False, validate=False)
    m.remove_unreferenced_vertices()
    return m, notes


def _nonmanifold_edges(faces: np.ndarray) -> int:
    e = np.sort(np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]]), axis=1)
    _, c = np.unique(e, axis=0, return_counts=True)
    return int((c > 2).sum())


def _split_nonmanifold(mesh):
    """Faces sharing an edge with more than one other face are separated along that edge
    (each face fan gets its own copy of the edge's vertices), so the result is edge-manifold."""
    import trimesh

    f = np.asarray(mesh.faces)
    directed = np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]])
    e = np.sort(directed, axis=1)
    _, inv, cnt = np.unique(e, axis=0, return_inverse=True, return_counts=True)
    _, dinv, dcnt = np.unique(directed, axis=0, return_inverse=True, return_counts=True)
    # an edge shared by more than two faces, or twice in the same direction (flipped neighbours)
    bad_edge = (cnt[inv.ravel()] > 2) | (dcnt[dinv.ravel()] > 1)
    if not bad_edge.any():
        return mesh, 0
    nf = len(f)
    bad_face = np.zeros(nf, bool)
    bad_face[np.arange(3 * nf)[bad_edge] % nf] = True
    # give every face touching a non-manifold edge its own vertices (cheap, local, and the
    # log map treats those faces as a separate boundary, which is what a PCB would do there)
    v = np.asarray(mesh.vertices)
    idx = np.flatnonzero(bad_face)
    newv = v[f[idx].ravel()]
    f2 = f.copy()
    f2[idx] = len(v) + np.arange(3 * len(idx)).reshape(-1, 3)
    out = trimesh.Trimesh(np.vstack([v, newv]), f2, process=False, validate=False)
    out.remove_unreferenced_vertices()
    return out, int(len(idx))


def _split_bowties(mesh):
    """Give every face at a vertex with more than one boundary loop through it (a bowtie: two
    fans meeting at a point) its own copy of that vertex; geometry-central needs manifold vertices."""
    import trimesh

    f = np.asarray(mesh.faces)
    e = np.sort(np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]]), axis=1)
    key, cnt = np.unique(e, axis=0, return_counts=True)
    bnd = key[cnt == 1]
    per_vertex = np.bincount(bnd.ravel(), minlength=len(mesh.vertices))
    bad = per_vertex > 2
    if not bad.any():
        return mesh, 0
    v = np.asarray(mesh.vertices)
    corner = bad[f]
    fi, ci = np.nonzero(corner)
    f2 = f.copy()
    f2[fi, ci] = len(v) + np.arange(len(fi))
    out = trimesh.Trimesh(np.vstack([v, v[f[fi, ci]]]), f2, process=False, validate=False)
    out.remove_unreferenced_vertices()
    return out, int(bad.sum())


# --- geometry helpers --------------------------------------------------------------------------------
def _closest(mesh, points: np.ndarray):
    """Closest points on ``mesh``: ``(points (n,3), face (n,), distance (n,))``."""
    points = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    try:
        import open3d as o3d  # C++ BVH: far faster than trimesh's for many points

        scene = o3d.t.geometry.RaycastingScene()
        tm = o3d.t.geometry.TriangleMesh()
        tm.vertex.positions = o3d.core.Tensor(np.asarray(mesh.vertices, np.float32))
        tm.triangle.indices = o3d.core.Tensor(np.asarray(mesh.faces, np.int32))
        scene.add_triangles(tm)
        ans = scene.compute_closest_points(o3d.core.Tensor(points.astype(np.float32)))
        face = ans["primitive_ids"].numpy().astype(np.int64)
        # refine in float64 on the found face (open3d works in float32)
        cp = _closest_on_faces(mesh, points, face)
    except ImportError:  # pragma: no cover - open3d is in the pinned stack
        import trimesh

        _, _, face = trimesh.proximity.closest_point(mesh, points)
        face = np.asarray(face, np.int64)
        cp = _closest_on_faces(mesh, points, face)
    return cp, face, np.linalg.norm(cp - points, axis=1)


def _snap(mesh, point) -> tuple[np.ndarray, np.ndarray, np.ndarray, float]:
    """The surface point of ``mesh`` nearest one ``point`` (3,), exactly and reproducibly.

    Every face is tested in float64 (one point: O(F), milliseconds at 100k faces) and ties go to
    the lowest face index, so the answer does not depend on a BVH's traversal order or on which
    proximity back-end is installed. Returns ``(point (1, 3), face (1,), distance (1,), spread)``
    where ``spread`` (metres) is how far apart the equally near surface points are: large when
    ``point`` is equally near several parts of the surface (the centre of a sphere).
    """
    p = np.asarray(point, dtype=np.float64).reshape(3)
    tri = np.asarray(mesh.triangles)
    near = closest_point_on_triangles(tri, np.broadcast_to(p, (len(tri), 3)).copy())
    d = np.linalg.norm(near - p, axis=1)
    dmin = float(d.min())
    scale = max(float(np.ptp(np.asarray(mesh.vertices), axis=0).max()), 1e-300)
    tie = np.flatnonzero(d <= dmin + 1e-9 * scale)
    f = int(tie[0])
    spread = float(np.linalg.norm(near[tie] - near[f], axis=1).max())
    return near[f][None], np.array([f]), np.array([dmin]), spread


def _closest_on_faces(mesh, points, face):
    """Closest point on the given face of each point (float64)."""
    tri = np.asarray(mesh.vertices)[np.asarray(mesh.faces)[face]]
    return closest_point_on_triangles(tri, points)


def closest_point_on_triangles(tri: np.ndarray, p: np.ndarray) -> np.ndarray:
    """Closest point (n, 3) of triangles ``tri`` (n, 3, 3) to points ``p`` (n, 3).

    Ericson's region test ("Real-Time Collision Detection", 5.1.5), vectorised. Written
    here because trimesh.triangles.closest_point misplaces points on needle-thin
    triangles (seen with 0.1 x 2.5 mm faces of a subdivided cylinder).
    """
    a, b, c = tri[:, 0], tri[:, 1], tri[:, 2]
    ab, ac, ap = b - a, c - a, p - a
    dot = lambda x, y: np.einsum("ij,ij->i", x, y)  # noqa: E731
    d1, d2 = dot(ab, ap), dot(ac, ap)
    bp = p - b
    d3, d4 = dot(ab, bp), dot(ac, bp)
    cp = p - c
    d5, d6 = dot(ab, cp), dot(ac, cp)
    va = d3 * d6 - d5 * d4
    vb = d5 * d2 - d1 * d6
    vc = d1 * d4 - d3 * d2
    out = np.empty_like(p)
    done = np.zeros(len(p), bool)

    def put(mask, value):
        m = mask & ~done
        out[m] = value[m] if np.ndim(value) == 2 else value
        done[m] = True

    with np.errstate(divide="ignore", invalid="ignore"):
        put((d1 <= 0) & (d2 <= 0), a)
        put((d3 >= 0) & (d4 <= d3), b)
        put((d6 >= 0) & (d5 <= d6), c)
        v = np.where(d1 - d3 != 0, d1 / (d1 - d3), 0.0)
        put((vc <= 0) & (d1 >= 0) & (d3 <= 0), a + v[:, None] * ab)
        w = np.where(d2 - d6 != 0, d2 / (d2 - d6), 0.0)
        put((vb <= 0) & (d2 >= 0) & (d6 <= 0), a + w[:, None] * ac)
        den = (d4 - d3) + (d5 - d6)
        w2 = np.where(den != 0, (d4 - d3) / den, 0.0)
        put((va <= 0) & ((d4 - d3) >= 0) & ((d5 - d6) >= 0), b + w2[:, None] * (c - b))
        s = va + vb + vc
        s = np.where(s != 0, s, 1.0)
        put(np.ones(len(p), bool), a + (vb / s)[:, None] * ab + (vc / s)[:, None] * ac)
    return out


def _barycentric(tri: np.ndarray, pts: np.ndarray) -> np.ndarray:
    """Barycentric coordinates (n, 3) of ``pts`` (n, d) in triangles ``tri`` (n, 3, d)."""
    a, b, c = tri[:, 0], tri[:, 1], tri[:, 2]
    v0, v1, v2 = b - a, c - a, pts - a
    d00 = np.einsum("ij,ij->i", v0, v0)
    d01 = np.einsum("ij,ij->i", v0, v1)
    d11 = np.einsum("ij,ij->i", v1, v1)
    d20 = np.einsum("ij,ij->i", v2, v0)
    d21 = np.einsum("ij,ij->i", v2, v1)
    den = d00 * d11 - d01 * d01
    den = np.where(np.abs(den) > 1e-300, den, 1e-300)
    v = (d11 * d20 - d01 * d21) / den
    w = (d00 * d21 - d01 * d20) / den
    return np.column_stack([1 - v - w, v, w])


def _surface_normals(mesh, face: np.ndarray, bary: np.ndarray) -> np.ndarray:
    vn = np.asarray(mesh.vertex_normals)
    n = np.einsum("nk,nkj->nj", bary, vn[np.asarray(mesh.faces)[face]])
    norm = np.linalg.norm(n, axis=1, keepdims=True)
    fn = np.asarray(mesh.face_normals)[face]
    return np.where(norm > 1e-12, n / np.maximum(norm, 1e-300), fn)


def arc_lengths(p: np.ndarray, q: np.ndarray, n_p: np.ndarray, n_q: np.ndarray) -> np.ndarray:
    """Length of the circular arc through ``p`` and ``q`` whose normals turn from ``n_p`` to ``n_q``:
    chord * (theta/2) / sin(theta/2). Exact on spheres and along circles of cylinders."""
    chord = np.linalg.norm(q - p, axis=1)
    cosang = np.clip(np.einsum("ij,ij->i", n_p, n_q), -1.0, 1.0)
    half = np.arccos(cosang) / 2
    factor = np.where(half > 1e-8, half / np.where(half > 1e-8, np.sin(half), 1.0), 1.0)
    return chord * factor


def layout_strain(layout: Layout, flat: np.ndarray, edges: np.ndarray) -> np.ndarray:
    """(E,) strain of ``edges`` (E, 2) of ``layout`` against ``flat`` (N, 2) coordinates."""
    if not len(edges):
        return np.zeros(0)
    i, j = edges[:, 0], edges[:, 1]
    lf = np.linalg.norm(flat[i] - flat[j], axis=1)
    ls = arc_lengths(layout.positions[i], layout.positions[j], layout.normals[i], layout.normals[j])
    return ls / np.where(lf > 0, lf, np.nan) - 1.0


def find_overlaps(positions: np.ndarray, module_ids: np.ndarray, min_distance: float) -> list:
    """Module pairs (a < b) that have taxels closer than ``min_distance`` metres."""
    if len(positions) < 2:
        return []
    pairs = cKDTree(positions).query_pairs(min_distance, output_type="ndarray")
    if not len(pairs):
        return []
    a, b = module_ids[pairs[:, 0]], module_ids[pairs[:, 1]]
    cross = a != b
    mp = np.unique(np.sort(np.column_stack([a[cross], b[cross]]), axis=1), axis=0)
    return [tuple(map(int, r)) for r in mp]


def find_overlaps_between(existing: Layout, positions: np.ndarray, module_ids: np.ndarray,
                          min_distance: float) -> list:
    """(existing_module, new_module) pairs with taxels closer than ``min_distance`` metres.

    existing : the layout already on the skin. positions : (n, 3) metres and module_ids :
    (n,) of the new taxels, in the same frame. A pair appears once.
    """
    if existing is None or len(existing) == 0 or len(positions) == 0:
        return []
    hits = cKDTree(np.asarray(existing.positions)).query_ball_point(np.asarray(positions), min_distance)
    counts = np.array([len(h) for h in hits])
    if not counts.sum():
        return []
    new = np.repeat(np.asarray(module_ids), counts)
    old = np.asarray(existing.module_ids)[np.concatenate([np.asarray(h, np.int64) for h in hits if len(h)])]
    mp = np.unique(np.column_stack([old, new]), axis=0)
    return [tuple(map(int, r)) for r in mp]


def _overlap_note(pairs: list) -> str:
    a = len({p[1] for p in pairs})
    b = len({p[0] for p in pairs})
    return (f"{a} module(s) of this patch overlap {b} module(s) already on the skin "
            f"({len(pairs)} pairs; taxels closer than {OVERLAP_FRACTION} pitch)")


def _at_notes(cp: np.ndarray, dist: float, spread: float) -> list:
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


def _tangent_basis(normal: np.ndarray, direction) -> tuple[np.ndarray, np.ndarray]:
    n = normal / np.linalg.norm(normal)
    if direction is None:
        helper = np.array([1.0, 0.0, 0.0]) if abs(n[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
        d = helper
    else:
        d = np.asarray(direction, dtype=np.float64).reshape(3)
    t = d - n * (d @ n)
    if np.linalg.norm(t) < 1e-9 * max(np.linalg.norm(d), 1e-300):
        raise InputError("direction is parallel to the surface normal at 'at'; give an in-plane direction",
                         key="direction")
    t1 = t / np.linalg.norm(t)
    return t1, np.cross(n, t1)


# --- log map ----------------------------------------------------------------------------------------
class LogMap:
    """The logarithmic map of a mesh at a surface point, and its inverse (the exponential map).

    mesh : trimesh.Trimesh (cleaned). at : (3,) metres. direction : (3,) or None.
    radius : float, metres, or None: crop the mesh to the connected part within
        this Euclidean distance of ``at`` before solving (faster for small patches).
    max_faces : int or None: solve on a copy simplified to about this many faces
        (vertex clustering or quadric decimation; see _decimate for the simplifiers without
        open3d) when the cropped mesh has more, then snap the mapped
        taxels to the full-resolution surface (the accuracy knob of the benchmark).
    resolution : metres or None: first split faces until no edge is longer than this (CAD
        meshes with long needle or fan faces give the heat method too few vertices; the split
        faces lie exactly on the old ones). ``place`` uses half the module pitch.
    After construction, ``uv`` (V, 2) holds the log coordinates of the (cropped)
    mesh's vertices in a frame whose x axis points along ``direction``
    (projected onto the tangent plane) and whose y axis is ``normal x x``.
    """

    def __init__(self, mesh, at, direction=None, radius: float | None = None, max_faces: int | None = None,
                 resolution: float | None = None):
        import potpourri3d as pp3d
        import trimesh

        at = np.asarray(at, dtype=np.float64).reshape(3)
        cp, face, dist, spread = _snap(mesh, at)
        self.notes = []  # worth a warning (the mesh was changed to be solvable)
        self.info = []  # how it was solved (no warning)
        self.at_distance = float(dist[0])
        self.notes += _at_notes(cp[0], float(dist[0]), spread)
        sub = mesh
        if radius is not None and np.isfinite(radius):
            # a face is kept when any point of it is within reach, not only a vertex: CAD meshes
            # have long faces (a cylinder's side from cap to cap) whose vertices are all far away
            tri = np.asarray(mesh.triangles)
            near = closest_point_on_triangles(tri, np.broadcast_to(cp[0], (len(tri), 3)).copy())
            keep_f = np.linalg.norm(near - cp[0], axis=1) <= radius
            keep_f[face[0]] = True
            if not keep_f.all():
                part = mesh.submesh([np.flatnonzero(keep_f)], append=True, repair=False)
                # keep the component that holds 'at'
                comp = trimesh.graph.connected_components(part.face_adjacency, nodes=np.arange(len(part.faces)))
                cpp, fpp, _, _ = _snap(part, cp[0])
                for c in comp:
                    if fpp[0] in set(np.asarray(c).ravel().tolist()):
                        part = part.submesh([np.asarray(c)], append=True, repair=False)
                        break
                sub = part
        if resolution is not None:
            sub = _refine(sub, float(resolution))
        sub, nsplit = _split_nonmanifold(sub)
        if nsplit:
            self.notes.append(f"{nsplit} faces around non-manifold edges were split apart")
        sub, nbow = _split_bowties(sub)
        if nbow:
            self.notes.append(f"{nbow} non-manifold (bowtie) vertices were split")
        self.surface = sub  # where the taxels land
        # the tangent frame at 'at' comes from the full-resolution surface
        cpf, facef, _, _ = _snap(sub, cp[0])
        trif = np.asarray(sub.vertices)[np.asarray(sub.faces)[facef]]
        normal = _surface_normals(sub, facef, _barycentric(trif, cpf))[0]
        if max_faces is not None and len(sub.faces) > max_faces:
            sub, note = _decimate(sub, int(max_faces))
            self.info.append(note)
        self.mesh = sub  # where the log map is solved
        cp, face, _, _ = _snap(sub, cp[0])
        self.at = cp[0]
        self.face = int(face[0])
        tri = np.asarray(sub.vertices)[np.asarray(sub.faces)[self.face]]
        bary = _barycentric(tri[None], cp)[0]
        src = int(np.asarray(sub.faces)[self.face][np.argmax(bary)])
        try:
            solver = pp3d.MeshVectorHeatSolver(np.asarray(sub.vertices), np.asarray(sub.faces))
            raw = np.asarray(solver.compute_log_map(src), dtype=np.float64)
        except RuntimeError as exc:
            if sub is self.surface:
                raise InputError(f"the log map cannot be solved on this mesh ({exc}); clean the mesh or "
                                 "use method='project'", key="mesh") from None
            # the simplified copy was not good enough for geometry-central: solve on the full mesh
            self.info.append("simplified mesh rejected by the solver; solved on the full mesh")
            sub = self.mesh = self.surface
            cp, face, _, _ = _snap(sub, cp[0])
            self.at, self.face = cp[0], int(face[0])
            tri = np.asarray(sub.vertices)[np.asarray(sub.faces)[self.face]]
            bary = _barycentric(tri[None], cp)[0]
            src = int(np.asarray(sub.faces)[self.face][np.argmax(bary)])
            solver = pp3d.MeshVectorHeatSolver(np.asarray(sub.vertices), np.asarray(sub.faces))
            raw = np.asarray(solver.compute_log_map(src), dtype=np.float64)
        # parts not connected to the source (split-off non-manifold fins) have no log coordinates
        self.reachable = np.isfinite(raw).all(axis=1)
        raw[~self.reachable] = 0.0
        bx, by, bn = (np.asarray(a) for a in solver.get_tangent_frames())
        t1, t2 = _tangent_basis(normal, direction)
        # the solver's log coordinates are in its own tangent basis (bx, by) at the source vertex;
        # express them in (t1, t2): a rotation, or a reflection if its basis is left-handed
        ex, ey = bx[src], by[src]
        m = np.array([[t1 @ ex, t1 @ ey], [t2 @ ex, t2 @ ey]])
        u, _, vt = np.linalg.svd(m)
        m = u @ vt
        uv = raw @ m.T
        # shift from the source vertex to the exact point 'at'
        at_uv = bary @ uv[np.asarray(sub.faces)[self.face]]
        self.uv = uv - at_uv
        self.normal = normal
        self.t1, self.t2 = t1, t2
        self._tree = None

    def exp(self, flat: np.ndarray):
        """Map flat coordinates (n, 2) to the surface.

        Returns ``(positions (n, 3), normals (n, 3), face (n,), found (n,) bool)``;
        where ``found`` is false the point lies outside the mesh (off an open
        boundary) and the position is the closest surface point of its
        tangent-plane extrapolation.
        """
        flat = np.asarray(flat, dtype=np.float64).reshape(-1, 2)
        F = np.asarray(self.mesh.faces)
        V = np.asarray(self.mesh.vertices)
        if self._tree is None:
            # per-mesh work, done once (fill calls exp dozens of times)
            self._tri2 = tri2 = self.uv[F]  # (F, 3, 2)
            area = np.cross(tri2[:, 1] - tri2[:, 0], tri2[:, 2] - tri2[:, 0])
            self._cent = tri2.mean(axis=1)
            self._rad = np.linalg.norm(tri2 - self._cent[:, None], axis=2).max(axis=1)
            good = area > 1e-16 * max(np.abs(area).max(), 1e-300)  # orientation kept, not folded
            # near the cut locus the log map is garbage: a face's image must be close to isometric
            t3 = V[F]
            l3 = np.linalg.norm(t3 - np.roll(t3, 1, axis=1), axis=2)
            l2 = np.linalg.norm(tri2 - np.roll(tri2, 1, axis=1), axis=2)
            ratio = l2 / np.maximum(l3, 1e-300)
            self._good = good & np.all((ratio > 0.5) & (ratio < 2.0), axis=1) & self.reachable[F].all(axis=1)
            self._tree = cKDTree(self._cent)
            self._geo = np.linalg.norm(self._cent, axis=1)
        tri2 = self._tri2
        n = len(flat)
        k = int(min(16, len(F)))
        _, cand = self._tree.query(flat, k)
        cand = cand.reshape(n, k)
        b = _barycentric(tri2[cand].reshape(-1, 3, 2), np.repeat(flat, k, axis=0)).reshape(n, k, 3)
        inside = (b.min(axis=2) >= -1e-9) & self._good[cand]
        # among the faces that contain the point, prefer the one nearest the source (before the cut locus)
        score = np.where(inside, self._geo[cand], np.inf)
        best = np.argmin(score, axis=1)
        found = np.isfinite(score[np.arange(n), best])
        if (~found).any():
            # the k nearest centroids can miss a big face: test every face whose disc holds the point
            miss = np.flatnonzero(~found)
            near = self._tree.query_ball_point(flat[miss], self._rad.max())
            counts = np.array([len(c) for c in near])
            if counts.sum():
                rows = np.repeat(np.arange(len(miss)), counts)
                fcs = np.concatenate([np.asarray(c, dtype=np.int64) for c in near if len(c)])
                bb = _barycentric(tri2[fcs], flat[miss][rows])
                ok = (bb.min(axis=1) >= -1e-9) & self._good[fcs]
                score = np.where(ok, self._geo[fcs], np.inf)
                # per missing point, the containing face nearest the source
                order = np.lexsort((score, rows))
                first = np.ones(len(order), bool)
                first[1:] = rows[order][1:] != rows[order][:-1]
                pick = order[first & np.isfinite(score[order])]
                q = miss[rows[pick]]
                cand[q, 0], b[q, 0], best[q], found[q] = fcs[pick], bb[pick], 0, True
        face = cand[np.arange(n), best]
        bary = b[np.arange(n), best]
        pos = np.einsum("nk,nkj->nj", bary, V[F[face]])
        nrm = _surface_normals(self.mesh, face, bary)
        if (~found).any():
            lost = np.flatnonzero(~found)
            guess = self.at + flat[lost, :1] * self.t1 + flat[lost, 1:] * self.t2
            cp, fc, _ = _closest(self.mesh, guess)
            tri = V[F[fc]]
            bb = _barycentric(tri, cp)
            pos[lost], face[lost] = cp, fc
            nrm[lost] = _surface_normals(self.mesh, fc, bb)
        if self.surface is not self.mesh:
            # solved on a decimated copy: move to the full-resolution surface
            pos, fc, _ = _closest(self.surface, pos)
            tri = np.asarray(self.surface.vertices)[np.asarray(self.surface.faces)[fc]]
            nrm = _surface_normals(self.surface, fc, _barycentric(tri, pos))
        return pos, nrm, face, found


# --- placement --------------------------------------------------------------------------------------
def _refine(mesh, resolution: float, max_faces: int = 300_000):
    """Midpoint-subdivide until no edge is longer than ``resolution`` (coarsened if that would
    exceed ``max_faces``); the new faces lie on the old ones, so the surface does not move."""
    e = mesh.edges_unique_length
    if not len(e) or e.max() <= resolution:
        return mesh
    t = np.asarray(mesh.triangles)
    longest = np.linalg.norm(t - np.roll(t, 1, axis=1), axis=2).max(axis=1)
    res = resolution
    while True:
        levels = np.ceil(np.log2(np.maximum(longest / res, 1.0)))
        if (4.0 ** levels).sum() <= max_faces:
            break
        res *= 1.5
    return mesh.subdivide_to_size(res, max_iter=int(levels.max()) + 2)


def _decimate(mesh, max_faces: int):
    """A coarser copy with about ``max_faces`` faces for the log-map solve, or ``mesh`` itself.

    Returns ``(mesh, note)``; ``note`` says which simplifier made the copy, or why none did.

    Two simplifiers are tried: vertex clustering on a voxel grid (roughly isotropic triangles,
    but it can tear or flip a closed surface) and quadric decimation (faithful on curved
    surfaces, but it leaves needle faces along the straight lines of ruled surfaces such as
    cylinders, where the heat method's log map breaks down). With open3d both are open3d's.
    Without it (inside Blender open3d is not bundled) only quadric decimation is tried, by trimesh
    when its optional fast-simplification back-end is installed; a numpy vertex clustering was
    tried here and dropped: it passes the checks below on a cylinder yet strains 2.6 % where the
    full mesh gives 0.05 %. The first copy that keeps the Euler
    characteristic, has consistent winding and well-shaped faces (95% with aspect ratio below 4)
    is used; otherwise the full (cropped) mesh is solved.
    """
    import trimesh

    h = float(np.sqrt(2.0 * mesh.area / max(max_faces, 1)))
    try:
        import open3d as o3d
    except ImportError:
        o3d = None
    if o3d is not None:
        def to_o3d(m):
            return o3d.geometry.TriangleMesh(o3d.utility.Vector3dVector(np.asarray(m.vertices, np.float64)),
                                             o3d.utility.Vector3iVector(np.asarray(m.faces, np.int32)))

        def o3d_out(d):
            d.remove_degenerate_triangles()
            d.remove_duplicated_triangles()
            d.remove_duplicated_vertices()
            d.remove_unreferenced_vertices()
            return trimesh.Trimesh(np.asarray(d.vertices), np.asarray(d.triangles), process=False, validate=False)

        makers = [("open3d vertex clustering", lambda: o3d_out(to_o3d(mesh).simplify_vertex_clustering(
                      voxel_size=h, contraction=o3d.geometry.SimplificationContraction.Average))),
                  ("open3d quadric decimation", lambda: o3d_out(to_o3d(mesh).simplify_quadric_decimation(
                      target_number_of_triangles=int(max_faces))))]
        tried = "open3d"
    else:
        try:
            import fast_simplification  # noqa: F401  (trimesh's quadric back-end)

            makers = [("quadric decimation (trimesh + fast-simplification; open3d not installed)",
                       lambda: mesh.simplify_quadric_decimation(face_count=int(max_faces)))]
            tried = "open3d not installed; fast-simplification tried"
        except ImportError:
            makers = []
            tried = "neither open3d nor fast-simplification is installed"
    chi = _euler(mesh)
    for name, make in makers:
        out = make()
        if len(out.faces) < 100:
            continue
        out, _ = clean_mesh(out)
        out, _ = _split_nonmanifold(out)
        out, _ = _split_bowties(out)
        if _euler(out) == chi and out.is_winding_consistent and np.percentile(_aspect(out), 95) < 4.0:
            return out, f"log map solved on a copy simplified by {name} to {len(out.faces)} faces"
    return mesh, (f"no faithful simplified copy with ~{max_faces} faces ({tried}); "
                  f"log map solved on the full cropped mesh ({len(mesh.faces)} faces)")


def _aspect(mesh) -> np.ndarray:
    """Longest edge squared over the area of an equilateral triangle's (1 for equilateral)."""
    t = np.asarray(mesh.triangles)
    longest = np.linalg.norm(t - np.roll(t, 1, axis=1), axis=2).max(axis=1)
    return longest ** 2 * np.sqrt(3) / 4 / np.maximum(mesh.area_faces, 1e-300)


def _euler(mesh) -> int:
    f = np.asarray(mesh.faces)
    e = np.unique(np.sort(np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]]), axis=1), axis=0)
    return int(len(np.unique(f)) - len(e) + len(f))


def _as_patch(patch, module) -> Patch:
    if isinstance(patch, Patch):
        return patch
    return make_patch(str(patch), module)


def place(mesh, patch="hexagon", at=(0.0, 0.0, 0.0), direction=None, *, module: str = "cyskin10",
          offset: float = 0.0, method: str = "logmap", region=None,
          logmap: "LogMap | None" = None, max_faces: int | None = 20_000,
          existing: Layout | None = None) -> tuple[Layout, PlacementReport]:
    """Conform ``patch`` to ``mesh`` around the surface point nearest ``at``.

    mesh : trimesh.Trimesh, metres (open, non-manifold or with degenerate faces is fine;
        it is cleaned first). patch : a :class:`Patch` or ``"triangle"``, ``"hexagon"``,
        ``"strip:N"`` (centred on ``at``). at : (3,) metres. direction : (3,) in-plane
        direction of the patch's x axis (default: world x projected). module : module type
        for named patches. offset : metres along the normal (e.g. a PCB's thickness).
    method : ``"logmap"`` or ``"project"``. region : optional (F,) bool face mask of
        ``mesh`` for the coverage figure (default: faces within the patch's radius).
    logmap : a :class:`LogMap` of this mesh at this point to reuse (several patches, one solve).
    max_faces : when the (cropped) mesh has more faces, solve the log map on a copy simplified
        to about this many faces by vertex clustering, then snap the taxels to the full mesh
        (None: always the full mesh). The benchmark shows what it costs in accuracy.
    existing : the skin already on this mesh (same frame). Modules of the new patch with
        taxels closer than ``OVERLAP_FRACTION`` pitch to its taxels are reported in
        ``report.existing_overlaps`` (and counted in ``as_dict()["overlaps"]``) with a warning;
        the new layout itself never contains the existing taxels (merge it yourself).

    Returns ``(layout, report)``; ``layout.meta["placement"]`` holds ``report.as_dict()``.
    """
    import time

    t0 = time.perf_counter()
    if method not in ("logmap", "project"):
        raise InputError(f"unknown method {method!r}; use logmap or project", key="method")
    p = _as_patch(patch, module)
    if len(p) == 0:
        raise InputError("the patch has no taxels", key="patch")
    at = np.asarray(at, dtype=np.float64).reshape(-1)
    if at.shape != (3,) or not np.isfinite(at).all():
        raise InputError(f"'at' must be 3 finite numbers, got {at.tolist()}", key="at")
    clean, notes = clean_mesh(mesh) if logmap is None else (mesh, [])
    extent = float(np.hypot(*p.flat.T).max()) + p.module.pitch
    if method == "logmap":
        lm = logmap if logmap is not None else LogMap(clean, at, direction, radius=1.5 * extent + 2 * p.module.pitch,
                                                      max_faces=max_faces, resolution=p.module.pitch / 2)
        notes += lm.notes
        pos, nrm, face, found = lm.exp(p.flat)
        surf_mesh = lm.surface
        uvmap = lm
    else:
        cp, face0, dist0, spread = _snap(clean, at)
        notes += _at_notes(cp[0], float(dist0[0]), spread)
        tri = np.asarray(clean.vertices)[np.asarray(clean.faces)[face0]]
        normal = _surface_normals(clean, face0, _barycentric(tri, cp))[0]
        t1, t2 = _tangent_basis(normal, direction)
        guess = cp[0] + p.flat[:, :1] * t1 + p.flat[:, 1:] * t2
        pos, face, _ = _closest(clean, guess)
        tri = np.asarray(clean.vertices)[np.asarray(clean.faces)[face]]
        nrm = _surface_normals(clean, face, _barycentric(tri, pos))
        # off an open boundary: the closest point is on the boundary, far from the tangent-plane point
        boundary = _boundary_faces(clean)
        found = ~(boundary[face] & (np.linalg.norm(pos - guess, axis=1) > 0.5 * p.module.pitch))
        surf_mesh = clean
        uvmap = None
    _, _, dist = _closest(surf_mesh, pos)
    pos = pos + offset * nrm
    meta = {"placement_method": method, "at": at.tolist(),
            "direction": None if direction is None else np.asarray(direction, float).tolist(),
            "offset_m": float(offset)}
    layout = p.to_layout(pos, nrm, meta)
    strain = layout_strain(layout.subset(slice(None)) if offset == 0 else _unoffset(layout, offset), p.flat,
                           p.module_edges)
    mstrain = np.zeros(p.n_modules)
    if len(strain):
        np.maximum.at(mstrain, p.module_ids[p.module_edges[:, 0]], np.abs(np.nan_to_num(strain)))
    overlaps = find_overlaps(layout.positions, layout.module_ids, OVERLAP_FRACTION * p.module.pitch)
    ex_overlaps = find_overlaps_between(existing, layout.positions, layout.module_ids,
                                        OVERLAP_FRACTION * p.module.pitch)
    if ex_overlaps:
        notes.append(_overlap_note(ex_overlaps))
    off = np.flatnonzero(~found)
    if len(off):
        notes.append(f"{len(off)} taxels fall outside the mapped surface (off an open boundary, or past "
                     "the cut locus of a closed one where the log map is unreliable)")
    cov = _coverage(clean, p, uvmap, region, extent)
    info = list(uvmap.info) if uvmap is not None else []
    report = PlacementReport(strain, mstrain, overlaps, off, cov, float(dist.max()), method,
                             time.perf_counter() - t0, notes + info, ex_overlaps)
    layout.meta["placement"] = report.as_dict()
    for msg in notes:
        warnings.warn(f"place: {msg}", LayoutWarning, stacklevel=2)
    return layout, report


def _unoffset(layout: Layout, offset: float) -> Layout:
    out = layout.subset(slice(None))
    out.positions = layout.positions - offset * layout.normals
    return out


def _boundary_faces(mesh) -> np.ndarray:
    f = np.asarray(mesh.faces)
    e = np.sort(np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]]), axis=1)
    _, inv, cnt = np.unique(e, axis=0, return_inverse=True, return_counts=True)
    on = cnt[inv.ravel()] == 1
    out = np.zeros(len(f), bool)
    out[np.arange(3 * len(f))[on] % len(f)] = True
    return out


def _coverage(mesh, patch: Patch, lm, region, extent) -> float:
    """Fraction of the region's area under module outlines (in the flat domain of the log map)."""
    if lm is None:
        return float("nan")
    F = np.asarray(lm.mesh.faces)
    area = lm.mesh.area_faces
    cent = lm.uv[F].mean(axis=1)
    reach = lm.reachable[F].all(axis=1)
    if region is None:
        sel = (np.hypot(*cent.T) <= float(np.hypot(*patch.flat.T).max())) & reach
    else:
        region = np.asarray(region, dtype=bool)
        if len(region) != len(mesh.faces):
            raise InputError(f"region has {len(region)} entries, the mesh {len(mesh.faces)} faces", key="region")
        # the log map's mesh is a cleaned crop: match faces by centroid
        c3 = np.asarray(lm.mesh.triangles_center)
        _, near = cKDTree(np.asarray(mesh.triangles_center)).query(c3)
        sel = region[near] & reach
    if not sel.any():
        return float("nan")
    inside = points_in_outlines(cent[sel], patch)
    return float(area[sel][inside].sum() / area[sel].sum())


def points_in_outlines(points: np.ndarray, patch: Patch) -> np.ndarray:
    """(n,) bool: which flat points (n, 2) lie inside some module outline of ``patch``."""
    out = np.zeros(len(points), bool)
    if not patch.n_modules or not len(points):
        return out
    outl = patch.outlines()  # (M, m, 2)
    tree = cKDTree(patch.poses[:, 1:])
    cand = tree.query_ball_point(points, patch.module.radius)
    rows = np.repeat(np.arange(len(points)), [len(c) for c in cand])
    mods = np.concatenate([np.asarray(c, dtype=np.int64) for c in cand]) if len(rows) else np.zeros(0, np.int64)
    if not len(rows):
        return out
    poly = outl[mods]  # (K, m, 2), counter-clockwise convex outlines
    edge = np.roll(poly, -1, axis=1) - poly
    rel = points[rows][:, None, :] - poly
    cross = edge[..., 0] * rel[..., 1] - edge[..., 1] * rel[..., 0]
    ins = np.all(cross >= 0, axis=1) | np.all(cross <= 0, axis=1)
    out[rows[ins]] = True
    return out


def fill(mesh, at, direction=None, *, module: str = "cyskin10", region=None, radius: float | None = None,
         offset: float = 0.0, max_strain: float = 0.05,
         max_faces: int | None = 20_000, existing: Layout | None = None,
         angles=tuple(np.radians(np.arange(0, 180, 30))), offsets: int = 2,
         refine_offsets: int = 4) -> tuple[Layout, PlacementReport]:
    """Tile a region of ``mesh`` with whole modules, without overlap, by the log map at ``at``.

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
        _, near = cKDTree(np.asarray(mesh.triangles_center)).query(np.asarray(clean.triangles_center))
        creg = region[near]
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
