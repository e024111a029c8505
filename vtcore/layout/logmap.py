"""The logarithmic map of a mesh at a surface point and its inverse, the exponential map.

Computed with the vector heat method (Sharp, Soliman, Crane 2019) as implemented by
potpourri3d (geometry-central): geodesic distance and direction from the source are kept
exactly. ``exp`` locates flat points in the mapped triangles through a spatial index.
"""

from __future__ import annotations

import numpy as np

from ..errors import InputError
from ..geometry import barycentric, closest_point_on_triangles, cross2
from .locate import TriangleGrid
from .repair import refine, split_bowties, split_nonmanifold
from .simplify import decimate
from .surface import at_notes, closest_points, frame_at, snap, surface_normals

class PreparedSurface:
    """A mesh made ready for log maps, once, so that several charts share the work.

    mesh : trimesh.Trimesh (cleaned), metres. resolution : metres or None: first split faces
    until no edge is longer than this (CAD meshes with long needle or fan faces give the heat
    method too few vertices; the split faces lie exactly on the old ones). max_faces : int or
    None: solve on a copy simplified to about this many faces when the mesh has more (the
    taxels still land on the full-resolution surface).

    ``surface`` is where taxels land, ``mesh`` where log maps are solved (the same object
    unless simplified); ``notes`` say what was repaired, ``info`` how it was solved.
    """

    def __init__(self, mesh, *, resolution: float | None = None, max_faces: int | None = None):
        self.notes, self.info = [], []
        sub = mesh
        if resolution is not None:
            n0 = len(sub.faces)
            sub = refine(sub, float(resolution))
            if len(sub.faces) > n0:
                self.info.append(f"{n0} faces subdivided to {len(sub.faces)} (no edge longer than "
                                 f"{1e3 * float(resolution):.2f} mm) for the log map")
        sub, nsplit = split_nonmanifold(sub)
        if nsplit:
            self.notes.append(f"{nsplit} faces around non-manifold edges were split apart")
        sub, nbow = split_bowties(sub)
        if nbow:
            self.notes.append(f"{nbow} non-manifold (bowtie) vertices were split")
        self.surface = sub
        if max_faces is not None and len(sub.faces) > max_faces:
            sub, note = decimate(sub, int(max_faces))
            self.info.append(note)
        self.mesh = sub
        self._solver = None
        self._graph = None
        self._geom = None

    def path_graph(self):
        """(V, V) scipy.sparse CSR graph of ``mesh`` for shortest paths that stay close to geodesic
        distances: the mesh edges plus, across each interior edge, the straight line between the
        two opposite vertices in the unfolded face pair (where it crosses the shared edge).

        Edges alone overestimate the geodesic distance by up to sqrt(2) on the grid-like
        triangulations of CAD and primitive meshes (a path along a diagonal the mesh lacks); the
        extra lines bring that under ~8 %, so the 1.15 and 1.25 factors of
        :meth:`LogMap.trusted_radius` and :meth:`LogMap.consistent` hold. Built once per surface.
        """
        if getattr(self, "_graph", None) is None:
            import scipy.sparse as sp

            m = self.mesh
            V = np.asarray(m.vertices)
            F = np.asarray(m.faces)
            e = np.concatenate([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]])
            w = np.linalg.norm(V[e[:, 0]] - V[e[:, 1]], axis=1)
            adj = np.asarray(m.face_adjacency_edges).reshape(-1, 2)
            opp = np.asarray(m.face_adjacency_unshared).reshape(-1, 2)
            if len(adj):
                a, b = V[adj[:, 0]], V[adj[:, 1]]
                ab = b - a
                L = np.maximum(np.linalg.norm(ab, axis=1), 1e-300)
                ex = ab / L[:, None]
                # each opposite vertex in the frame (along ab, distance from the line ab)
                rel = [V[opp[:, k]] - a for k in (0, 1)]
                x = [np.einsum("ij,ij->i", r, ex) for r in rel]
                y = [np.linalg.norm(r - x_[:, None] * ex, axis=1) for r, x_ in zip(rel, x)]
                ysum = np.maximum(y[0] + y[1], 1e-300)
                cross = x[0] + (x[1] - x[0]) * y[0] / ysum  # where the unfolded line meets ab
                ok = (cross > 0) & (cross < L) & (y[0] > 0) & (y[1] > 0)
                d = np.hypot(x[1] - x[0], ysum)
                e = np.concatenate([e, opp[ok]])
                w = np.concatenate([w, d[ok]])
            # one entry per vertex pair, the shortest (a coo matrix would sum duplicates: edges of
            # duplicated or inconsistently oriented faces)
            e = np.sort(e, axis=1)
            order = np.lexsort((w, e[:, 1], e[:, 0]))
            e, w = e[order], w[order]
            first = np.ones(len(e), bool)
            first[1:] = np.any(e[1:] != e[:-1], axis=1)
            n = len(V)
            self._graph = sp.csr_matrix((w[first], (e[first, 0], e[first, 1])), shape=(n, n))
        return self._graph

    def face_geometry(self) -> dict:
        """What the log maps' checks need of ``mesh``'s own faces, computed once for all charts:
        ``l3`` (F, 3) edge lengths (edge k from corner k-1 to k), ``l3max`` (F,) the longest, ``h``
        their median, ``alt`` (F,) altitude over the longest edge, ``edge01`` the median length of
        the faces' first edges (metres)."""
        if self._geom is None:
            F = np.asarray(self.mesh.faces)
            V = np.asarray(self.mesh.vertices)
            t3 = V[F]
            l3 = np.linalg.norm(t3 - np.roll(t3, 1, axis=1), axis=2)
            l3max = np.maximum(np.maximum(l3[:, 0], l3[:, 1]), l3[:, 2])
            alt = np.linalg.norm(np.cross(t3[:, 1] - t3[:, 0], t3[:, 2] - t3[:, 0]), axis=1) / \
                np.maximum(l3max, 1e-300)
            self._geom = {"l3": l3, "l3max": l3max, "h": float(np.median(l3)), "alt": alt,
                          "edge01": float(np.median(np.linalg.norm(V[F[:, 0]] - V[F[:, 1]], axis=1)))}
        return self._geom

    def solver(self):
        """The vector heat solver of ``mesh`` (factored once; geometry-central caches its
        factorizations, so each further log map costs back-substitutions only)."""
        import potpourri3d as pp3d

        if self._solver is None:
            try:
                self._solver = pp3d.MeshVectorHeatSolver(np.asarray(self.mesh.vertices), np.asarray(self.mesh.faces))
            except RuntimeError as exc:
                if self.mesh is self.surface:
                    raise InputError(f"the log map cannot be solved on this mesh ({exc}); clean the mesh or "
                                     "use method='project'", key="mesh") from None
                # the simplified copy was not good enough for geometry-central: solve on the full mesh
                self.info.append("simplified mesh rejected by the solver; solved on the full mesh")
                self.mesh = self.surface
                self._graph = self._geom = None  # both were of the simplified copy
                return self.solver()
        return self._solver


def crop(mesh, point: np.ndarray, face: int, radius: float):
    """The connected part of ``mesh`` holding ``face`` among the faces with a point within
    ``radius`` metres (Euclidean) of ``point`` (3,). A face counts when any point of it is near,
    not only a vertex: CAD meshes have long faces (a cylinder's side from cap to cap)."""
    import trimesh

    tri = np.asarray(mesh.triangles)
    near = closest_point_on_triangles(tri, np.broadcast_to(point, (len(tri), 3)).copy())
    keep_f = np.linalg.norm(near - point, axis=1) <= radius
    keep_f[face] = True

    def longest_edge(m):
        t = np.asarray(m.triangles)
        return float(np.linalg.norm(t - np.roll(t, 1, axis=1), axis=2).max())

    if keep_f.all():
        # every face reaches into the ball, but one may still run far beyond it (a box with a vertex
        # pulled out a metre: its long faces all pass near the patch)
        if longest_edge(mesh) <= radius:
            return mesh
        part = mesh
    else:
        part = mesh.submesh([np.flatnonzero(keep_f)], append=True, repair=False)
    longest = longest_edge(part)
    while longest > radius:
        # faces far longer than the ball (a 1 m box side under a 40 mm patch) would be subdivided
        # to the module pitch along their whole length: split them (at most 8x finer per pass, so a
        # 100 m face costs a few passes of a few hundred faces) and keep only the pieces that
        # reach into the ball
        part = refine(part, max(radius / 4, longest / 8))
        tri = np.asarray(part.triangles)
        near = closest_point_on_triangles(tri, np.broadcast_to(point, (len(tri), 3)).copy())
        part = part.submesh([np.flatnonzero(np.linalg.norm(near - point, axis=1) <= radius)], append=True,
                            repair=False)
        before, longest = longest, longest_edge(part)
        if longest > 0.9 * before:  # refine's face budget stopped it: go on with what there is
            break
    comp = trimesh.graph.connected_components(part.face_adjacency, nodes=np.arange(len(part.faces)))
    _, fpp, _, _ = snap(part, point)
    for c in comp:
        if fpp[0] in set(np.asarray(c).ravel().tolist()):
            return part.submesh([np.asarray(c)], append=True, repair=False)
    return part


class LogMap:
    """The logarithmic map of a mesh at a surface point, and its inverse (the exponential map).

    mesh : trimesh.Trimesh (cleaned). at : (3,) metres. direction : (3,) or None.
    radius : float, metres, or None: crop the mesh to the connected part within
        this Euclidean distance of ``at`` before solving (faster for small patches).
    max_faces, resolution : see :class:`PreparedSurface` (``place`` uses half the module pitch).
    prepared : a :class:`PreparedSurface` of ``mesh`` to reuse (several charts, one preparation
        and one factorization); ``radius``, ``max_faces`` and ``resolution`` are then ignored.
    After construction, ``uv`` (V, 2) holds the log coordinates of the (cropped)
    mesh's vertices in a frame whose x axis points along ``direction``
    (projected onto the tangent plane) and whose y axis is ``normal x x``.
    """

    def __init__(self, mesh, at, direction=None, radius: float | None = None, max_faces: int | None = None,
                 resolution: float | None = None, prepared: PreparedSurface | None = None):
        at = np.asarray(at, dtype=np.float64).reshape(3)
        self.notes = []  # worth a warning (the mesh was changed to be solvable)
        self.info = []  # how it was solved (no warning)
        if prepared is None:
            cp, face, dist, spread = snap(mesh, at)
            self.at_distance = float(dist[0])
            self.notes += at_notes(cp[0], float(dist[0]), spread)
            sub = mesh if radius is None or not np.isfinite(radius) else crop(mesh, cp[0], int(face[0]), radius)
            prepared = PreparedSurface(sub, resolution=resolution, max_faces=max_faces)
            self.notes += prepared.notes
            self.info += prepared.info
            point = cp[0]
        else:
            point = at
        solver = prepared.solver()
        self.prepared = prepared
        self.surface = sub = prepared.surface  # where the taxels land
        # the tangent frame at 'at' comes from the full-resolution surface
        cpf, facef, distf, _ = snap(sub, point)
        if not hasattr(self, "at_distance"):  # a prepared surface: 'at' is measured on it
            self.at_distance = float(distf[0])
        trif = np.asarray(sub.vertices)[np.asarray(sub.faces)[facef]]
        normal = surface_normals(sub, facef, barycentric(trif, cpf))[0]
        self.mesh = sub = prepared.mesh  # where the log map is solved
        cp, face, _, _ = snap(sub, cpf[0])
        self.at = cp[0]
        self.face = int(face[0])
        tri = np.asarray(sub.vertices)[np.asarray(sub.faces)[self.face]]
        bary = barycentric(tri[None], cp)[0]
        src = int(np.asarray(sub.faces)[self.face][np.argmax(bary)])
        raw = np.asarray(solver.compute_log_map(src), dtype=np.float64)
        # parts not connected to the source (split-off non-manifold fins) have no log coordinates
        self.reachable = np.isfinite(raw).all(axis=1)
        raw[~self.reachable] = 0.0
        bx, by, bn = (np.asarray(a) for a in solver.get_tangent_frames())
        t1, t2 = frame_at(normal, direction)
        # the solver's log coordinates are in its own tangent basis (bx, by) at the source vertex;
        # express them in (t1, t2): a rotation, or a reflection if its basis is left-handed
        ex, ey = bx[src], by[src]
        m = np.array([[t1 @ ex, t1 @ ey], [t2 @ ex, t2 @ ey]])
        if not (np.isfinite(m).all() and np.isfinite(normal).all()):
            # geometry-central gives no tangent frame at a vertex of degenerate or inconsistently
            # wound faces (a mangled OBJ): say so rather than fail in the SVD
            raise InputError("the surface has no tangent plane at 'at' (degenerate or inconsistently "
                             "wound faces there); repair the mesh or choose another point", key="at")
        u, _, vt = np.linalg.svd(m)
        m = u @ vt
        uv = raw @ m.T
        # shift from the source vertex to the exact point 'at'
        at_uv = bary @ uv[np.asarray(sub.faces)[self.face]]
        self.uv = uv - at_uv
        self.normal = normal
        self.t1, self.t2 = t1, t2
        self._grid = None

    def trusted_radius(self, band: float = 0.25, faces: np.ndarray | None = None) -> float:
        """Geodesic radius (metres) within which the map is trusted: up to the nearest face whose
        image is folded or stretched more than ``band`` (25 %) against the surface, which is where
        the cut locus (or strong curvature) starts; inf when no face is. ``faces`` (F,) bool of
        ``mesh``: only these faces count (the region a fill may use). See :meth:`index`."""
        self.index()
        bad = self._reach & (self._folded | (self._stretch > band) | ~self._consistent)
        if faces is not None:  # only the faces that may carry taxels count (a fill's region)
            bad &= np.asarray(faces, bool)
        # a face's distance: its farthest vertex's in the map, or its Euclidean distance (a lower
        # bound of the geodesic one) if larger: at the cut locus the heat method averages opposite
        # directions, so a vertex there can map next to the source
        if not bad.any():
            return float("inf")
        F = np.asarray(self.mesh.faces)[bad]
        V = np.asarray(self.mesh.vertices)
        far = np.maximum(np.linalg.norm(self.uv[F], axis=2).max(axis=1),
                         np.linalg.norm(V[F] - self.at, axis=2).min(axis=1))
        # and the shortest path along mesh edges, which overestimates the geodesic distance by
        # at most ~15 % on meshes of fair triangles (the 3-D distance is far too short round a
        # thin link: 2 r against pi r to the cut locus of a cylinder)
        path = self.edge_distance()
        far = np.maximum(far, path[F].min(axis=1) / 1.15)
        return float(far.min())

    def consistent(self) -> np.ndarray:
        """(V,) bool: vertices whose log-map distance agrees with their distance along mesh edges
        (at least 1/1.25 of it, less two typical edges): false at the cut locus's garbage."""
        if getattr(self, "_cons", None) is None:
            h = self.prepared.face_geometry()["edge01"]
            self._cons = np.linalg.norm(self.uv, axis=1) >= self.edge_distance() / 1.25 - 2 * h
        return self._cons

    def edge_distance(self) -> np.ndarray:
        """(V,) metres from the source point along the surface's path graph (inf where
        unreachable): scipy's Dijkstra on :meth:`PreparedSurface.path_graph`, computed once."""
        if getattr(self, "_path", None) is None:
            from scipy.sparse.csgraph import dijkstra

            V = np.asarray(self.mesh.vertices)
            src = np.asarray(self.mesh.faces)[self.face]
            d0 = np.linalg.norm(V[src] - self.at, axis=1)
            dist = dijkstra(self.prepared.path_graph(), directed=False, indices=src)
            self._path = (dist + d0[:, None]).min(axis=0)
        return self._path

    def index(self) -> TriangleGrid:
        """The point-location index over the mapped faces (built once; ``exp`` uses it)."""
        if self._grid is None:
            F = np.asarray(self.mesh.faces)
            tri2 = self.uv[F]  # (F, 3, 2)
            area = cross2(tri2[:, 1] - tri2[:, 0], tri2[:, 2] - tri2[:, 0])
            good = area > 1e-16 * max(np.abs(area).max(), 1e-300)  # orientation kept, not folded
            # near the cut locus the log map is garbage: a face's image must be close to isometric
            geom = self.prepared.face_geometry()
            l3, h = geom["l3"], geom["h"]
            l2 = np.linalg.norm(tri2 - np.roll(tri2, 1, axis=1), axis=2)
            # edge length error against the face's size (not the edge's: CAD needles have edges
            # a hundred times shorter than their longest, where the map's small absolute error
            # would look like a large ratio)
            err = np.abs(l2 - l3)
            self._stretch = np.maximum(np.maximum(err[:, 0], err[:, 1]), err[:, 2]) / np.maximum(geom["l3max"], h)
            self._reach = self.reachable[F].all(axis=1)
            # near the cut locus the heat method averages opposite directions and a vertex can map
            # next to the source: a face whose map distance is far below its distance along mesh
            # edges (which overestimates the geodesic one by ~15 % at most) is not used
            self._consistent = self.consistent()[F].all(axis=1)
            self._usable = good & (self._stretch < 0.5) & self._reach & self._consistent
            # a folded sliver (altitude under a fifth of the typical edge) is rounding, not the cut locus
            self._folded = ~good & (geom["alt"] > 0.2 * h)
            self._geo = np.linalg.norm(tri2.mean(axis=1), axis=1)
            # among the faces that contain a point, the one nearest the source (before the cut locus)
            self._grid = TriangleGrid(tri2, self._usable, self._geo)
        return self._grid

    def exp(self, flat: np.ndarray, fallback: bool = True, on_surface: bool = True):
        """Map flat coordinates (n, 2) to the surface.

        Returns ``(positions (n, 3), normals (n, 3), face (n,), found (n,) bool)``;
        where ``found`` is false the point lies outside the mesh (off an open
        boundary) and the position is the closest surface point of its
        tangent-plane extrapolation (``fallback=False``: left at a vertex of the
        face 0, for callers that drop such points anyway). Memory: O(n) plus the index (bounded, see
        :mod:`vtcore.layout.locate`); no (points x faces) array. ``on_surface=False`` leaves the
        points on the mesh the map is solved on when that is a simplified copy (cheaper: for
        callers that only compare candidates, such as the fill's tiling tries).
        """
        flat = np.asarray(flat, dtype=np.float64).reshape(-1, 2)
        F = np.asarray(self.mesh.faces)
        V = np.asarray(self.mesh.vertices)
        face, bary, found = self.index().locate(flat)
        pos = np.einsum("nk,nkj->nj", bary, V[F[face]])
        nrm = surface_normals(self.mesh, face, bary)
        if fallback and (~found).any():
            lost = np.flatnonzero(~found)
            guess = self.at + flat[lost, :1] * self.t1 + flat[lost, 1:] * self.t2
            cp, fc, _ = closest_points(self.mesh, guess)
            tri = V[F[fc]]
            bb = barycentric(tri, cp)
            pos[lost], face[lost] = cp, fc
            nrm[lost] = surface_normals(self.mesh, fc, bb)
        if on_surface:
            pos, nrm = self.to_surface(pos, nrm)
        return pos, nrm, face, found

    def to_surface(self, pos: np.ndarray, nrm: np.ndarray):
        """``(positions (n, 3), normals (n, 3))``: points ``pos`` (n, 3) of the mesh the map is solved on
        (with their normals ``nrm``) moved to the full-resolution surface when that mesh is a
        simplified copy (what :meth:`exp` does unless ``on_surface=False``; point by point, so a
        caller may map many points cheaply and move only those it keeps)."""
        if self.surface is self.mesh or not len(pos):
            return pos, nrm
        # solved on a decimated copy: move to the full-resolution surface
        pos, fc, _ = closest_points(self.surface, pos)
        tri = np.asarray(self.surface.vertices)[np.asarray(self.surface.faces)[fc]]
        return pos, surface_normals(self.surface, fc, barycentric(tri, pos))
