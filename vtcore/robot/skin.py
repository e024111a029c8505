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
    from .exposure import body_labels

    labels = body_labels(mesh)
    area = np.bincount(labels, weights=mesh.area_faces)
    return labels == int(np.argmax(area))


#: metres: with the exposure check on, a coarse link mesh (more than :data:`COARSE_AREA` of its area in
#: faces with an edge longer than this) is split first (on its own faces: the surface does not move), so
#: that the exposed-face mask can follow a neighbour's edge on a collision box instead of keeping or
#: dropping a whole 50 mm face; a CAD mesh's few long slivers are left as they are (the taxel check
#: after the fill catches what they hide)
EXPOSURE_EDGE = 0.01
COARSE_AREA = 0.2
#: faces the split may make, about: past it the edge grows with the link's size (a millimetre tube
#: scaled to 48 m by a typo in its mesh scale was split to 10 mm edges for minutes, past the fuzz alarm)
EXPOSURE_MAX_FACES = 30_000


def _split_edge(area: float, length: float) -> float:
    """Metres: :data:`EXPOSURE_EDGE`, or longer where splitting faces of total ``area`` (m^2) and
    total longest-edge ``length`` (m) to it would make more than :data:`EXPOSURE_MAX_FACES` faces.
    Faces made, over-estimated: 3 area / (0.43 e^2) (fat faces) + 2 length / e (needles are split
    along their length only); e solves that count = the cap."""
    cap = float(EXPOSURE_MAX_FACES)
    a, b = 3.0 * area / 0.433, 2.0 * length
    if a / EXPOSURE_EDGE ** 2 + b / EXPOSURE_EDGE <= cap:  # every link of ordinary size: as before
        return EXPOSURE_EDGE
    return float((b + np.sqrt(b * b + 4.0 * a * cap)) / (2.0 * cap))


def exposure_mesh(mesh, region=None):
    """``(mesh, region)`` with ``mesh``'s edges longer than :data:`EXPOSURE_EDGE` split (longer on a link
    so large that it would make more than :data:`EXPOSURE_MAX_FACES` faces; the same
    object when none is) and ``region`` (an (F,) bool mask of the given mesh, or None) carried to
    the new faces (each lies on one old face: the one nearest its centre)."""
    from ..layout.repair import longest_edges, refine
    from ..layout.surface import closest_points

    if not len(mesh.faces):
        return mesh, region
    longest = longest_edges(np.asarray(mesh.vertices), np.asarray(mesh.faces))
    long = longest > EXPOSURE_EDGE
    area = np.asarray(mesh.area_faces)
    if area[long].sum() <= COARSE_AREA * area.sum():
        return mesh, region
    edge = _split_edge(float(area.sum()), float(longest.sum()))
    fine = refine(mesh, edge)
    if len(fine.faces) > 1.5 * EXPOSURE_MAX_FACES:  # the estimate was short (needles of a link metres long)
        fine = refine(mesh, edge * float(np.sqrt(len(fine.faces) / EXPOSURE_MAX_FACES)))
    if region is not None:
        region = np.asarray(region, dtype=bool)[closest_points(mesh, np.asarray(fine.triangles_center))[1]]
    return fine, region


def reasons_on(mesh, fine, reason) -> np.ndarray:
    """(F,) int8: the exposure ``reason`` codes of ``fine``'s faces (a split copy of ``mesh`` from
    :func:`exposure_mesh`, or ``mesh`` itself) carried back to ``mesh``'s own faces, to colour the
    mesh a user sees: each face takes the reason of most of its area (a 50 mm face of a collision
    box two-thirds under a neighbour shows as covered)."""
    from ..layout.surface import closest_points
    from .exposure import COLOURS

    reason = np.asarray(reason, dtype=np.int64)
    if fine is mesh:
        return reason.astype(np.int8)
    owner = closest_points(mesh, np.asarray(fine.triangles_center))[1]  # each split face lies on one face
    k = len(COLOURS)
    area = np.bincount(owner * k + reason, weights=np.asarray(fine.area_faces), minlength=len(mesh.faces) * k)
    return area.reshape(-1, k).argmax(axis=1).astype(np.int8)


def exposure_of(robot: Robot, link: str, geometry: str, mesh, exposure, probe_radius=None):
    """``(exposure, surfaces)``: the :class:`.exposure.Exposure` of ``link`` on ``mesh`` (``exposure``
    itself when it is one, computed by the caller for this mesh; else computed, ``probe_radius``
    metres, default 8 mm) and the :class:`.exposure.RobotSurfaces` the taxel check reuses."""
    from .exposure import PROBE_RADIUS, Exposure, exposed_faces, shared_surfaces

    surfaces = shared_surfaces(robot, geometry)
    if isinstance(exposure, Exposure):
        if len(exposure.reason) != len(mesh.faces):
            raise InputError(f"the exposure has {len(exposure.reason)} faces, the mesh {len(mesh.faces)}",
                             key="exposure")
        return exposure, surfaces
    return exposed_faces(robot, link, geometry, mesh=mesh, probe_radius=probe_radius or PROBE_RADIUS,
                         surfaces=surfaces), surfaces


class NoExposedSurface(InputError):
    """A link (or a region of it) with no exposed face: like :class:`..layout.islands.NoModuleFits`, a
    refusal of that link (``vtcore robot skin`` reports it "refused", not "failed")."""


#: how the refusal names the way round it (the CLI's option; the add-on names its own)
ANYWHERE_HINT = "--anywhere lays it there anyway"


def no_exposed_surface(robot: Robot, link: str, geometry: str, exp, where: str = "") -> InputError:
    """The one-line refusal of a link (or a region of it) with no exposed face."""
    return NoExposedSurface(f"link {link!r} ({geometry} geometry) has no exposed surface{where} to lay skin on: "
                      f"{exp.excluded_text().split(': ', 1)[1]}; {ANYWHERE_HINT}",
                      file=robot.path, key="--link")


def check_taxels(robot: Robot, link: str, geometry: str, mesh, layout, exp, *, what: str, force: bool,
                 surfaces=None):
    """Judge the placed taxels against the links round them at the zero pose
    (:func:`.exposure.taxel_reasons`). A fill leaves out the modules with a taxel covered or
    unreachable (its notes say how many); a placed patch is refused
    (:class:`vtcore.layout.report.PlacementRefused`) unless ``force`` (then a warning).
    Returns the layout kept and the note (or None)."""
    import warnings

    from ..layout.mesh import LayoutWarning
    from ..layout.report import PlacementRefused
    from .exposure import COVERED, UNREACHABLE, taxel_reasons

    if not len(layout):
        return layout, None
    why = taxel_reasons(robot, link, layout.positions, layout.normals, geometry, mesh=mesh,
                        probe_radius=exp.probe_radius, clearance=exp.clearance, surfaces=surfaces)
    bad = why != 0
    if not bad.any():
        return layout, None
    n_cov, n_unr = int((why == COVERED).sum()), int((why == UNREACHABLE).sum())
    parts = ([f"{n_cov} within {1e3 * exp.clearance:g} mm of or inside another link or another body of "
              "this one"] if n_cov else []) + (
        [f"{n_unr} where no {1e3 * exp.probe_radius:g} mm probe reaches"] if n_unr else [])
    text = f"{int(bad.sum())} of {len(layout)} taxels would lie on covered or unreachable surface ({', '.join(parts)})"
    if what != "fill":
        if not force:
            raise PlacementRefused([f"{text}: move --at to the exposed surface, or lay it --anywhere"], what)
        warnings.warn(f"kept with --force: {text}", LayoutWarning, stacklevel=3)
        return layout, text
    drop = np.unique(layout.module_ids[bad])
    kept = layout.subset(~np.isin(layout.module_ids, drop))
    return kept, f"left out {len(drop)} modules after the fill: {text}"


def lay_on_link(robot: Robot, link: str, patch: str = "fill", at=None, direction=None, *, geometry: str = "visual",
                module="cyskin10", offset: float = 0.0, method: str = "logmap", radius: float | None = None,
                mesh=None, exposure=True, probe_radius: float | None = None, force: bool = False, **options):
    """Place ``patch`` ("hexagon", "triangle", "strip:N") or ``"fill"`` on ``link`` of ``robot``.

    at : (3,) metres in the link frame (default :func:`default_anchor` on the exposed surface).
    geometry : "visual" or "collision". mesh : the link's surface if already loaded
    (:func:`.meshes.link_mesh`).
    exposure : True (default): only the link's exposed surface (:mod:`.exposure`: not within 2 mm
        of or inside another link at the zero pose, not between two bodies of the link itself,
        reachable by a ``probe_radius`` sphere, default 8 mm) takes modules: a fill's region is
        cut to it, the default start lies on it, a fill leaves out modules with a taxel off it and
        a placed patch there is refused unless ``force``; an :class:`.exposure.Exposure` of
        ``mesh`` computed by the caller works the same; False: anywhere on the surface (the
        behaviour before issue 33).
    options : passed to :func:`vtcore.layout.fill` (``region``, ``max_faces``, ``progress``, ...); a
    fill's region defaults to the link's outer shell (:func:`outer_region`).
    Returns ``(layout, report)``; the layout is in the link's frame, ``meta["exposure"]`` the
    exposure's summary. A link no module fits on, or with no exposed surface, is an InputError
    naming the link.
    """
    from .meshes import link_mesh

    if mesh is None:
        mesh = link_mesh(robot, link, geometry)
    exp = surfaces = None
    if exposure is not False:
        if not (exposure is not True and len(getattr(exposure, "reason", ())) == len(mesh.faces)):
            mesh, options["region"] = exposure_mesh(mesh, options.get("region"))
        exp, surfaces = exposure_of(robot, link, geometry, mesh, exposure, probe_radius)
        if not exp.mask.any():
            raise no_exposed_surface(robot, link, geometry, exp)
    layout, report = lay_patch(robot, link, patch, at, direction, mesh, exp, geometry=geometry, module=module,
                               offset=offset, method=method, radius=radius, surfaces=surfaces, **options)
    note = None
    if exp is not None:
        layout, note = check_taxels(robot, link, geometry, mesh, layout, exp, what=patch, force=force,
                                    surfaces=surfaces)
        report.notes.append(exp.excluded_text())
        if note:
            report.notes.append(note)
    if len(layout) == 0:
        why = "; ".join(report.notes[-3:]) if getattr(report, "notes", None) else "no module fits"
        raise InputError(f"no module fits on link {link!r} ({geometry} geometry): {why}", file=robot.path,
                         key="--link")
    layout.frame, layout.parent, layout.transform = link, None, np.eye(4)
    layout.meta.update({"robot": str(robot.path), "robot_format": robot.format, "link": link,
                        "geometry": geometry})
    if isinstance(layout.meta.get("placement"), dict):
        layout.meta["placement"]["notes"] = list(report.notes)
    if exp is not None:
        layout.meta["exposure"] = dict(exp.summary(), excluded=exp.excluded_text(), taxel_check=note)
    else:
        layout.meta["exposure"] = None
    return layout, report


def interior_point(mesh, region, excluded) -> np.ndarray:
    """(3,) metres: the centre of the face of ``region`` farthest from the faces ``excluded``
    ((F,) bool masks each): where a patch is most at home on the exposed surface (a fingertip's
    free half: its pole)."""
    from scipy.spatial import cKDTree

    centres = np.asarray(mesh.triangles_center)
    idx = np.flatnonzero(region)
    far = cKDTree(centres[excluded]).query(centres[idx])[0]
    return centres[idx[int(np.argmax(far))]]


def lay_patch(robot: Robot, link: str, patch, at, direction, mesh, exp, *, geometry, module, offset, method, radius,
              surfaces=None, **options):
    """The fill or the placed patch of :func:`lay_on_link` (``exp``: the exposure, or None: anywhere)."""
    from ..layout import fill, place
    from ..layout.islands import NoModuleFits

    exposed = None if exp is None else exp.mask
    if patch == "fill":
        region = options.get("region")
        region = outer_region(mesh) if region is None else np.asarray(region, dtype=bool)
        if exposed is not None:
            cut = region & exposed
            if not cut.any() and options.get("region") is None:
                cut = exposed  # the outer shell all covered: what is exposed elsewhere
            if not cut.any():
                raise no_exposed_surface(robot, link, geometry, exp, " in the region asked for")
            region = cut
        options["region"] = region
        at = anchors(mesh, region)[0] if at is None else np.asarray(at, dtype=np.float64).reshape(3)
        try:
            return fill(mesh, at, direction, module=module, radius=radius, offset=offset, **options)
        except NoModuleFits as exc:  # the fill's reason, said of this link (a robot has many)
            raise NoModuleFits(f"no module fits on link {link!r} ({geometry} geometry): {exc.reason}", exc.details,
                               key="--link") from None
    return place_on_link(robot, link, patch, at, direction, mesh, exp, geometry=geometry, module=module,
                         offset=offset, method=method, surfaces=surfaces, **options)


def place_on_link(robot: Robot, link: str, patch, at, direction, mesh, exp, *, geometry, module, offset, method,
                  surfaces=None, **options):
    """The placed patch of :func:`lay_patch`. Without ``at`` the start is searched for on the exposed
    surface: first the exposed point farthest from the excluded faces (:func:`interior_point`), then
    the default anchors (:func:`anchors`) round which the whole patch fits, those whose nearest excluded
    face lies farther than the first placement's extent (:func:`fitting_anchors`); the first place
    where every taxel is exposed and the patch lies well wins, else the one with fewest taxels off the
    exposed surface."""
    from ..layout import place

    exposed = None if exp is None else exp.mask
    if at is None:
        region = outer_region(mesh)
        if exposed is not None:
            region = region & exposed if (region & exposed).any() else exposed
        cands = anchors(mesh, region)
        partial = exposed is not None and not exposed.all()
        tries = [interior_point(mesh, region, ~exposed) if partial else cands[0]]
    else:
        tries, partial = [np.asarray(at, dtype=np.float64).reshape(3)], False
    best, best_score = None, None
    for k, point in enumerate(tries):  # the list grows after the first try, once the patch's extent is known
        layout, report = place(mesh, patch, point, direction, module=module, offset=offset, method=method,
                               **options)
        bad = 0
        if exp is not None and at is None and len(layout):
            from .exposure import taxel_reasons

            bad = int(np.count_nonzero(taxel_reasons(robot, link, layout.positions, layout.normals, geometry,
                                                     mesh=mesh, probe_radius=exp.probe_radius,
                                                     clearance=exp.clearance, surfaces=surfaces)))
        # fewest taxels on covered or unreachable faces, then the least strained
        score = (not len(layout), bad, report.strain_max)
        if best is None or score < best_score:
            best, best_score = (layout, report), score
        if len(layout) and not bad and not len(report.off_boundary) and report.strain_max <= GOOD_STRAIN:
            return layout, report
        if k == 0 and at is None:
            rest = cands[1:ANCHOR_TRIES]  # four starts in all, as before the search
            if partial:
                extent = (float(np.linalg.norm(layout.positions - point, axis=1).max()) if len(layout)
                          else ANCHOR_RADIUS) + FIT_MARGIN
                rest = fitting_anchors(mesh, ~exposed, extent, cands)[:ANCHOR_TRIES]
            tries += list(rest)
    return best


#: metres: a start fits a patch when no excluded face centre lies within the patch's extent plus this
#: (a face centre stands for a face up to a few mm across)
FIT_MARGIN = 0.003


def fitting_anchors(mesh, excluded, extent: float, candidates) -> np.ndarray:
    """``candidates`` (K, 3) reordered for a patch reaching ``extent`` metres round its start: those with
    no face of ``excluded`` ((F,) bool) within ``extent`` first, in their own order (flat, central),
    then the others, the farthest from the excluded faces first."""
    from scipy.spatial import cKDTree

    candidates = np.asarray(candidates, dtype=np.float64).reshape(-1, 3)
    if not np.any(excluded) or not len(candidates):
        return candidates
    clear = cKDTree(np.asarray(mesh.triangles_center)[excluded]).query(candidates)[0]
    fits = clear >= extent
    order = np.lexsort((np.where(fits, np.arange(len(candidates)), -clear), ~fits))
    return candidates[order]
