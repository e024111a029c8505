"""A simulated press matched to a recorded frame: the indenter laid where the recorded footprint
lies, along its long axis, pressed along the skin's normal there, on the real layout.

The press is solved on the taxels within ``window`` of the contact (a sub-layout: the plane solve's
height field and grid then cover the contact's neighbourhood, not the whole half-cylinder) and the
readings are put back in the full layout's order (0 elsewhere).

Pose and force rule (force is not recorded): a recording is one placement of the finger, so its
frames are pressed at the recording's mean contact pose (the footprints' centroids move by a
millimetre or so while the finger lands and lifts, less than a pose read from a 7 mm taxel grid
can resolve); each frame gets the force at which the simulated, noise-free peak reading equals its
recorded peak. The press is computed once per recording for a ladder of forces (warm-started) and
each frame's readings are interpolated in log force between the two ladder presses around its
force. So the simulated peak matches the recorded one, and the footprint's *shape* (rings,
extent, width) is the model's prediction.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..contact import ContactGrid, SoftLayer, press
from ..contact.objects import make_object, surface_pose
from ..errors import InputError, UnreachableTargetError
from .footprint import contact_geometry
from .pose import local_surface

#: taxels within this distance of the contact centre take part in a matched press, m
WINDOW_M = 0.045
#: forces of the ladder, N: 1/8 to 16 N in steps of sqrt(2) (a frame's readings are interpolated in
#: log force between two neighbours: the step keeps that interpolation within ~1 % of a direct press)
LADDER_N = tuple(float(x) for x in 2.0 ** (np.arange(-6, 9) / 2.0))


@dataclass
class FramePose:
    """Where a frame's contact lies. centre (3,) m on the taxel surface; normal (3,) unit, outward;
    axis (3,) unit, the footprint's long direction; curvature 1/m of the skin along the axis (> 0 convex)."""

    centre: np.ndarray
    normal: np.ndarray
    axis: np.ndarray
    curvature: float


def frame_poses(counts, layout, sigma, k: float = 5.0) -> list[FramePose]:
    """(K,) FramePoses of the recorded frames ``counts`` (K, N) on ``layout``."""
    c, n, a, _ = contact_geometry(counts, layout.positions, layout.normals, sigma, k=k)
    out = []
    for i in range(len(c)):     # a handful of frames per recording: one small least-squares fit each
        point, normal, kappa = local_surface(layout.positions, c[i], n[i], a[i])
        axis = a[i] - (a[i] @ normal) * normal
        out.append(FramePose(point, normal, axis / max(np.linalg.norm(axis), 1e-12), kappa))
    return out


def mean_pose(poses: list[FramePose]) -> FramePose:
    """The average of several poses (axes sign-aligned first: an axis and its opposite are one axis).
    A mean of surface points lies a little inside a convex skin: the recording's pose is the mean
    refitted with :func:`vtcore.calibrate.pose.local_surface` by whoever has the layout
    (:func:`recording_pose`)."""
    ref = poses[0].axis
    ax = np.mean([p.axis * np.sign(p.axis @ ref or 1.0) for p in poses], axis=0)
    n = np.mean([p.normal for p in poses], axis=0)
    n /= np.linalg.norm(n)
    ax -= (ax @ n) * n
    ax /= max(np.linalg.norm(ax), 1e-12)
    return FramePose(np.mean([p.centre for p in poses], axis=0), n, ax,
                     float(np.mean([p.curvature for p in poses])))


def recording_pose(poses: list[FramePose], layout) -> FramePose:
    """One pose for a recording's frames: their mean, put back on the skin's surface (normal and
    curvature refitted there)."""
    m = mean_pose(poses)
    point, normal, kappa = local_surface(layout.positions, m.centre, m.normal, m.axis)
    axis = m.axis - (m.axis @ normal) * normal
    return FramePose(point, normal, axis / max(np.linalg.norm(axis), 1e-12), kappa)


def check_wrap(value) -> float:
    """A finger pad's ``wrap`` (0-1, see :class:`MatchedPress`) as a float, or an InputError naming it."""
    try:
        w = float(value)
    except (TypeError, ValueError, OverflowError):
        w = float("nan")
    if isinstance(value, bool) or not 0.0 <= w <= 1.0:
        raise InputError(f"must be a number from 0 (a straight pad) to 1 (wrapping the skin), got {value!r}",
                         key="wrap")
    return w


#: the indenter kind of a soft finger: a finger pad whose pulp deforms too (vtcore.contact.soft_finger)
SOFT_FINGER = "softfinger"


def soft_finger_parts(indenter: dict, layer: SoftLayer):
    """``(indenter, layer)`` as the press takes them: a ``"softfinger"`` (a finger pad's ``radius``,
    ``length``, ``wrap`` and its pulp's ``pad_modulus`` Pa, ``core_depth`` m over the rigid bone,
    ``pad_poisson``) becomes a ``"fingerpad"`` mesh pressed through the layer with the pad's
    compliance in series (:func:`vtcore.contact.soft_finger.soft_indenter`); other kinds pass as given."""
    from ..contact.soft_finger import FINGER_DEFAULTS, finger_pad, soft_indenter

    if indenter.get("kind") != SOFT_FINGER:
        return indenter, layer
    pad = {k: indenter.pop(k, v) for k, v in FINGER_DEFAULTS.items()}
    radius = float(indenter.get("radius", 0.008))
    if not float(pad["core_depth"]) < radius:
        raise InputError(f"must be below the finger pad's radius ({radius:g} m): the bone lies inside the finger, "
                         f"got {pad['core_depth']!r}", key="core_depth")
    return {**indenter, "kind": "fingerpad"}, soft_indenter(layer, finger_pad(**pad))


class MatchedPress:
    """Presses of one indenter through one layer on a layout, at recorded poses.

    layout : the real layout. layer : SoftLayer. indenter : dict for make_object (``kind`` and its
    dimensions, e.g. ``{"kind": "fingerpad", "radius": 0.008, "length": 0.04}``; a finger pad's may
    hold ``wrap``, below; a ``"softfinger"`` is a finger pad whose pulp deforms too:
    :func:`soft_finger_parts`). conform : a finger pad's axis is bent along the skin's curvature (a soft
    pad lying along a convex skin wraps it), straight where the skin is flat or concave. How far:
    ``wrap`` (0-1, default 1) of the curvature of the arc concentric with the skin (radius
    1/curvature + h + pad radius): 1 wraps it fully (the pad as soft as the layer, an even
    pressure along its length), 0 leaves it straight (a rigid finger touching at one point of the
    arc); a real finger, about as soft as Ecoflex 00-20, lies in between.
    grid : ContactGrid; samples_per_taxel as in press().
    """

    def __init__(self, layout, layer: SoftLayer, indenter: dict, *, conform: bool = True,
                 grid: ContactGrid | None = None, samples_per_taxel: int = 7, window: float = WINDOW_M):
        self.layout = layout
        self.indenter, self.layer = soft_finger_parts(dict(indenter), layer)
        self.wrap = check_wrap(self.indenter.pop("wrap", 1.0))
        self.conform = conform and self.indenter.get("kind") == "fingerpad" and self.wrap > 0
        self.grid = grid or ContactGrid(spacing=1e-3)
        self.samples = samples_per_taxel
        self.window = window
        self._meshes: dict = {}
        self._subs: dict = {}

    def mesh(self, curvature: float):
        """The indenter's mesh for a skin of ``curvature`` (1/m) along its axis (cached per 5 mm of radius)."""
        kind = self.indenter["kind"]
        dims = {k: v for k, v in self.indenter.items() if k != "kind"}
        bend = 0.0
        if self.conform and curvature > 1.0:               # radius below 1 m: conform; flatter: straight
            r_skin = 1.0 / curvature
            radius = (r_skin + self.layer.thickness + dims.get("radius", 0.008)) / self.wrap
            if not radius < 1e6:  # layer.thickness 1e308: round(inf) was an OverflowError (contact.press's bound)
                raise InputError(f"a layer {self.layer.thickness:g} m thick bends the finger pad round a radius of "
                                 f"{radius:.3g} m, beyond any skin", key="thickness")
            bend = round(radius / 0.005) * 0.005
        key = (kind, tuple(sorted(dims.items())), bend)
        if key not in self._meshes:
            extra = {"bend_radius": bend} if kind == "fingerpad" else {}
            self._meshes[key] = make_object(kind, **dims, **extra)
        return self._meshes[key]

    def _sub(self, centre):
        key = tuple(np.round(centre, 9))
        hit = self._subs.get(key)
        if hit is None:
            idx = np.flatnonzero(np.linalg.norm(self.layout.positions - centre, axis=1) <= self.window)
            hit = self._subs[key] = (self.layout.subset(idx), idx)
        return hit

    def _pose(self, mesh, pose: FramePose, normal):
        top = pose.centre + self.layer.thickness * normal
        return surface_pose(mesh, top, normal, pose.axis, gap=5e-4)

    def press(self, pose: FramePose, force: float, warm=None, ref: FramePose | None = None):
        """One press: ``(pressure (N,) Pa at the taxels, full layout order, PressResult)``.

        ref : the recording's mean pose; when given, its normal is the press direction and its
        centre picks the taxels solved on, so the frames of one recording share the solver's
        cached skin grid (the finger moves by a millimetre or two within a recording)."""
        ref = ref or pose
        sub, idx = self._sub(ref.centre)
        mesh = self.mesh(ref.curvature)
        res = press(sub, mesh, self._pose(mesh, pose, ref.normal), self.layer, force=float(force),
                    direction=-ref.normal, grid=self.grid, samples_per_taxel=self.samples, warm_start=warm)
        out = np.zeros(len(self.layout.positions))
        out[idx] = res.pressure
        return out, res

    def ladder(self, pose: FramePose, forces=LADDER_N):
        """Pressures (L, N) Pa at each force of ``forces`` (N, increasing), warm-started; forces the layer
        cannot carry (it would bottom out) are left out: ``(forces (L',), pressures (L', N),
        compression (L',) max compression / thickness)``."""
        fs, ps, cs = [], [], []
        warm = None
        for f in forces:
            try:
                p, res = self.press(pose, f, warm)
            except UnreachableTargetError:
                break
            warm = res
            fs.append(f)
            ps.append(p)
            cs.append(res.max_compression / self.layer.thickness)
        return np.asarray(fs, float), np.asarray(ps, float).reshape(len(fs), -1), np.asarray(cs, float)


def force_for_peak(forces, peaks, target):
    """The force (N) at which the peak reading reaches ``target`` counts, by interpolation of
    ``peaks`` (L,) counts over ``forces`` (L,) N in log-log (clamped to the ladder's ends);
    target (K,) -> (K,) forces, and (K,) bool: reachable within the ladder."""
    f = np.asarray(forces, float)
    pk = np.maximum.accumulate(np.maximum(np.asarray(peaks, float), 1e-12))   # monotone for the inversion
    t = np.atleast_1d(np.asarray(target, float))
    ok = (t >= pk[0]) & (t <= pk[-1])
    lf = np.interp(np.log(np.maximum(t, 1e-12)), np.log(pk), np.log(f))
    return np.exp(lf), ok


def at_forces(forces, pressures, compression, f_star):
    """Ladder presses read at the forces ``f_star`` (K,) N: ``(pressures (K, N), compression (K,))``,
    linear in log force between the ladder's neighbours ``forces`` (L,) N (clamped to its ends).
    pressures (L, N) Pa (or counts: the interpolation does not care), compression (L,)."""
    lf = np.log(np.asarray(forces, float))
    x = np.clip(np.interp(np.log(np.asarray(f_star, float)), lf, np.arange(len(lf))), 0, len(lf) - 1)
    i0 = np.minimum(np.floor(x).astype(int), len(lf) - 2)
    w = (x - i0)
    p = np.asarray(pressures, float)
    c = np.asarray(compression, float)
    return p[i0] * (1 - w)[:, None] + p[i0 + 1] * w[:, None], c[i0] * (1 - w) + c[i0 + 1] * w
