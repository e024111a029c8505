"""Lay a skin on a robot's own link: the layout is born in the link's frame.

:func:`lay_on_link` loads the link's geometry as the model places it (:func:`.meshes.link_mesh`),
places a patch or fills the surface there (:func:`vtcore.layout.place`, :func:`vtcore.layout.fill`)
and records where the layout lives: ``frame`` is the link, the transform identity, and
``meta["robot"]`` (file), ``meta["link"]``, ``meta["geometry"]``. Exporting it back into the robot
(:mod:`.export`) then needs no transform from the user.
"""

from __future__ import annotations

import numpy as np

from ..errors import InputError
from .model import Robot


#: metres: the neighbourhood whose flatness picks the default anchor (about a hexagon's radius)
ANCHOR_RADIUS = 0.015
#: a neighbourhood this flat (length of its mean unit normal) takes a patch without strain to speak of:
#: a 36 mm tube reads 0.97 over 15 mm, a flange face 1.0
FLAT_ENOUGH = 0.95
#: without a given point, a patch is tried at up to this many anchors until one lies well
ANCHOR_TRIES = 4
#: module-edge strain a patch placed at a default anchor is content with
GOOD_STRAIN = 0.05
#: candidate anchors tried (area-weighted samples of the region, seeded: the same anchor every time)
ANCHOR_CANDIDATES = 64


def default_anchor(mesh, region=None) -> np.ndarray:
    """(3,) metres: the first of :func:`anchors`."""
    return anchors(mesh, region)[0]


def anchors(mesh, region=None) -> np.ndarray:
    """(K, 3) metres: where a placement may start when none is given, best first: on ``region`` (a
    (F,) bool face mask; default :func:`outer_region`), the face centre nearest the region's
    area-weighted centroid and 64 seeded area-weighted samples; those the outside can see and whose
    faces within 15 mm are flat enough (:data:`FLAT_ENOUGH`) first, nearest the centroid first, then
    the others, flattest first (the centroid alone fell on a crease of the Panda's links, the flattest
    alone on a flange)."""
    from scipy.spatial import cKDTree

    from ..layout.surface import closest_points

    region = outer_region(mesh) if region is None else np.asarray(region, dtype=bool)
    idx = np.flatnonzero(region)
    centres, normals, w = mesh.triangles_center[idx], mesh.face_normals[idx], mesh.area_faces[idx]
    centroid = (centres * w[:, None]).sum(0) / max(float(w.sum()), 1e-30)
    part = mesh.submesh([idx], append=True)
    first = closest_points(part, centroid[None])[0][0]
    rng = np.random.default_rng(0)
    pick = rng.choice(len(idx), size=min(ANCHOR_CANDIDATES, len(idx)), replace=False, p=w / w.sum())
    cands = np.vstack([first[None], centres[pick]])
    cand_n = np.vstack([normals[int(np.argmin(np.linalg.norm(centres - first, axis=1)))][None], normals[pick]])
    near = cKDTree(centres).query_ball_point(cands, ANCHOR_RADIUS)
    # flatness: length of the area-weighted mean normal of the faces round each candidate (1: flat)
    flat = np.array([np.linalg.norm((normals[k] * w[k, None]).sum(0)) / max(w[k].sum(), 1e-30) if len(k) else 0.0
                     for k in map(np.asarray, near)])
    # a place the outside cannot see (under a cover, inside a housing) is no place for skin
    flat[occluded(mesh, cands + 1e-4 * cand_n, cand_n)] -= 2.0
    # the places flat enough, nearest the middle first (a tube's side, not a flange), then the rest, flattest first
    dist = np.linalg.norm(cands - centroid, axis=1)
    good = flat >= FLAT_ENOUGH
    order = np.lexsort((np.where(good, dist, -flat), ~good))
    return np.asarray(cands[order], dtype=np.float64)


#: ray x triangle tests per chunk of :func:`occluded` (bounds its memory: about 0.5 GB of float64 temporaries)
RAY_TESTS = 2_000_000


def occluded(mesh, origins, directions) -> np.ndarray:
    """(R,) bool: whether each ray (origins, directions (R, 3)) hits a triangle of ``mesh``
    (Moller-Trumbore in numpy, rays chunked so that rays x faces stays under RAY_TESTS: trimesh's
    ray queries need rtree or embree, which the Blender extension does not bundle)."""
    tri = np.asarray(mesh.triangles, dtype=np.float64)
    a, e1, e2 = tri[:, 0], tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]
    out = np.zeros(len(origins), bool)
    step = max(1, RAY_TESTS // max(len(tri), 1))
    for k in range(0, len(origins), step):
        o, d = origins[k:k + step, None, :], directions[k:k + step, None, :]
        p = np.cross(d, e2[None])
        det = np.einsum("rfi,fi->rf", p, e1)
        with np.errstate(divide="ignore", invalid="ignore"):
            inv = 1.0 / det
            t = o - a[None]
            u = np.einsum("rfi,rfi->rf", t, p) * inv
            q = np.cross(t, e1[None])
            v = np.einsum("rfi,rfi->rf", np.broadcast_to(d, q.shape), q) * inv
            dist = np.einsum("rfi,fi->rf", q, e2) * inv
            hit = (np.abs(det) > 1e-18) & (u >= 0) & (v >= 0) & (u + v <= 1) & (dist > 0)
        out[k:k + step] = hit.any(axis=1)
    return out


def outer_region(mesh) -> np.ndarray:
    """(F,) bool: the faces of the connected part of ``mesh`` with the largest area (after merging
    coincident vertices). A maker's visual mesh is often many parts (a shell, screws, inner
    mechanics: the UR10 shoulder's COLLADA file has dozens); the skin goes on the outer shell."""
    import trimesh

    m = trimesh.Trimesh(mesh.vertices, mesh.faces, process=False, validate=False)
    m.merge_vertices()
    labels = trimesh.graph.connected_component_labels(m.face_adjacency, node_count=len(m.faces))
    area = np.bincount(labels, weights=mesh.area_faces)
    return labels == int(np.argmax(area))


def lay_on_link(robot: Robot, link: str, patch: str = "fill", at=None, direction=None, *, geometry: str = "visual",
                module="cyskin10", offset: float = 0.0, method: str = "logmap", radius: float | None = None,
                mesh=None, **options):
    """Place ``patch`` ("hexagon", "triangle", "strip:N") or ``"fill"`` on ``link`` of ``robot``.

    at : (3,) metres in the link frame (default :func:`default_anchor`). geometry : "visual" or
    "collision". mesh : the link's surface if already loaded (:func:`.meshes.link_mesh`).
    options : passed to :func:`vtcore.layout.fill` (``region``, ``max_faces``, ``progress``, ...); a
    fill's region defaults to the link's outer shell (:func:`outer_region`).
    Returns ``(layout, report)``; the layout is in the link's frame. A link no module fits on is an
    InputError naming the link and what the placement report says.
    """
    from ..layout import fill, place
    from ..layout.islands import NoModuleFits
    from .meshes import link_mesh

    if mesh is None:
        mesh = link_mesh(robot, link, geometry)
    if patch == "fill" and options.get("region") is None:
        options["region"] = outer_region(mesh)
    if patch == "fill":
        at = anchors(mesh, options.get("region"))[0] if at is None else np.asarray(at, dtype=np.float64).reshape(3)
        try:
            layout, report = fill(mesh, at, direction, module=module, radius=radius, offset=offset, **options)
        except NoModuleFits as exc:  # the fill's reason, said of this link (a robot has many)
            raise NoModuleFits(f"no module fits on link {link!r} ({geometry} geometry): {exc.reason}", exc.details,
                               key="--link") from None
    else:
        tries = anchors(mesh)[:ANCHOR_TRIES] if at is None else [np.asarray(at, dtype=np.float64).reshape(3)]
        best = None
        for point in tries:  # without a given point: the first place the patch lies well, else the least strained
            layout, report = place(mesh, patch, point, direction, module=module, offset=offset, method=method,
                                   **options)
            fine = len(layout) and not len(report.off_boundary) and report.strain_max <= GOOD_STRAIN
            if best is None or (len(layout) and (not len(best[0]) or report.strain_max < best[1].strain_max)):
                best = (layout, report)
            if fine:
                best = (layout, report)
                break
        layout, report = best
    if len(layout) == 0:
        why = "; ".join(report.notes[-3:]) if getattr(report, "notes", None) else "no module fits"
        raise InputError(f"no module fits on link {link!r} ({geometry} geometry): {why}", file=robot.path,
                         key="--link")
    layout.frame, layout.parent, layout.transform = link, None, np.eye(4)
    layout.meta.update({"robot": str(robot.path), "robot_format": robot.format, "link": link,
                        "geometry": geometry})
    return layout, report
