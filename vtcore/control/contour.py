"""Tapping contour following of seed 002 (§5.1-5.2, Eq. 9), in simulation.

The controller works in a *control frame* attached to the end-effector: origin
at the reference point ``x_R``, z along the approach axis (perpendicular to the
object surface, pointing from the object to the skin), x along the edge to be
followed. Each tap: approach along z until contact and hold the target force
(the ``sense`` callable: "press here and give me the taxel pressures"), find
the edges (a detector from :mod:`vtcore.filters`), compute the planar motion of
Eq. 9, lift, move, repeat.

Eq. 9: translate by ``(s cos theta, x_C2 - x_R2, 0)`` in the control frame and
rotate by ``theta`` about z through ``x_R`` (``x_R`` is the frame origin, so
``x_R2 = 0``), where ``theta`` is the mean edge orientation and ``x_C`` the
edge centroid. Orientations are undirected (mod pi) and kept in (-pi/2, pi/2],
so ``s cos theta > 0``: the robot keeps going the way it was heading.

Poses are 4x4 homogeneous matrices, metres.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable

import numpy as np

from ..contact.analytic import footprint_pressure
from ..errors import InputError
from ..tolerances import EPS


def rot_z(a: float) -> np.ndarray:
    c, s = np.cos(a), np.sin(a)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def pose(rotation=None, translation=(0.0, 0.0, 0.0)) -> np.ndarray:
    """4x4 pose from a (3, 3) rotation and a (3,) translation (metres)."""
    m = np.eye(4)
    if rotation is not None:
        m[:3, :3] = rotation
    m[:3, 3] = translation
    return m


def facing_down(x_ref_world, heading: float, height: float = 0.0) -> np.ndarray:
    """Control-frame pose in the world for a skin facing down onto the plane z = 0.

    The control frame's z is the skin's outward normal at x_R, so it points down
    in the world (towards the object): the rotation is ``Rz(heading) Rx(pi)``
    (``Rx(pi) = diag(1, -1, -1)``); its x axis lies along ``heading`` (radians,
    world xy plane). ``x_ref_world`` (2,) or (3,) metres; ``height`` the origin's z.
    """
    flip = np.diag([1.0, -1.0, -1.0])
    p = np.zeros(3)
    p[: len(np.ravel(x_ref_world))] = np.ravel(x_ref_world)
    p[2] = height
    return pose(rot_z(heading) @ flip, p)


def heading_of(world_pose) -> float:
    """World heading (radians) of a control frame's x axis."""
    x = np.asarray(world_pose)[:3, 0]
    return float(np.arctan2(x[1], x[0]))


def control_frame(layout) -> np.ndarray:
    """Pose (4x4) of the control frame in the layout's frame.

    Origin at x_R: ``layout.meta["reference_taxel"]`` (a taxel index) or
    ``layout.meta["reference_point"]`` (3,), else the taxel nearest the centroid.
    z: the outward normal at x_R (the approach axis, perpendicular to the object).
    x: for a skin curved about one axis (seed 002's non-planar patch) the axis
    of the curvature; for a flat skin, the layout's x axis (projected).
    It is the frame the edge detectors project into (Eq. 8),
    :func:`vtcore.filters.skin_frame`, which lives in ``vtcore.filters`` so the
    filters' own benchmark can use it without importing control.
    """
    from ..filters import skin_frame

    return skin_frame(layout)


def motion(features, step: float):
    """Eq. 9: ``(dx, dy, dtheta)`` in the control frame from edge features.

    features : EdgeFeatures in the control frame (x_R at the origin). step : s, metres.
    Components without an orientation (single points, blobs) leave theta at 0.
    """
    theta = float(features.theta) if features.has_orientation else 0.0
    return step * np.cos(theta), float(features.centroid[1]), theta


def motion_matrix(dx: float, dy: float, dtheta: float) -> np.ndarray:
    """4x4 control-frame motion: translate by (dx, dy, 0), then rotate by dtheta about the new x_R."""
    return pose(rot_z(dtheta), (dx, dy, 0.0))


@dataclass
class ContourRun:
    """One contour-following experiment.

    poses : (L, 4, 4) control frame in the world at each tap (before pressing).
    x_ref : (L, 3) metres, x_R in the world at each tap (seed 002's x_l).
    pressure : (L, N) taxel pressure (or counts) at each tap.
    centroid : (L, 2) metres, edge centroid in the control frame (0 when none).
    theta : (L,) radians, mean edge orientation. n_components, n_edge_points : (L,) int.
    edge : (L, N) bool, taxels marked as edges (mesh method; empty for others).
    stop_reason : why it ended ("explored", "no contact", "no edge", "max taps").
    """

    poses: np.ndarray
    x_ref: np.ndarray
    pressure: np.ndarray
    centroid: np.ndarray
    theta: np.ndarray
    n_components: np.ndarray
    n_edge_points: np.ndarray
    edge: np.ndarray
    stop_reason: str
    seconds_detect: float = 0.0
    extra: dict = field(default_factory=dict)

    def __len__(self) -> int:
        return len(self.x_ref)


class ContourFollower:
    """The tapping loop of seed 002 §5.2.

    detector : object with ``detect(pressure (N,)) -> EdgeFeatures`` (control frame).
    step : s of Eq. 9, metres (seed 002: 5 mm). lift : metres raised between taps
    (recorded; the approach itself is the ``sense`` callable's job).
    max_taps : safety limit.
    """

    def __init__(self, detector, step: float = 5e-3, lift: float = 0.01, max_taps: int = 200):
        if not step > 0:
            raise InputError(f"must be > 0, got {step}", key="step")
        if int(max_taps) < 1:
            raise InputError(f"must be >= 1, got {max_taps}", key="max_taps")
        self.detector, self.step, self.lift, self.max_taps = detector, float(step), float(lift), int(max_taps)

    def run(self, sense: Callable, start_pose, stop: Callable | None = None) -> ContourRun:
        """Follow a contour from ``start_pose`` (4x4, control frame in the world).

        sense : ``sense(world_pose) -> (N,) pressures`` after approaching and
            force control, or ``None`` when no contact can be made there.
        stop : ``stop(x_ref (L, 3), poses (L, 4, 4)) -> bool``, True once the contour
            is explored (checked after every tap).
        """
        import time

        cur = np.asarray(start_pose, dtype=np.float64).copy()
        poses, xr, pres, cen, th, ncomp, npts, edges = [], [], [], [], [], [], [], []
        reason = "max taps"
        t_det = 0.0
        for _ in range(self.max_taps):
            p = sense(cur)
            if p is None:
                reason = "no contact"
                break
            p = np.asarray(p, dtype=np.float64)
            t0 = time.perf_counter()
            f = self.detector.detect(p)
            t_det += time.perf_counter() - t0
            poses.append(cur.copy())
            xr.append(cur[:3, 3].copy())
            pres.append(p)
            cen.append(np.asarray(f.centroid, dtype=np.float64))
            th.append(float(f.theta))
            ncomp.append(f.n_components)
            npts.append(len(f.points))
            mask = f.extra.get("mask")
            edges.append(mask if mask is not None and len(mask) == len(p) else np.zeros(len(p), bool))
            if not f.found:
                reason = "no edge"
                break
            if stop is not None and stop(np.array(xr), np.array(poses)):
                reason = "explored"
                break
            cur = cur @ motion_matrix(*motion(f, self.step))
        n = len(pres[0]) if pres else int(getattr(self.detector, "n", 0))
        return ContourRun(
            poses=np.array(poses).reshape(-1, 4, 4), x_ref=np.array(xr).reshape(-1, 3),
            pressure=np.array(pres).reshape(-1, n), centroid=np.array(cen).reshape(-1, 2),
            theta=np.array(th), n_components=np.array(ncomp, dtype=np.int64),
            n_edge_points=np.array(npts, dtype=np.int64),
            edge=np.array(edges, dtype=bool).reshape(-1, n), stop_reason=reason, seconds_detect=t_det)


# --------------------------------------------------------------------------------------
# Contours, their error (seed 002 §6) and stop rules
# --------------------------------------------------------------------------------------

@dataclass
class LineContour:
    """A straight edge along world x at ``y = offset`` from ``x_start`` to ``x_end`` (metres)."""

    offset: float = 0.0
    x_start: float = -0.125
    x_end: float = 0.125
    width: float = 1e-3

    def distances(self, x_ref) -> np.ndarray:
        """Seed 002: ``d_l = |x_l2 - c|`` for the taps l = 2..L (metres)."""
        x = np.asarray(x_ref, dtype=np.float64).reshape(-1, 3)[1:]
        return np.abs(x[:, 1] - self.offset)

    def explored(self, margin: float = 0.0):
        """Stop rule: x_R has passed ``x_end - margin``."""
        return lambda xr, poses: bool(xr[-1, 0] >= self.x_end - margin)

    def footprint_distance(self, xy) -> np.ndarray:
        """Distance (m) of world points (M, 2) from the edge's top face (0 on it)."""
        xy = np.asarray(xy, dtype=np.float64)
        dy = np.maximum(np.abs(xy[:, 1] - self.offset) - self.width / 2, 0.0)
        dx = np.maximum(np.maximum(self.x_start - xy[:, 0], xy[:, 0] - self.x_end), 0.0)
        return np.hypot(dx, dy)


@dataclass
class CircleContour:
    """A circular rim (a mug) centred at ``centre`` (2,) in the world plane.

    inner, outer : radii of the rim's top face (m). reference : the radius the
    error is measured against (seed 002: 39.5 mm for a 75/81 mm mug).
    """

    centre: tuple = (0.0, 0.0)
    inner: float = 0.0375
    outer: float = 0.0405
    reference: float = 0.0395

    def distances(self, x_ref) -> np.ndarray:
        """Seed 002: polar coordinates about the centre, ``d_l = |x_l - r_bar (cos a_l, sin a_l)|``."""
        x = np.asarray(x_ref, dtype=np.float64).reshape(-1, 3)[1:, :2] - np.asarray(self.centre)
        r = np.hypot(x[:, 0], x[:, 1])
        return np.abs(r - self.reference)

    def swept_angle(self, x_ref) -> float:
        """Absolute angle (radians) travelled around the centre by x_R."""
        x = np.asarray(x_ref, dtype=np.float64).reshape(-1, 3)[:, :2] - np.asarray(self.centre)
        a = np.unwrap(np.arctan2(x[:, 1], x[:, 0]))
        return float(abs(a[-1] - a[0])) if len(a) else 0.0

    def explored(self, angle: float = 2 * np.pi):
        """Stop rule: x_R has gone ``angle`` radians around the rim."""
        return lambda xr, poses: self.swept_angle(xr) >= angle

    def footprint_distance(self, xy) -> np.ndarray:
        xy = np.asarray(xy, dtype=np.float64) - np.asarray(self.centre)
        r = np.hypot(xy[:, 0], xy[:, 1])
        return np.maximum(np.maximum(self.inner - r, r - self.outer), 0.0)


def summarize(distances_per_run) -> dict:
    """Seed 002 §6 statistics over runs (each a (L-1,) array, metres).

    Returns ``d_mean`` (mean of the per-run means), ``d_std`` (mean of the per-run
    standard deviations), ``d_max`` (maximum over all runs), in metres; NaN-free
    (0 with no taps, ``taps`` tells).
    """
    runs = [np.asarray(d, dtype=np.float64) for d in distances_per_run if len(d)]
    if not runs:
        return {"d_mean": 0.0, "d_std": 0.0, "d_max": 0.0, "taps": 0}
    return {"d_mean": float(np.mean([d.mean() for d in runs])),
            "d_std": float(np.mean([d.std() for d in runs])),
            "d_max": float(max(d.max() for d in runs)),
            "taps": int(sum(len(d) for d in runs))}


class AnalyticContact:
    """An analytic stand-in for a force-controlled press onto a thin contour.

    The object's top face (a :class:`LineContour` or :class:`CircleContour`) lies
    in the world plane z = 0. A taxel at world point ``q`` bears pressure
    ``exp(-dist^2 / (2 spread^2)) * max(0, 1 - (q_z - z_min) / depth)``, where
    ``dist`` is its horizontal distance to the face, ``z_min`` the lowest skin
    point above the face (where a curved skin touches first) and ``depth`` the
    layer thickness; the field is scaled to the target force over the taxel area.
    Not a contact solver (use :func:`vtcore.contact.press`): a smooth, exactly
    known pressure for testing the controller and the filters.

    positions : (N, 3) taxels in the control frame. force : N. area : m^2 per taxel.
    """

    def __init__(self, positions, contour, force: float = 15.0, spread: float = 2e-3,
                 depth: float = 3e-3, area: float = 4.9e-5):
        self.positions = np.asarray(positions, dtype=np.float64)
        self.contour, self.force = contour, float(force)
        self.spread, self.depth, self.area = float(spread), float(depth), float(area)

    def __call__(self, world_pose):
        q = self.positions @ np.asarray(world_pose)[:3, :3].T + np.asarray(world_pose)[:3, 3]
        dist = self.contour.footprint_distance(q[:, :2])
        return footprint_pressure(dist, q[:, 2], self.force, self.spread, self.depth, self.area)


# --------------------------------------------------------------------------------------
# Seed 002's experiment: skins in the control frame, objects, starts, a press per tap
# --------------------------------------------------------------------------------------

def control_skin(name: str):
    """``(end-effector mesh, layout in the control frame, control frame pose in the layout frame)``.

    name : a ``vtcore.layout`` end-effector, e.g. ``"seed002_planar"`` or ``"seed002_curved"``.
    """
    from .. import layout as L

    mesh, lay = getattr(L, name)()
    frame = control_frame(lay)
    moved = lay.transformed(np.linalg.inv(frame), frame="control")
    moved.meta = dict(lay.meta)
    return mesh, moved, frame


def seed002_object(kind: str, *, ruler_length: float = 0.25, ruler_thickness: float = 1e-3,
                   ruler_height: float = 0.02, mug_outer_diameter: float = 0.081,
                   mug_inner_diameter: float = 0.075, mug_height: float = 0.10,
                   reference_radius: float = 0.0395):
    """Seed 002's objects standing on a table whose top face is the world plane z = 0.

    kind : ``"ruler"`` (a 1 mm thick straight edge along world x) or ``"mug"`` (a rim,
    81/75 mm, error measured against the 39.5 mm reference radius). Metres.
    Returns ``(contour, (make_object kind, dims), world pose (4, 4) of the object)``.
    """
    if kind == "ruler":
        half = ruler_length / 2
        contour = LineContour(0.0, -half, half, ruler_thickness)
        spec = ("box", {"extents": (ruler_length, ruler_thickness, ruler_height)})
        height = ruler_height
    elif kind == "mug":
        ro, ri = mug_outer_diameter / 2, mug_inner_diameter / 2
        if not ri < ro:
            raise InputError("must be smaller than mug_outer_diameter", key="mug_inner_diameter")
        contour = CircleContour((0.0, 0.0), ri, ro, reference_radius)
        spec = ("mug", {"radius": ro, "wall": ro - ri, "height": mug_height})
        height = mug_height
    else:
        raise InputError(f"unknown object {kind!r}; use 'ruler' or 'mug'", key="object")
    world = np.eye(4)
    world[2, 3] = -height  # the object stands on a table; its top face is the plane z = 0
    return contour, spec, world


def random_starts(contour, runs: int, rng, *, offset: float = 2e-3, heading: float = 0.17,
                  step: float = 5e-3, margin: float = 0.03) -> list:
    """Seeded initial control-frame poses (4x4, world) near ``contour``.

    x_R within ``+-offset`` m of the contour (the reference radius for a circle),
    heading error within ``+-heading`` rad; a line starts ``margin`` (+ up to one
    ``step``) inside its start, a circle at a random angle, going clockwise as in
    seed 002 Fig. 8.
    """
    out = []
    for _ in range(int(runs)):
        off = rng.uniform(-offset, offset)
        hd = rng.uniform(-heading, heading)
        if isinstance(contour, LineContour):
            x0 = contour.x_start + margin + rng.uniform(0, step)
            out.append(facing_down([x0, contour.offset + off], hd))
        else:
            a0 = rng.uniform(0, 2 * np.pi)
            r = contour.reference + off
            c = np.asarray(contour.centre)
            # clockwise: heading = angle - pi/2
            out.append(facing_down(c + r * np.array([np.cos(a0), np.sin(a0)]), a0 - np.pi / 2 + hd))
    return out


class PressContact:
    """One tap of seed 002 §5.2 with the contact solver: ``sense(world_pose) -> (N,) Pa or None``.

    The control frame is placed at ``world_pose`` with the skin's outer surface
    ``lift`` above the object's top (``height = layer.thickness + lift``), then
    the object is pressed along the approach axis until ``force`` N
    (``vtcore.contact.press``). Only taxels within ``active_depth`` m of the tangent
    plane at x_R are solved: the rest cannot reach a flat-topped object within
    the layer's travel (<1 % change, 3-5x faster).

    A tap whose force would bottom the layer out presses as deep as the layer
    allows (80 % of its thickness), as a real force loop stops at the hard stop;
    ``saturated`` counts such taps, ``forces`` holds the force of each tap (N).

    layout : Layout in the control frame. mesh : object (trimesh, object frame).
    world : (4, 4) object pose in the world. layer : vtcore.contact.SoftLayer.
    press_options : more keyword arguments for ``vtcore.contact.press``.
    """

    def __init__(self, layout, mesh, world, layer, force: float = 15.0, lift: float = 0.01,
                 active_depth: float = 0.012, **press_options):
        self.n = len(layout)
        self.active = np.flatnonzero(np.asarray(layout.positions)[:, 2] >= -active_depth)
        self.sub = layout.subset(self.active)
        self.mesh, self.world, self.layer = mesh, np.asarray(world, dtype=np.float64), layer
        self.force, self.height = float(force), layer.thickness + float(lift)
        self.options = dict(direction=[0.0, 0.0, -1.0], open_mesh="envelope", **press_options)
        self.saturated, self.forces = 0, []

    def __call__(self, world_pose):
        from ..contact import press
        from ..errors import UnreachableTargetError

        w = np.array(world_pose, dtype=np.float64)
        w[2, 3] = self.height
        pose = np.linalg.inv(w) @ self.world
        try:
            res = press(self.sub, self.mesh, pose, self.layer, force=self.force, **self.options)
        except UnreachableTargetError:
            # either the object misses the skin, or the layer would bottom out before the
            # target force (a short contact across the curved patch)
            try:
                res = press(self.sub, self.mesh, pose, self.layer, indentation=0.8 * self.layer.thickness,
                            **self.options)
            except UnreachableTargetError:
                return None
            if not np.any(res.pressure > 0):
                return None
            self.saturated += 1
        self.forces.append(float(res.force))
        full = np.zeros(self.n)
        full[self.active] = res.pressure
        return full


POSITION_ERROR_MODELS = ("module", "taxel")


def taxel_position_error(layout, rms: float, rng, model: str = "module") -> np.ndarray:
    """(N, 3) metres: the error of a robot's estimate of its taxel positions.

    rms : root-mean-square length of the per-taxel error (m); seed 002 gives "an
    uncertainty of 1 mm" for its hand-built curved patch.
    model : ``"module"`` (default) a rigid misplacement of each module
    (``layout.module_ids``): a translation in the module's tangent plane and a
    rotation about its mean normal, equal in mean square. CySkin taxels sit on
    rigid triangular PCBs whose layout is known from CAD (seed 002: the flat
    patch's positions are exact); the error comes from placing the modules by
    hand, so neighbours on one module keep their exact distance.
    ``"taxel"``: an independent isotropic error per taxel (std ``rms / sqrt(3)``
    per axis), a worst case that also changes distances within a module.
    """
    pos = np.asarray(layout.positions, dtype=np.float64)
    if model == "taxel":
        return rng.normal(0.0, rms / np.sqrt(3.0), pos.shape)
    if model != "module":
        raise InputError(f"unknown model {model!r}; use {' or '.join(POSITION_ERROR_MODELS)}", key="model")
    nrm = np.asarray(layout.normals, dtype=np.float64)
    mids, inv = np.unique(np.asarray(layout.module_ids), return_inverse=True)
    k = len(mids)
    count = np.bincount(inv, minlength=k)[:, None]
    centre = np.column_stack([np.bincount(inv, pos[:, j], k) for j in range(3)]) / count
    normal = np.column_stack([np.bincount(inv, nrm[:, j], k) for j in range(3)])
    normal /= np.maximum(np.linalg.norm(normal, axis=1, keepdims=True), EPS)
    r = pos - centre[inv]
    r_rms = np.sqrt(np.bincount(inv, np.sum(r**2, axis=1), k) / count[:, 0])
    t = rng.normal(0.0, 1.0, (k, 3))
    t -= normal * np.sum(t * normal, axis=1, keepdims=True)  # in the tangent plane: E|t|^2 = 2
    # rotation about the module normal by an angle whose arc is rms/sqrt(2) on average;
    # Rodrigues' formula, so the module stays exactly rigid
    a = rng.normal(0.0, 1.0, k) * (rms / np.sqrt(2.0)) / np.maximum(r_rms, EPS)
    ai, ni = a[inv, None], normal[inv]
    rot = (r * (np.cos(ai) - 1.0) + np.cross(ni, r) * np.sin(ai)
           + ni * np.sum(ni * r, axis=1, keepdims=True) * (1.0 - np.cos(ai)))
    return t[inv] * (rms / 2.0) + rot                           # E|t|^2 = 2: translation rms/sqrt(2)


def believed_skin(layout, error):
    """The skin as the robot believes it, and the true skin, both in the believed control frame.

    layout : Layout in the (true) control frame. error : (N, 3) m, the position error.
    The robot builds its control frame (x_R, approach axis, x along the curvature) from
    what it believes, so x_R is the believed reference taxel; the contact sees the true
    taxels. Returns ``(true layout, believed layout, F)`` with F (4x4) the believed
    control frame in the true one.
    """
    belief = layout.subset(slice(None))
    belief.positions = np.asarray(layout.positions, dtype=np.float64) + error
    f = control_frame(belief)
    inv = np.linalg.inv(f)
    return layout.transformed(inv), belief.transformed(inv), f
