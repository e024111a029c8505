"""The logarithmic map of a mesh at a surface point and its inverse, the exponential map.

Computed with the vector heat method (Sharp, Soliman, Crane 2019) as implemented by
potpourri3d (geometry-central): geodesic distance and direction from the source are kept
exactly. ``exp`` locates flat points in the mapped triangles through a spatial index.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

from ..errors import InputError
from ..geometry import barycentric, closest_point_on_triangles, cross2
from .repair import decimate, refine, split_bowties, split_nonmanifold
from .surface import at_notes, closest_points, frame_at, snap, surface_normals

class LogMap:
    """The logarithmic map of a mesh at a surface point, and its inverse (the exponential map).

    mesh : trimesh.Trimesh (cleaned). at : (3,) metres. direction : (3,) or None.
    radius : float, metres, or None: crop the mesh to the connected part within
        this Euclidean distance of ``at`` before solving (faster for small patches).
    max_faces : int or None: solve on a copy simplified to about this many faces
        (vertex clustering or quadric decimation; see decimate for the simplifiers without
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
        cp, face, dist, spread = snap(mesh, at)
        self.notes = []  # worth a warning (the mesh was changed to be solvable)
        self.info = []  # how it was solved (no warning)
        self.at_distance = float(dist[0])
        self.notes += at_notes(cp[0], float(dist[0]), spread)
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
                cpp, fpp, _, _ = snap(part, cp[0])
                for c in comp:
                    if fpp[0] in set(np.asarray(c).ravel().tolist()):
                        part = part.submesh([np.asarray(c)], append=True, repair=False)
                        break
                sub = part
        if resolution is not None:
            sub = refine(sub, float(resolution))
        sub, nsplit = split_nonmanifold(sub)
        if nsplit:
            self.notes.append(f"{nsplit} faces around non-manifold edges were split apart")
        sub, nbow = split_bowties(sub)
        if nbow:
            self.notes.append(f"{nbow} non-manifold (bowtie) vertices were split")
        self.surface = sub  # where the taxels land
        # the tangent frame at 'at' comes from the full-resolution surface
        cpf, facef, _, _ = snap(sub, cp[0])
        trif = np.asarray(sub.vertices)[np.asarray(sub.faces)[facef]]
        normal = surface_normals(sub, facef, barycentric(trif, cpf))[0]
        if max_faces is not None and len(sub.faces) > max_faces:
            sub, note = decimate(sub, int(max_faces))
            self.info.append(note)
        self.mesh = sub  # where the log map is solved
        cp, face, _, _ = snap(sub, cp[0])
        self.at = cp[0]
        self.face = int(face[0])
        tri = np.asarray(sub.vertices)[np.asarray(sub.faces)[self.face]]
        bary = barycentric(tri[None], cp)[0]
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
            cp, face, _, _ = snap(sub, cp[0])
            self.at, self.face = cp[0], int(face[0])
            tri = np.asarray(sub.vertices)[np.asarray(sub.faces)[self.face]]
            bary = barycentric(tri[None], cp)[0]
            src = int(np.asarray(sub.faces)[self.face][np.argmax(bary)])
            solver = pp3d.MeshVectorHeatSolver(np.asarray(sub.vertices), np.asarray(sub.faces))
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
            area = cross2(tri2[:, 1] - tri2[:, 0], tri2[:, 2] - tri2[:, 0])
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
        b = barycentric(tri2[cand].reshape(-1, 3, 2), np.repeat(flat, k, axis=0)).reshape(n, k, 3)
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
                bb = barycentric(tri2[fcs], flat[miss][rows])
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
        nrm = surface_normals(self.mesh, face, bary)
        if (~found).any():
            lost = np.flatnonzero(~found)
            guess = self.at + flat[lost, :1] * self.t1 + flat[lost, 1:] * self.t2
            cp, fc, _ = closest_points(self.mesh, guess)
            tri = V[F[fc]]
            bb = barycentric(tri, cp)
            pos[lost], face[lost] = cp, fc
            nrm[lost] = surface_normals(self.mesh, fc, bb)
        if self.surface is not self.mesh:
            # solved on a decimated copy: move to the full-resolution surface
            pos, fc, _ = closest_points(self.surface, pos)
            tri = np.asarray(self.surface.vertices)[np.asarray(self.surface.faces)[fc]]
            nrm = surface_normals(self.surface, fc, barycentric(tri, pos))
        return pos, nrm, face, found
