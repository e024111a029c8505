"""Which part of a link's surface is exposed within its robot (issue 33).

A link is skinned where an object can press it: not where another link covers it (a wrist's end
face mating with the elbow, a fingertip sphere half inside the previous phalanx), not in a pocket
no fingertip reaches. :func:`exposed_faces` says, per face of a link's surface:

- **covered**: a sample of the face (its centroid and three points half-way to its corners) lies
  inside another link or within :data:`CLEARANCE` (2 mm) of its surface at the zero pose;
- **covered at every pose**: covered so at the zero pose and (by its centroid) at each of ``poses``
  configurations drawn within the joints' limits (+-pi for a continuous joint): a mating face,
  never touchable; faces free at the zero pose and covered at *some* poses are only reported
  (``sometimes``: the skin there is pressed by the robot itself when it moves);
- **unreachable**: a probe sphere of radius :data:`PROBE_RADIUS` (a fingertip, 8 mm) touching the
  face at its centroid along its normal (centre ``p + r n``) would cut into the link itself or
  another link at the zero pose (its centre closer than ``r -`` :data:`PROBE_TOLERANCE` to them).

A link made of several bodies (separate collision elements, the geoms of one MJCF body, the disconnected
parts of one mesh file: :func:`body_labels`) covers itself where they meet: a face with another body of
the same link just in front of it (inside it, or face to face within :data:`CLEARANCE`: the UR10
forearm's tube ends in a cap coplanar with the next body's start face) is covered at every pose, like a
mating face (:func:`own_covered`; the link names itself in ``covered_by``).

Distances and inside tests are open3d's ``RaycastingScene`` (one per link, in its own frame, built
once: :class:`RobotSurfaces`); the other links are culled by bounding spheres and boxes, so a query
touches only the points near a neighbour, and memory grows with faces x poses (booleans), never
faces x faces; a link's own bodies are told apart by the face each ray hits in the link's one scene
(rays x hits, in chunks). :func:`taxel_reasons` judges placed taxels the same way (the check after a fill).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..errors import InputError
from .model import Robot

#: metres: a face closer than this to another link (or inside it) is covered (the Done-when of issue 33)
CLEARANCE = 0.002
#: metres: the probe that must be able to touch a face (a fingertip)
PROBE_RADIUS = 0.008
#: metres: how far the probe may cut into a surface and still count as touching: a fingertip's pad gives
#: that much, and the G1's finger meshes (ridged, finely faceted) cut a tangent 8 mm sphere by 0.5 mm at
#: half their faces
PROBE_TOLERANCE = 0.002
#: sampled configurations besides the zero pose
POSES = 32
#: barycentric sample points of a face: centroid, then half-way from it to each corner
SAMPLES = np.array([[1, 1, 1], [4, 1, 1], [1, 4, 1], [1, 1, 4]], dtype=np.float64) / np.array([[3.0], [6.0], [6.0],
                                                                                                [6.0]])
#: rays per inside test (odd: a majority vote, robust to a ray through an edge)
INSIDE_RAYS = 3

#: reason codes of :attr:`Exposure.reason`
EXPOSED, COVERED, ALWAYS_COVERED, UNREACHABLE = 0, 1, 2, 3
REASONS = {EXPOSED: "exposed", COVERED: "covered by another link at the zero pose",
           ALWAYS_COVERED: "covered by another link at every sampled pose, or by another body of the link",
           UNREACHABLE: "unreachable by the probe"}
#: the colour of each reason (RGBA, 0..1) and its name in a legend: the add-on's Import Robot and the docs' picture
COLOURS = {EXPOSED: ((0.55, 0.80, 0.55, 1.0), "green"), COVERED: ((0.95, 0.45, 0.35, 1.0), "red"),
           ALWAYS_COVERED: ((0.65, 0.10, 0.10, 1.0), "dark red"), UNREACHABLE: ((0.98, 0.75, 0.25, 1.0), "orange")}


def face_colours(reason) -> np.ndarray:
    """(F, 4) float RGBA of the reason codes (F,) (:data:`COLOURS`)."""
    table = np.array([COLOURS[k][0] for k in sorted(COLOURS)], dtype=np.float64)
    return table[np.asarray(reason, dtype=np.int64)]


def legend(exposure: "Exposure") -> list[str]:
    """The colour legend of one link's exposure, one line per colour present, with its area."""
    lines = []
    for code in sorted(COLOURS):
        sel = exposure.reason == code
        if sel.any():
            what = REASONS[code] + (f" ({1e3 * exposure.probe_radius:g} mm)" if code == UNREACHABLE else "")
            lines.append(f"{COLOURS[code][1]}: {what}, {1e4 * exposure.area[sel].sum():.1f} cm2")
    return lines


@dataclass
class Exposure:
    """The exposed surface of one link (per face of its mesh, in the order of ``mesh.faces``).

    reason : (F,) int8, :data:`EXPOSED`, :data:`COVERED` (at the zero pose, free at some sampled
        pose), :data:`ALWAYS_COVERED` (at the zero pose and every sampled one, or by another body of
        the link itself: :func:`own_covered`) or :data:`UNREACHABLE` (covered first: a covered face
        is not also called unreachable). area : (F,) m^2.
    sometimes : (F,) bool, covered at some sampled pose but not at the zero pose (kept, reported).
    covered_by : (F,) int, index into ``neighbours`` of a link covering the face at the zero pose (the
        link itself where only its own other bodies do), -1.
    poses : configurations sampled besides the zero pose. probe_radius, clearance : metres.
    notes : links whose geometry could not be loaded (left out of the check), and the like.
    """

    link: str
    geometry: str
    reason: np.ndarray
    area: np.ndarray
    sometimes: np.ndarray
    covered_by: np.ndarray
    neighbours: list
    poses: int
    probe_radius: float
    clearance: float
    notes: list = field(default_factory=list)

    @property
    def mask(self) -> np.ndarray:
        """(F,) bool: the faces a module may go on."""
        return self.reason == EXPOSED

    def summary(self) -> dict:
        """Areas (m^2) and face counts of each reason, the covering links (name -> m^2 covered)."""
        out = {"link": self.link, "geometry": self.geometry, "faces": int(len(self.reason)),
               "area_m2": float(self.area.sum()), "poses": self.poses, "probe_radius_m": self.probe_radius,
               "clearance_m": self.clearance}
        for code, key in ((EXPOSED, "exposed"), (COVERED, "covered"), (ALWAYS_COVERED, "always_covered"),
                          (UNREACHABLE, "unreachable")):
            sel = self.reason == code
            out[f"{key}_faces"], out[f"{key}_m2"] = int(sel.sum()), float(self.area[sel].sum())
        some = self.sometimes & self.mask
        out["sometimes_covered_faces"], out["sometimes_covered_m2"] = int(some.sum()), float(self.area[some].sum())
        hit = self.covered_by >= 0
        by = np.bincount(self.covered_by[hit], weights=self.area[hit], minlength=len(self.neighbours))
        out["covered_by"] = {self.neighbours[k]: float(by[k]) for k in np.flatnonzero(by)}
        out["notes"] = list(self.notes)
        return out

    def excluded_text(self) -> str:
        """One line: what was left out and why (for the placement report)."""
        s = self.summary()
        parts = []
        n_cov, a_cov = s["covered_faces"] + s["always_covered_faces"], s["covered_m2"] + s["always_covered_m2"]
        if n_cov:
            by = ", ".join("its own other bodies" if k == self.link else k
                           for k in sorted(s["covered_by"], key=lambda k: -s["covered_by"][k])[:3])
            every = (f", {s['always_covered_faces']} of them at every one of {self.poses} sampled poses"
                     if self.poses and s["always_covered_faces"] else "")
            parts.append(f"{n_cov} faces ({1e6 * a_cov:.0f} mm2) within {1e3 * self.clearance:g} mm of or inside "
                         f"{by or 'another link'}{every}")
        if s["unreachable_faces"]:
            parts.append(f"{s['unreachable_faces']} faces ({1e6 * s['unreachable_m2']:.0f} mm2) no "
                         f"{1e3 * self.probe_radius:g} mm probe reaches")
        text = "; ".join(parts) if parts else "nothing"
        if s["sometimes_covered_faces"]:
            text += (f" (and {s['sometimes_covered_faces']} faces, {1e6 * s['sometimes_covered_m2']:.0f} mm2, "
                     f"covered at some of {self.poses} sampled poses, kept)")
        return f"exposure of {self.link!r}: left out {text}"


class RobotSurfaces:
    """Every link's surface of one kind as an open3d ``RaycastingScene`` in the link's frame,
    loaded once and shared by the exposure of several links (``vtcore robot info``, the bench).

    geometry : "visual" or "collision"; a link without that kind is seen through its other kind
    (a neighbour covers a face with whatever it has). A link whose meshes cannot be read is left
    out and named in ``notes``.
    """

    def __init__(self, robot: Robot, geometry: str = "visual"):
        self.robot, self.geometry = robot, geometry
        self._cache: dict = {}
        self._spheres = None  # the links' bounding spheres as arrays, once all are loaded
        self.notes: list = []

    def mesh(self, name: str):
        """The link's surface (trimesh, link frame, metres), or None when it has none."""
        entry = self.entry(name)
        return None if entry is None else entry["mesh"]

    def entry(self, name: str):
        if name not in self._cache:
            self._cache[name] = self._load(name)
        return self._cache[name]

    def holds(self, name: str, mesh) -> bool:
        """Whether link ``name`` is already seen through this very ``mesh`` object."""
        e = self._cache.get(name)
        return e is not None and e["mesh"] is mesh

    def set_mesh(self, name: str, mesh) -> None:
        """Use ``mesh`` (as the caller loaded or refined it) for link ``name``."""
        self._cache[name] = self._build(mesh)
        self._spheres = None

    def _load(self, name: str):
        import trimesh

        from .meshes import geometry_mesh

        ln = self.robot.link(name)
        parts = ln.geometry(self.geometry) or ln.geometry("collision" if self.geometry == "visual" else "visual")
        if not parts:
            return None
        try:
            meshes = [geometry_mesh(g, self.robot) for g in parts]
        except InputError as exc:
            self.notes.append(f"link {name!r} left out of the exposure check: {exc.reason}")
            return None
        return self._build(meshes[0] if len(meshes) == 1 else trimesh.util.concatenate(meshes))

    @staticmethod
    def _build(mesh):
        import open3d as o3d

        v = np.asarray(mesh.vertices, dtype=np.float64)
        f = np.asarray(mesh.faces, dtype=np.int64)
        if not len(f):
            return None
        lo, hi = v.min(axis=0), v.max(axis=0)
        centre = (lo + hi) / 2
        scene = o3d.t.geometry.RaycastingScene()
        # float32 inside open3d: coordinates about the box centre keep ~1e-8 m on a link
        scene.add_triangles(o3d.core.Tensor((v - centre).astype(np.float32)), o3d.core.Tensor(f.astype(np.uint32)))
        return {"mesh": mesh, "scene": scene, "centre": centre, "lo": lo, "hi": hi,
                "radius": float(np.linalg.norm(hi - lo) / 2)}

    def signed(self, name: str, points: np.ndarray) -> np.ndarray:
        """(P,) metres from ``points`` (P, 3) in link ``name``'s frame to its surface, negative
        inside it (ray parity, :data:`INSIDE_RAYS` rays: a closed surface is assumed)."""
        import open3d as o3d

        e = self.entry(name)
        q = o3d.core.Tensor((points - e["centre"]).astype(np.float32))
        return e["scene"].compute_signed_distance(q, nsamples=INSIDE_RAYS).numpy().astype(np.float64)

    def bodies(self, name: str):
        """(F,) int64: the body of each face of link ``name``'s surface (:func:`body_labels`), found
        once per surface; None for a link without one."""
        e = self.entry(name)
        if e is None:
            return None
        if "bodies" not in e:
            e["bodies"] = body_labels(e["mesh"])
        return e["bodies"]

    def nearest_faces(self, name: str, points: np.ndarray) -> np.ndarray:
        """(P,) int64: the face of link ``name``'s surface nearest each of ``points`` (P, 3, link frame)."""
        import open3d as o3d

        e = self.entry(name)
        q = o3d.core.Tensor((points - e["centre"]).astype(np.float32))
        return e["scene"].compute_closest_points(q)["primitive_ids"].numpy().astype(np.int64)

    def faces_under(self, name: str, points: np.ndarray, normals: np.ndarray, depth: float = 1e-3) -> np.ndarray:
        """(P,) int64: the face of link ``name``'s surface each point (P, 3, link frame) with unit
        ``normals`` (P, 3) lies on: of the faces that the line along its normal meets within ``depth``
        metres either side, the one turned most its way (where two bodies' faces coincide, a taxel on
        the end cap of one is on that cap, not on the other's start face); else the nearest face."""
        import open3d as o3d

        e = self.entry(name)
        out = self.nearest_faces(name, points)
        n = np.asarray(normals, dtype=np.float64)
        rays = np.column_stack([points - e["centre"] + depth * n, -n]).astype(np.float32)
        hits = {k: v.numpy() for k, v in e["scene"].list_intersections(o3d.core.Tensor(rays)).items()}
        ray, prim = hits["ray_ids"].astype(np.int64), hits["primitive_ids"].astype(np.int64)
        near = hits["t_hit"] <= 2 * depth
        ray, prim = ray[near], prim[near]
        turned = np.einsum("ij,ij->i", np.asarray(e["mesh"].face_normals, dtype=np.float64)[prim], n[ray])
        order = np.lexsort((-turned, ray))  # per point, the face turned most its way first
        first = order[np.r_[True, ray[order][1:] != ray[order][:-1]]] if len(order) else order
        out[ray[first]] = prim[first]
        return out

    def distance(self, name: str, points: np.ndarray) -> np.ndarray:
        """(P,) metres from ``points`` (P, 3, link frame) to link ``name``'s surface (unsigned)."""
        import open3d as o3d

        e = self.entry(name)
        q = o3d.core.Tensor((points - e["centre"]).astype(np.float32))
        return e["scene"].compute_distance(q).numpy().astype(np.float64)

    def placed(self, link: str, poses: dict, reach: float):
        """The other links near ``link`` at ``poses`` (name -> (4, 4), one world frame): a list of
        ``(index in robot.links, name, (4, 4) transform from link's frame to the other's)`` for
        those whose bounding spheres come within ``reach`` metres of ``link``'s."""
        own = self.entry(link)
        if own is None:
            return []
        ks, names, centres, radii = self.spheres()
        t = np.stack([poses[n] for n in names])  # (K, 4, 4)
        world = np.einsum("kij,kj->ki", t[:, :3, :3], centres) + t[:, :3, 3]
        t_l = poses[link]
        gap = world - (t_l[:3, :3] @ own["centre"] + t_l[:3, 3])
        near = np.einsum("ki,ki->k", gap, gap) <= (own["radius"] + radii + reach) ** 2
        near &= np.array([n != link for n in names])
        return [(ks[i], names[i], rigid_inverse(t[i]) @ t_l) for i in np.flatnonzero(near)]

    def spheres(self):
        """``(indices in robot.links, names, (K, 3) box centres, (K,) radii)`` of the links with a surface."""
        if self._spheres is None:
            rows = [(k, n, self.entry(n)) for k, n in enumerate(self.robot.links)]
            rows = [(k, n, e) for k, n, e in rows if e is not None]
            self._spheres = ([k for k, _, _ in rows], [n for _, n, _ in rows],
                             np.array([e["centre"] for _, _, e in rows]).reshape(-1, 3),
                             np.array([e["radius"] for _, _, e in rows]))
        return self._spheres

    def box_distance(self, name: str, points: np.ndarray) -> np.ndarray:
        """(P,) metres from ``points`` (link ``name``'s frame) to its bounding box (0 inside it):
        a lower bound of the distance to its surface."""
        e = self.entry(name)
        out = np.maximum(np.maximum(e["lo"] - points, points - e["hi"]), 0.0)
        return np.sqrt(np.einsum("ij,ij->i", out, out))

    def nearest_others(self, link: str, points: np.ndarray, poses: dict, reach: float, within: float,
                       distance: bool = False):
        """Points (P, 3) of ``link`` (its frame) against every other link placed by ``poses``
        (name -> (4, 4) in one world frame): (P,) bool whether a point lies inside another link
        or within ``within`` metres of it, and (P,) int the first such link's index in
        ``self.robot.links`` (-1); with ``distance`` also (P,) metres, the smallest signed distance
        to the links queried (inf where none was: every other link is farther than ``reach``).
        Links farther than ``reach`` (bounding spheres, then boxes) are not queried."""
        hit = np.zeros(len(points), bool)
        who = np.full(len(points), -1, np.int64)
        dist = np.full(len(points), np.inf)
        for k, other, rel in (self.placed(link, poses, reach) if len(points) else []):
            p = points @ rel[:3, :3].T + rel[:3, 3]
            idx = np.flatnonzero(self.box_distance(other, p) <= reach)
            if not len(idx):
                continue
            d = self.signed(other, p[idx])
            dist[idx] = np.minimum(dist[idx], d)
            close = idx[d < within]
            who[close[who[close] < 0]] = k
            hit[close] = True
        return (hit, who, dist) if distance else (hit, who)


def rigid_inverse(t: np.ndarray) -> np.ndarray:
    """(4, 4) inverse of a rigid transform (R^T, -R^T t)."""
    out = np.eye(4)
    out[:3, :3] = t[:3, :3].T
    out[:3, 3] = -t[:3, :3].T @ t[:3, 3]
    return out


def body_labels(mesh) -> np.ndarray:
    """(F,) int64: which body, 0 .. B-1, each face of ``mesh`` belongs to: its connected parts after
    merging coincident vertices (a link's separate collision elements, the geoms of one MJCF body, the
    disconnected parts of one mesh file). Faces join over edges of exactly two faces (trimesh's
    adjacency), so two bodies sharing a face's corners stay two."""
    import trimesh

    m = trimesh.Trimesh(np.asarray(mesh.vertices), np.asarray(mesh.faces), process=False, validate=False)
    m.merge_vertices()
    return trimesh.graph.connected_component_labels(m.face_adjacency, node_count=len(m.faces)).astype(np.int64)


#: metres: the own-body test looks from this far in front of a point on a face: off the face itself, and
#: off a coplanar face of another body turned the same way (the bodies' common outer surface stays
#: exposed); the scenes hold float32 coordinates (~1e-7 m on a link)
OWN_OFFSET = 1e-5
#: the own-body inside test's rays besides the face normal: fixed unit directions off a mesh's axes and
#: diagonals (a ray through an edge counts both its faces, so one ray's parity can be wrong: a majority
#: of three decides, as ``INSIDE_RAYS`` does for other links), each turned into the face's outer
#: half-space and halfway to its normal: a ray that crossed the face's own plane again would meet two
#: bodies' coincident faces (a flush outer surface) at the very same distance, and open3d lists only one
#: of two hits that close
OWN_DIRECTIONS = np.array([[0.5377, 0.8212, -0.1903], [-0.6531, 0.2237, 0.7234]])
OWN_DIRECTIONS = OWN_DIRECTIONS / np.linalg.norm(OWN_DIRECTIONS, axis=1, keepdims=True)
#: points per open3d ray query of the own-body test (the hits of one query are held at once)
OWN_CHUNK = 20_000


def own_covered(surfaces: "RobotSurfaces", link: str, points: np.ndarray, normals: np.ndarray, faces: np.ndarray,
                clearance: float = CLEARANCE) -> np.ndarray:
    """(P,) bool: whether another body of ``link`` (:meth:`RobotSurfaces.bodies`) covers each point
    (P, 3, link frame) lying on face ``faces`` (P,) of its surface with unit outward ``normals`` (P, 3):
    the point :data:`OWN_OFFSET` in front of it lies inside another body (parity of that body's faces
    alone along the normal and :data:`OWN_DIRECTIONS` turned outwards, a majority of the three: bodies
    that overlap each count), or the line along the normal meets a face of another body turned towards it within
    ``clearance`` metres, either side of :data:`OWN_OFFSET` (two bodies face to face: the coplanar start
    face of the next body, a hair behind the point or a millimetre in front). A link of one body, and a
    point without a normal: False."""
    labels = surfaces.bodies(link)
    out = np.zeros(len(points), bool)
    if labels is None or not len(points) or labels.max() == 0:
        return out
    import open3d as o3d

    e = surfaces.entry(link)
    n = np.asarray(normals, dtype=np.float64)
    ok = np.flatnonzero(np.einsum("ij,ij->i", n, n) > 0.25)  # degenerate faces have no normal
    p = np.asarray(points, dtype=np.float64)[ok] - e["centre"]
    face_n = np.asarray(e["mesh"].face_normals, dtype=np.float64)
    nb = int(labels.max()) + 1
    for start in range(0, len(ok), OWN_CHUNK):
        sl = slice(start, start + OWN_CHUNK)
        c, nk = len(p[sl]), n[ok[sl]]
        # ray k * c + i is point i's: along the normal from behind the face, then the others from in front
        origins = np.concatenate([p[sl] - OWN_OFFSET * nk] + [p[sl] + OWN_OFFSET * nk] * len(OWN_DIRECTIONS))
        dirs = [nk]
        for d in OWN_DIRECTIONS:  # into the face's outer half-space, halfway to its normal
            v = np.where((nk @ d < 0)[:, None], -d, d) + nk
            dirs.append(v / np.linalg.norm(v, axis=1, keepdims=True))
        dirs = np.concatenate(dirs)
        hits = {k: v.numpy() for k, v in e["scene"].list_intersections(
            o3d.core.Tensor(np.column_stack([origins, dirs]).astype(np.float32))).items()}
        ray, prim = hits["ray_ids"].astype(np.int64), hits["primitive_ids"].astype(np.int64)
        other = labels[prim] != labels[np.asarray(faces)[ok[sl]]][ray % c]
        ray, prim, t = ray[other], prim[other], hits["t_hit"][other].astype(np.float64)
        facing = np.einsum("ij,ij->i", face_n[prim], nk[ray % c]) < 0
        front = ray[(ray < c) & (t < clearance + OWN_OFFSET) & facing]
        keep = (ray >= c) | (t > 2 * OWN_OFFSET)  # the parity of the point in front of the face
        ray, body = ray[keep], labels[prim[keep]]
        keys, count = np.unique(ray * nb + body, return_counts=True)
        odd = keys[count % 2 == 1]  # (ray, body): the point lies inside that body along that ray
        pairs, votes = np.unique((odd // nb % c) * nb + odd % nb, return_counts=True)
        inside = pairs[votes >= 2] // nb
        out[ok[sl][np.concatenate([front, inside])]] = True
    return out


#: metres: round another link, the zero pose's signed distances are computed exactly this far out of
#: its box (beyond it the box distance bounds them); a sampled pose moves a point by delta, and the
#: distance then by at most delta, so most points need no query at most poses
EXACT_BAND = 0.01


def covered_over_poses(surfaces: RobotSurfaces, link: str, points: np.ndarray, configs: list, clearance: float,
                       covered0: np.ndarray) -> tuple:
    """Over the sampled configurations ``configs[1:]`` (link poses each), of the points (P, 3,
    link frame; ``covered0`` (P,) bool: covered at the zero pose ``configs[0]``): (P,) bool
    covered at every pose, (P,) bool covered at some pose.

    A point is decided once it is (covered at the zero pose and found free at one pose, or free at
    the zero pose and found covered at one); the undecided are queried only where the bound
    ``distance >= max(box distance, zero-pose distance - how far the point moved)`` does not
    already keep them clear.
    """
    always, some = covered0.copy(), np.zeros(len(points), bool)
    zero: dict = {}  # other link -> (points at the zero pose in its frame, lower bound of signed distance)
    for pose in configs[1:]:
        hit = np.zeros(len(points), bool)
        undecided = always | ~some
        for k, other, rel in surfaces.placed(link, pose, clearance):
            if other not in zero:
                rel0 = [r for kk, _, r in surfaces.placed(link, configs[0], np.inf) if kk == k][0]
                p0 = points @ rel0[:3, :3].T + rel0[:3, 3]
                lb0 = surfaces.box_distance(other, p0)
                band = np.flatnonzero(lb0 <= EXACT_BAND)
                lb0[band] = surfaces.signed(other, p0[band])
                zero[other] = (p0, lb0)
            p0, lb0 = zero[other]
            p = points @ rel[:3, :3].T + rel[:3, 3]
            moved = np.sqrt(np.einsum("ij,ij->i", p - p0, p - p0))
            lb = np.maximum(surfaces.box_distance(other, p), lb0 - moved)
            idx = np.flatnonzero(undecided & ~hit & (lb < clearance))
            if len(idx):
                hit[idx[surfaces.signed(other, p[idx]) < clearance]] = True
        always &= hit
        some |= hit & ~covered0
    return always, some


def _shared(robot: Robot) -> dict:
    """{geometry: RobotSurfaces, ("configs", poses, seed): configurations}: the scenes of a robot read
    once (a whole-robot skin, or Blender's lays on several links, would read every link's meshes again
    for each link), kept on the robot itself so that they go with it. A module-level cache keyed by
    id(robot) never let a robot go (its RobotSurfaces held it): every robot placed on in one process
    stayed in memory with its open3d scenes, and a fuzz run's process was killed by a segmentation
    fault in open3d after about a thousand robots."""
    return robot.__dict__.setdefault("_exposure_shared", {})


def shared_surfaces(robot: Robot, geometry: str = "visual") -> RobotSurfaces:
    """The :class:`RobotSurfaces` of ``robot`` kept for as long as ``robot`` lives (the meshes of
    its links are read once; a caller that sets a link's own mesh changes only that link's scene,
    whose surface is the same)."""
    shared = _shared(robot)
    if geometry not in shared:
        shared[geometry] = RobotSurfaces(robot, geometry)
    return shared[geometry]


def face_samples(mesh) -> np.ndarray:
    """(F, S, 3) metres: the sample points of each face (:data:`SAMPLES`)."""
    tri = np.asarray(mesh.triangles, dtype=np.float64)
    return np.einsum("sk,fkj->fsj", SAMPLES, tri)


#: metres: a configuration is self-colliding where a sample of a link's surface lies this deep inside
#: another link it is not jointed to (and did not already overlap at the zero pose): the robot cannot hold it
SELF_DEPTH = 0.002
#: surface samples per link for the self-collision test (area-weighted, seeded)
SELF_SAMPLES = 256
#: draws per wanted configuration before the sampler gives up on finding a collision-free one
SELF_TRIES = 100


class SelfCollision:
    """Whether a configuration of ``robot`` puts one link through another (on the surfaces of
    ``surfaces``: :class:`RobotSurfaces`): a sample of one link's surface (:data:`SELF_SAMPLES` per
    link) lies more than ``depth`` metres inside a link that is neither its joint parent or child nor
    already overlapping it at the zero pose (meshes that interpenetrate by design: a cover over its
    mount, a hand's fingers in the palm). Such a pose the real robot can never hold; random
    configurations uniform within the joint limits are often of that kind (a humanoid's arm through its
    own torso)."""

    def __init__(self, surfaces: RobotSurfaces, depth: float = SELF_DEPTH, seed: int = 0):
        self.surfaces, self.depth = surfaces, float(depth)
        robot = surfaces.robot
        rng = np.random.default_rng(seed)
        self.points = {}
        for name in robot.links:
            mesh = surfaces.mesh(name)
            if mesh is not None:
                self.points[name] = surface_samples(mesh, SELF_SAMPLES, rng)
        self.exempt = {frozenset((j.parent, j.child)) for j in robot.joints}
        self.exempt |= self.pairs(robot.link_poses({}))

    def pairs(self, poses: dict, first: bool = False) -> set:
        """The pairs of links (frozensets of names) interpenetrating at ``poses`` (link name ->
        (4, 4)), leaving out the exempt ones; with ``first`` stop at the first such pair."""
        names = list(self.points)
        rank = {n: i for i, n in enumerate(names)}
        out: set = set()
        for name in names:
            pts = self.points[name]
            for _, other, rel in self.surfaces.placed(name, poses, 0.0):
                pair = frozenset((name, other))
                if rank.get(other, -1) <= rank[name] or pair in out or pair in getattr(self, "exempt", ()):
                    continue  # each pair once (the other way round it is the other's turn)
                p = pts @ rel[:3, :3].T + rel[:3, 3]
                idx = np.flatnonzero(self.surfaces.box_distance(other, p) <= 0.0)
                if len(idx) and (self.surfaces.signed(other, p[idx]) < -self.depth).any():
                    out.add(pair)
                    if first:
                        return out
        return out

    def free(self, poses: dict) -> bool:
        """Whether no two links interpenetrate at ``poses`` (link name -> (4, 4)) but the exempt ones."""
        return not self.pairs(poses, first=True)


def surface_samples(mesh, count: int, rng) -> np.ndarray:
    """(count, 3) points on ``mesh`` (a trimesh), area-weighted, from ``rng``."""
    area = np.asarray(mesh.area_faces, dtype=np.float64)
    tri = np.asarray(mesh.triangles, dtype=np.float64)
    f = rng.choice(len(tri), size=count, p=area / area.sum()) if area.sum() > 0 else rng.integers(len(tri), size=count)
    u, v = rng.random(count), rng.random(count)
    flip = u + v > 1  # fold the square onto the triangle: uniform barycentric samples
    u[flip], v[flip] = 1 - u[flip], 1 - v[flip]
    return tri[f, 0] + u[:, None] * (tri[f, 1] - tri[f, 0]) + v[:, None] * (tri[f, 2] - tri[f, 0])


def configurations(robot: Robot, poses: int = POSES, seed: int = 0, surfaces: RobotSurfaces | None = None,
                   free: bool = True, tries: int = SELF_TRIES) -> list:
    """The zero pose and ``poses`` configurations drawn uniformly within the joints' limits (+-pi for
    a joint without limits: continuous joints), seeded: a list of (name -> (4, 4)) link poses.

    free : keep only configurations the robot can hold, no link through another
    (:class:`SelfCollision`, on ``surfaces``, default the visual ones; rejection sampling): a face
    covered only at poses the robot cannot reach is not covered. After ``tries`` draws per wanted pose
    without a free one the draws stop and fewer poses come back (a robot whose every random pose
    collides: the zero pose still judges it)."""
    rng = np.random.default_rng(seed)
    out = [robot.link_poses({})]
    check = SelfCollision(surfaces or RobotSurfaces(robot), seed=seed) if free and poses else None
    draws = 0
    while len(out) <= int(poses) and draws < int(tries) * int(poses):
        draws += 1
        p = robot.link_poses(robot.random_configuration(rng))
        if check is None or check.free(p):
            out.append(p)
    return out


def probe_blocked(surfaces: RobotSurfaces, link: str, points, normals, poses: dict,
                  probe_radius: float = PROBE_RADIUS, tolerance: float = PROBE_TOLERANCE) -> np.ndarray:
    """(P,) bool: whether a sphere of ``probe_radius`` touching each point (P, 3, link frame)
    along its unit normal (P, 3) cuts more than ``tolerance`` into the link itself or into
    another link placed by ``poses``."""
    centres = np.asarray(points, dtype=np.float64) + probe_radius * np.asarray(normals, dtype=np.float64)
    limit = probe_radius - tolerance
    blocked = surfaces.distance(link, centres) < limit
    hit, _ = surfaces.nearest_others(link, centres, poses, reach=probe_radius, within=limit)
    return blocked | hit


def covered_at_zero(surfaces: RobotSurfaces, link: str, pts: np.ndarray, pose: dict, clearance: float) -> tuple:
    """(F,) bool: a sample of each face (``pts`` (F, S, 3), centroid first) within ``clearance`` of
    or inside another link at ``pose``; (F,) int the index of such a link in ``robot.links`` (-1).
    The centroids are queried first; a face's other samples only where the centroid's distance, less
    how far they lie from it, does not already clear ``clearance`` (signed distance is 1-Lipschitz)."""
    spread = np.linalg.norm(pts[:, 1:] - pts[:, :1], axis=2).max(axis=1)  # (F,) metres
    hit, who, dist = surfaces.nearest_others(link, pts[:, 0], pose, reach=clearance + float(spread.max()),
                                             within=clearance, distance=True)
    need = np.flatnonzero(~hit & (dist - spread < clearance))
    if len(need):
        h, w = surfaces.nearest_others(link, pts[need, 1:].reshape(-1, 3), pose, reach=clearance, within=clearance)
        h, w = h.reshape(len(need), -1), w.reshape(len(need), -1)
        hit[need] = h.any(axis=1)
        who[need] = np.where(h.any(axis=1), w.max(axis=1), -1)
    return hit, who


def exposed_faces(robot: Robot, link: str, geometry: str = "visual", *, mesh=None, poses: int = POSES,
                  probe_radius: float = PROBE_RADIUS, clearance: float = CLEARANCE,
                  tolerance: float = PROBE_TOLERANCE, seed: int = 0, surfaces: RobotSurfaces | None = None,
                  configs: list | None = None) -> Exposure:
    """The exposed surface of ``link`` (see the module doc), per face of ``mesh`` (default the
    link's ``geometry`` surface as :func:`.meshes.link_mesh` loads it; a refined copy of it works
    too: the faces are whatever ``mesh`` has).

    poses : configurations sampled besides the zero pose (0: the zero pose only). probe_radius,
    clearance, tolerance : metres. surfaces, configs : shared by the caller over several links
    (:class:`RobotSurfaces`, :func:`configurations`). Returns an :class:`Exposure`.
    """
    for key, v in (("probe_radius", probe_radius), ("clearance", clearance)):
        if not (np.isfinite(v) and v > 0):
            raise InputError(f"must be a positive number of metres, got {v!r}", key=key)
    if not (np.isfinite(tolerance) and 0 <= tolerance < probe_radius):
        raise InputError(f"must be in [0, probe radius {probe_radius:g}) metres, got {tolerance!r}", key="tolerance")
    if mesh is None:
        from .meshes import link_mesh

        mesh = link_mesh(robot, link, geometry)
    surfaces = surfaces or RobotSurfaces(robot, geometry)
    if not surfaces.holds(link, mesh):
        surfaces.set_mesh(link, mesh)
    if configs is None:  # drawn once per shared robot and seed (forward kinematics of 33 poses: ~0.1 s, a humanoid)
        shared, key = _shared(robot), ("configs", int(poses), int(seed))
        configs = shared.get(key) or configurations(robot, poses, seed, surfaces)
        if shared.get(geometry) is surfaces:
            shared[key] = configs
    pts = face_samples(mesh)
    covered0, who0 = covered_at_zero(surfaces, link, pts, configs[0], clearance)
    # the sampled poses judge each face by its centroid (the zero pose, which the skin must clear, by all samples)
    always, sometimes = covered_over_poses(surfaces, link, pts[:, 0], configs, clearance, covered0)
    normals = np.asarray(mesh.face_normals, dtype=np.float64)
    blocked = probe_blocked(surfaces, link, pts[:, 0], normals, configs[0], probe_radius, tolerance)
    # between the link's own bodies: covered whatever the pose (by every sample, as at the zero pose)
    own = own_covered(surfaces, link, pts.reshape(-1, 3), np.repeat(normals, pts.shape[1], axis=0),
                      np.repeat(np.arange(len(pts)), pts.shape[1]), clearance).reshape(len(pts), -1).any(axis=1)
    reason = np.full(len(pts), EXPOSED, np.int8)
    reason[blocked] = UNREACHABLE
    reason[covered0] = COVERED
    if len(configs) > 1:  # without sampled poses nothing is known to be covered at every one
        reason[covered0 & always] = ALWAYS_COVERED
    reason[own] = ALWAYS_COVERED
    names = list(robot.links)
    who0 = np.where(own & (who0 < 0), names.index(link), who0)
    used = np.unique(who0[who0 >= 0])
    remap = np.full(len(names), -1, np.int64)
    remap[used] = np.arange(len(used))
    return Exposure(link, geometry, reason, np.asarray(mesh.area_faces, dtype=np.float64),
                    sometimes, np.where(who0 >= 0, remap[np.maximum(who0, 0)], -1),
                    [names[k] for k in used], len(configs) - 1, float(probe_radius), float(clearance),
                    list(surfaces.notes))


def taxel_reasons(robot: Robot, link: str, positions, normals, geometry: str = "visual", *, mesh=None,
                  probe_radius: float = PROBE_RADIUS, clearance: float = CLEARANCE,
                  tolerance: float = PROBE_TOLERANCE, surfaces: RobotSurfaces | None = None) -> np.ndarray:
    """(N,) int8 reason codes (:data:`EXPOSED`, :data:`COVERED`, :data:`UNREACHABLE`) of taxels
    at ``positions`` with unit ``normals`` (N, 3 each, metres, link frame) at the zero pose: the
    check of a placed patch or fill against the links round it."""
    p = np.asarray(positions, dtype=np.float64).reshape(-1, 3)
    n = np.asarray(normals, dtype=np.float64).reshape(-1, 3)
    surfaces = surfaces or RobotSurfaces(robot, geometry)
    if mesh is not None and not surfaces.holds(link, mesh):
        surfaces.set_mesh(link, mesh)
    elif surfaces.entry(link) is None:
        from .meshes import link_mesh

        surfaces.set_mesh(link, link_mesh(robot, link, geometry))
    zero = robot.link_poses({})
    hit, _ = surfaces.nearest_others(link, p, zero, reach=clearance, within=clearance)
    blocked = probe_blocked(surfaces, link, p, n, zero, probe_radius, tolerance)
    bodies = surfaces.bodies(link)
    if len(p) and bodies is not None and bodies.max() > 0:  # a taxel between the link's own bodies
        hit |= own_covered(surfaces, link, p, n, surfaces.faces_under(link, p, n), clearance)
    out = np.full(len(p), EXPOSED, np.int8)
    out[blocked] = UNREACHABLE
    out[hit] = COVERED
    return out


def robot_exposure(robot: Robot, geometry: str = "visual", links=None, **options) -> dict:
    """:func:`exposed_faces` of every link with geometry (or of ``links``), sharing the scenes and
    the sampled configurations: link name -> :class:`Exposure`; a link whose surface cannot be
    read is left out (``RobotSurfaces.notes``)."""
    surfaces = RobotSurfaces(robot, geometry)
    configs = configurations(robot, options.pop("poses", POSES), options.pop("seed", 0), surfaces)
    out = {}
    for name in links or list(robot.links):
        ln = robot.link(name)
        if not ln.geometry(geometry):
            continue
        mesh = surfaces.mesh(name)
        if mesh is None:
            continue
        out[name] = exposed_faces(robot, name, geometry, mesh=mesh, surfaces=surfaces, configs=configs, **options)
    return out


def modules_room(exposure: Exposure, module="cyskin10") -> int:
    """About how many modules of ``module`` the exposed area takes: exposed area over the module's
    outline area, rounded down (an upper bound: creases, narrow parts and strain leave some out)."""
    from ..layout.modules import get_module

    area = float(exposure.area[exposure.mask].sum())
    return int(area // get_module(module).area)
