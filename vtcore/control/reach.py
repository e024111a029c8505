"""Reaching in clutter with the augmented point cloud (seed 000, Sect. 4.3, Eqs. 6-7, Fig. 10).

A skin-covered link (:class:`~vtcore.control.link_skin.LinkSkin`, a disc of radius ``r``
in the trajectory plane) moves from A to B between obstacles it cannot all avoid. Three
controllers, as the paper compares them, on the same robot and skin:

- ``augmented`` (the paper's method): the reactive controller below, with each obstacle's
  Eq. 6 radius ``eps_i = c_i r_max / c_max`` and, while the link's centre is closer than
  ``eps_i`` to obstacle ``i``'s centroid, the Eq. 7 deviation, tangent to the obstacle, in
  the plane, proportional to its tactile colour:

      x_dev = gamma c_i (x_ee - x_i) / ||x_ee - x_i|| x e_z                       (Eq. 7)

  Eq. 7 changes the **direction** of motion only: the commanded velocity is the goal
  direction at nominal speed plus the deviations (``gamma c_i`` in m/s), renormalised to the
  nominal speed (a normalised velocity). It never speeds the robot up. The sense of ``e_z``
  is the one whose tangent makes progress towards B.
- ``reactive`` (the paper's baseline, its reference [39], which is also the "underlying
  control scheme" of the augmented run): the seed text names [39] but its reference list is
  not in our copy, so this is our model of a reactive tactile controller, stated: it moves
  towards B at nominal speed; when the skin's last frame (20 Hz) shows a contact whose peak
  taxel exceeds a threshold (a pressure limit: lighter contact is accepted), it removes the
  velocity component into the touched side and backs away from it at a speed proportional to
  the excess (``v_nom`` at ``react_full``), the total capped at the nominal speed. It learns
  about an obstacle only by touching it. The thresholds of [39] are not in our copy either; the
  default is the soft layer's linear-elastic limit, 30 % compression (the bound the contact
  package warns at), and nominal retreat at 60 % (:meth:`LinkSkin.compression_counts`).
- ``impedance`` (the paper's other baseline, "joint impedance control with very low
  gains"): the reference moves along the straight line at nominal speed regardless of
  contact; the robot is a soft spring (``k_low``) to it and is pushed aside by obstacles.
- ``straight`` (not in the paper; a control for attributing differences): the same straight
  reference on the augmented and reactive runs' robot (``k_robot``), no Eq. 7 and no tactile
  reaction. Against it, ``reactive`` shows what the reaction alone does and ``augmented`` what
  Eq. 7 adds on top; against ``impedance`` it shows what the low gains alone do.

The robot is quasi-static: the link's position is the equilibrium between a Cartesian
spring to the commanded reference (``k_robot``, or ``k_low`` for the impedance run) and the
obstacles' contact forces (:class:`~vtcore.control.link_skin.ContactLaw`: the skin's soft
layer in series with the obstacle's stiffness). Nothing slows the robot but its controller:
a reactive run is slower only because backing away and sliding cost progress.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..errors import InputError
from ..inputs import need_memory, need_time
from ..tolerances import EPS, LENGTH_TOL
from .link_skin import CORNER_RADIUS, LinkSkin

CONTROLLERS = ("augmented", "reactive", "impedance", "straight")
#: s: a run that has not reached B by then stops (the control loop's length)
MAX_TIME_S = 120.0
#: Optimistic CPU seconds of one control step (measured ~350 us: the equilibrium solve and the skin read,
#: 2-core machine at load 20): the time guard refuses only loops that surely exceed the budget.
STEP_S = 1e-4
#: Bytes one control step keeps (its record: measured ~650 B with tracemalloc, rounded up).
STEP_BYTES = 1000


def check_steps(dt: float, max_time: float = MAX_TIME_S, runs: int = 1, *, key: str = "dt", file=None) -> None:
    """Refuse, before the loop, ``runs`` control loops of ``max_time / dt`` steps that need more time or
    memory than the budgets (:func:`vtcore.inputs.need_time`, ``need_memory``; a dt of 1e-320 is
    infinitely many steps, not an ``int(inf)``)."""
    steps = float(max_time) / float(dt) * max(int(runs), 1)
    what = f"{runs} control loop(s) of {max_time:g} s at a {dt:g} s period"
    remedy = f"raise {key}"
    need_memory(steps * STEP_BYTES, key=key, what=what, file=file, remedy=remedy)
    need_time(steps, STEP_S, key=key, what=what, file=file, remedy=remedy)


@dataclass
class Obstacle:
    """A fixed obstacle in the trajectory plane.

    kind : "circle" (radius) or "box" (half-extents (2,)); centre : (2,) metres;
    stiffness : N/m at its surface; colour : tactile colour c_i (counts/m) from
    its augmented cloud, or None if unknown.
    """

    name: str
    kind: str
    centre: tuple
    size: object
    stiffness: float
    colour: float | None = None

    def penetration(self, x, r_link):
        """(depth m, outward unit normal (2,), local radius of curvature m) of a disc of radius r_link at x (2,).

        The radius is the circle's, ``inf`` on a box face, :data:`CORNER_RADIUS` at a box corner.
        """
        c = np.asarray(self.centre, float)
        if self.kind == "circle":
            d = x - c
            dist = float(np.hypot(*d))
            n = d / dist if dist > EPS else np.array([0.0, 1.0])
            return float(self.size) + r_link - dist, n, float(self.size)
        if self.kind == "box":
            h = np.asarray(self.size, float)
            q = x - c
            closest = np.clip(q, -h, h)
            d = q - closest
            dist = float(np.hypot(*d))
            if dist > EPS:
                corner = bool(np.all(np.abs(q) > h))
                return r_link - dist, d / dist, CORNER_RADIUS if corner else np.inf
            # centre inside the box: push out through the nearest face
            gaps = h - np.abs(q)
            k = int(np.argmin(gaps))
            n = np.zeros(2)
            n[k] = 1.0 if q[k] >= 0 else -1.0
            return r_link + float(gaps[k]), n, np.inf
        raise InputError(f"unknown obstacle kind {self.kind!r}; use circle or box", key="kind")


@dataclass
class ReachResult:
    """One run. time (T,) s; position (T, 2) m of the link; reference (T, 2) m commanded;
    force (T,) N of all contacts; per_obstacle (T, O) N; frame_time (K,) s and intensity (K,)
    counts of the skin frames (20 Hz); speed_cmd (T,) m/s of the commanded motion."""

    controller: str
    time: np.ndarray
    position: np.ndarray
    reference: np.ndarray
    force: np.ndarray
    per_obstacle: np.ndarray
    frame_time: np.ndarray
    intensity: np.ndarray
    speed_cmd: np.ndarray
    reached: bool
    time_to_target: float
    layer_bottomed: bool = False
    meta: dict = field(default_factory=dict)

    def mean_contact_intensity(self) -> float:
        """Mean over the run's skin frames of the contact intensity (counts): the paper's measure."""
        return float(np.mean(self.intensity)) if len(self.intensity) else 0.0

    def mean_force(self) -> float:
        """Time-averaged total contact force over the run, N."""
        return float(np.mean(self.force)) if len(self.force) else 0.0

    def path_length(self) -> float:
        """Length (m) of the path the link's centre travelled."""
        return float(np.sum(np.hypot(*np.diff(self.position, axis=0).T))) if len(self.position) > 1 else 0.0


def influence_radii(colours, r_max: float = 0.07) -> np.ndarray:
    """Eq. 6: ``eps_i = c_i r_max / c_max`` with c_max the stiffest obstacle's colour."""
    c = np.asarray(colours, dtype=np.float64)
    if c.size == 0:
        return c
    if np.any(~np.isfinite(c)) or np.any(c < 0) or c.max() <= 0:
        raise InputError(f"obstacle colours must be finite, >= 0 and not all zero, got {c}", key="colours")
    return c * (r_max / c.max())


def eq7_direction(x, goal, obstacles, eps, colours, gamma: float, speed: float) -> np.ndarray:
    """Unit direction (2,) of the augmented motion at ``x``: the goal direction at ``speed`` plus
    each Eq. 7 deviation ``gamma c_i t_i`` (m/s) of the obstacles whose radius ``eps_i`` holds
    ``x``, normalised. ``t_i`` = (x - x_i)/|x - x_i| x e_z, its sense the one towards ``goal``."""
    to_goal = np.asarray(goal, float) - x
    dist = float(np.hypot(*to_goal))
    v = speed * to_goal / dist if dist > EPS else np.zeros(2)
    for o, e, c in zip(obstacles, eps, colours):
        r = x - np.asarray(o.centre, float)
        rn = float(np.hypot(*r))
        if 0 < rn < e:
            tangent = np.array([r[1], -r[0]]) / rn             # (r / |r|) x e_z, e_z = +z
            if tangent @ to_goal < 0:
                tangent = -tangent
            v = v + gamma * c * tangent
    n = float(np.hypot(*v))
    return v / n if n > EPS else np.zeros(2)


def react(v, frame, skin: LinkSkin, speed: float, threshold: float, full: float) -> np.ndarray:
    """The reactive controller's answer to a skin frame. For each contact the frame shows whose
    peak taxel reads more than ``threshold`` counts: remove the velocity into the touched side and
    back away from it at ``speed * (peak - threshold) / (full - threshold)`` (at most ``speed``).
    Lighter contacts are accepted. The total is capped at ``speed``."""
    hard = [(n, peak) for n, _, peak in skin.contacts(frame) if peak > threshold]
    for n, _ in hard:
        v = v - max(float(v @ n), 0.0) * n
    for n, peak in hard:
        v = v - speed * min((peak - threshold) / max(full - threshold, EPS), 1.0) * n
    s = float(np.hypot(*v))
    return v * (speed / s) if s > speed else v


def reach(start, goal, obstacles: list[Obstacle], *, controller: str = "augmented", skin: LinkSkin | None = None,
          r_max: float = 0.07, gamma: float | None = None, speed: float = 0.02, k_robot: float = 3000.0,
          k_low: float = 300.0, react_threshold: float = 10000.0, react_full: float = 40000.0, dt: float = 0.01, tolerance: float = 0.003,
          max_time: float = MAX_TIME_S, rng=None) -> ReachResult:
    """Move the link from ``start`` to ``goal`` (2,) metres among ``obstacles`` with ``controller``.

    skin : the link's skin (its radius is the link's). gamma : m/s per colour unit of Eq. 7;
    default ``speed / c_max`` (the stiffest obstacle's deviation weighs as much as the goal).
    k_robot, k_low : N/m, the robot's stiffness to its reference (augmented, reactive, straight; impedance).
    react_threshold, react_full : peak taxel counts above which the reactive controller reacts to a
    contact, and at which it backs away at nominal speed (:func:`react`). rng : seed of the skin's read noise.
    """
    if controller not in CONTROLLERS:
        raise InputError(f"unknown controller {controller!r}; valid: {', '.join(CONTROLLERS)}", key="controller")
    if not (speed > 0 and dt > 0 and k_robot > 0 and k_low > 0 and 0 <= react_threshold < react_full):
        raise InputError("speed, dt, k_robot and k_low must be > 0 and 0 <= react_threshold < react_full",
                         key="speed")
    check_steps(dt, max_time)
    skin = skin or LinkSkin()
    rng = np.random.default_rng(rng)
    a, b = np.asarray(start, float), np.asarray(goal, float)
    if controller == "augmented":
        if any(o.colour is None for o in obstacles):
            raise InputError("every obstacle needs a tactile colour to reach with the augmented cloud", key="colour")
        cols = np.array([o.colour for o in obstacles], float)
        eps = influence_radii(cols, r_max)
        g = gamma if gamma is not None else speed / cols.max()
    laws = _laws(obstacles, skin)
    k = k_low if controller == "impedance" else k_robot
    every = max(1, int(round(1.0 / (skin.rate * dt))))          # control steps per skin frame
    x, frame = a.copy(), skin.read(np.zeros(len(skin.angles)), rng)
    rec = {key: [] for key in ("x", "ref", "f", "per", "speed")}
    ft, inten = [], []
    reached, t_hit, bottomed = False, float("nan"), False
    length = float(np.hypot(*(b - a)))
    for i in range(int(max_time / dt)):                         # a controller: sequential in time
        if float(np.hypot(*(b - x))) < tolerance:
            reached, t_hit = True, i * dt
            break
        if controller in ("impedance", "straight"):             # the straight reference, whatever happens
            ref = a + min(speed * (i + 1) * dt, length) * (b - a) / max(length, EPS)
            v = (ref - (rec["ref"][-1] if rec["ref"] else a)) / dt
        else:
            d = float(np.hypot(*(b - x)))
            v = speed * (b - x) / d if d > EPS else np.zeros(2)
            if controller == "augmented":
                v = speed * eq7_direction(x, b, obstacles, eps, cols, g, speed)
            v = react(v, frame, skin, speed, react_threshold, react_full)
            v = v * min(1.0, d / (speed * dt))                   # no overshoot of B within a step
            ref = (rec["ref"][-1] if rec["ref"] else a) + v * dt  # the commanded velocity, integrated
        x, forces, contacts, bad = _equilibrium(ref, x, obstacles, laws, skin.radius, k)
        bottomed |= bad
        if i % every == every - 1:                               # the skin's 20 Hz frames
            frame = skin.read(skin.counts(contacts), rng)
            ft.append((i + 1) * dt)
            inten.append(skin.intensity(frame))
        for key, val in (("x", x.copy()), ("ref", ref.copy()), ("f", float(forces.sum())), ("per", forces),
                         ("speed", float(np.hypot(*v)))):
            rec[key].append(val)
    n = len(rec["x"])
    return ReachResult(controller=controller, time=np.arange(n) * dt, position=np.array(rec["x"]).reshape(-1, 2),
                       reference=np.array(rec["ref"]).reshape(-1, 2), force=np.array(rec["f"]),
                       per_obstacle=np.array(rec["per"]).reshape(n, len(obstacles)), frame_time=np.array(ft),
                       intensity=np.array(inten), speed_cmd=np.array(rec["speed"]), reached=reached,
                       time_to_target=t_hit, layer_bottomed=bottomed,
                       meta={"k_robot": k, "gamma": g if controller == "augmented" else None})


def _laws(obstacles, skin):
    """Per obstacle, its contact laws by local radius (a box has a face law and a corner law)."""
    out = []
    for o in obstacles:
        radii = (float(o.size),) if o.kind == "circle" else (np.inf, CORNER_RADIUS)
        out.append({r: skin.law(o.stiffness, r) for r in radii})
    return out


def _equilibrium(ref, x0, obstacles, laws, r_link, k_robot, iterations: int = 20):
    """Quasi-static position of the link: minimise the robot's spring energy plus the contacts'.

    E(x) = k_robot/2 |x - ref|^2 + sum_j W_j(pen_j(x)), with dW/dpen = F_j the contact law, by
    Newton steps in the plane. Returns (x (2,), forces (O,) N, contacts for the skin
    [(angle on the link rad, layer compression m, r_eff m)], layer bottomed out (bool)).
    """
    x = np.array(ref, float)
    if all(o.penetration(x, r_link)[0] <= 0 for o in obstacles):
        return x, np.zeros(len(obstacles)), [], False           # free: the link is where it is commanded
    x = np.array(x0, float)
    for _ in range(iterations):
        grad = k_robot * (x - ref)
        hess = k_robot * np.eye(2)
        for o, law in zip(obstacles, laws):
            pen, n, r = o.penetration(x, r_link)
            if pen > 0:
                cl = law[r]
                f = cl.force(pen)
                if not np.isfinite(f):                           # past the table: the stiffest slope
                    f = cl.f[-1] + (pen - cl.pen[-1]) * (cl.f[-1] - cl.f[-2]) / (cl.pen[-1] - cl.pen[-2])
                grad -= f * n
                hess += cl.stiffness(min(pen, cl.pen[-1])) * np.outer(n, n)
        step = np.linalg.solve(hess, grad)
        x = x - step
        if float(np.hypot(*step)) < LENGTH_TOL:
            break
    forces, contacts, bottomed = np.zeros(len(obstacles)), [], False
    for j, (o, law) in enumerate(zip(obstacles, laws)):
        pen, n, r = o.penetration(x, r_link)
        if pen > 0:
            cl = law[r]
            f = cl.force(pen)
            if not np.isfinite(f):
                bottomed, f = True, float(cl.f[-1])
            forces[j] = f
            contacts.append((float(np.arctan2(-n[1], -n[0])), cl.compression(pen), cl.r_eff))
    return x, forces, contacts, bottomed
