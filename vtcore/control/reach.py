"""Reaching in clutter with the augmented point cloud (seed 000, Sect. 4.3, Eqs. 6-7, Fig. 10).

A skin-covered link (a disc of radius ``r_link`` in the trajectory plane)
moves from A to B between obstacles it cannot all avoid. With the augmented
cloud, each obstacle ``i`` of tactile colour ``c_i`` gets an influence radius

    eps_i = c_i r_max / c_max                                             (Eq. 6)

and while the link is closer than ``eps_i`` to its centroid the motion is
deviated tangentially, in the plane, proportionally to the colour:

    x_dev = gamma c_i (x_ee - x_i) / ||x_ee - x_i|| x e_z                 (Eq. 7)

so stiff obstacles are skirted widely and soft ones barely (the link pushes
through them). The sense of ``e_z`` (which way round) is the one whose tangent
makes progress towards B. The "straight" baseline follows the minimum-distance
line. Both run on the same compliant robot: the link's actual position is the
commanded one displaced by the contact forces against a Cartesian impedance
``k_robot``; contact forces are penetration times the series stiffness of
the obstacle and the robot, and the commanded speed drops while in contact
(``v = v_nom / (1 + F / f_slow)``), a safety scaling common to both runs.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import InputError
from ..tolerances import EPS, LENGTH_TOL


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
        """(depth m, outward unit normal (2,)) of a disc of radius r_link at x (2,)."""
        c = np.asarray(self.centre, float)
        if self.kind == "circle":
            d = x - c
            dist = float(np.hypot(*d))
            n = d / dist if dist > EPS else np.array([0.0, 1.0])
            return float(self.size) + r_link - dist, n
        if self.kind == "box":
            h = np.asarray(self.size, float)
            q = x - c
            closest = np.clip(q, -h, h)
            d = q - closest
            dist = float(np.hypot(*d))
            if dist > EPS:
                return r_link - dist, d / dist
            # centre inside the box: push out through the nearest face
            gaps = h - np.abs(q)
            k = int(np.argmin(gaps))
            n = np.zeros(2)
            n[k] = 1.0 if q[k] >= 0 else -1.0
            return r_link + float(gaps[k]), n
        raise InputError(f"unknown obstacle kind {self.kind!r}; use circle or box", key="kind")


@dataclass
class ReachResult:
    """time (T,) s; position (T, 2) m of the link; force (T,) N of all contacts; per_obstacle (T, O) N."""

    time: np.ndarray
    position: np.ndarray
    force: np.ndarray
    per_obstacle: np.ndarray
    reached: bool
    time_to_target: float

    def mean_contact_intensity(self) -> float:
        """Time-averaged total contact force over the run, N."""
        return float(np.mean(self.force))


def influence_radii(colours, r_max: float = 0.07) -> np.ndarray:
    """Eq. 6: ``eps_i = c_i r_max / c_max`` with c_max the stiffest obstacle's colour."""
    c = np.asarray(colours, dtype=np.float64)
    if c.size == 0:
        return c
    if np.any(~np.isfinite(c)) or np.any(c < 0) or c.max() <= 0:
        raise InputError(f"obstacle colours must be finite, >= 0 and not all zero, got {c}", key="colours")
    return c * (r_max / c.max())


def reach(start, goal, obstacles: list[Obstacle], *, use_colours: bool, r_max: float = 0.07,
          gamma: float | None = None, speed: float = 0.02, r_link: float = 0.025, k_robot: float = 800.0,
          f_slow: float = 2.0, dt: float = 0.01, tolerance: float = 0.003, max_time: float = 120.0) -> ReachResult:
    """Move the link from ``start`` to ``goal`` (2,) metres among ``obstacles``.

    use_colours : apply Eqs. 6-7 with the obstacles' ``colour``; False is the
    minimum-distance (straight) baseline. gamma : m/s per colour unit; default
    ``2 speed / c_max`` (the stiffest obstacle deviates at twice the nominal speed).
    """
    a, b = np.asarray(start, float), np.asarray(goal, float)
    if use_colours:
        if any(o.colour is None for o in obstacles):
            raise InputError("every obstacle needs a tactile colour to reach with the augmented cloud", key="colour")
        cols = np.array([o.colour for o in obstacles], float)
        eps = influence_radii(cols, r_max)
        g = gamma if gamma is not None else 2.0 * speed / cols.max()
    steps = int(max_time / dt)
    ref = a.copy()                                # the commanded (reference) position
    x = a.copy()                                  # the link's actual position
    pos, frc, per = [], [], []
    reached, t_hit = False, float("nan")
    f_total = 0.0
    for i in range(steps):                       # a controller: sequential in time
        if float(np.hypot(*(b - x))) < tolerance:
            reached, t_hit = True, i * dt
            break
        to_goal = b - ref
        dist = float(np.hypot(*to_goal))
        vel = np.zeros(2) if dist < EPS else min(speed / (1.0 + f_total / f_slow), dist / dt) * to_goal / dist
        if use_colours:
            for o, e, c in zip(obstacles, eps, cols):
                r = x - np.asarray(o.centre, float)
                rn = float(np.hypot(*r))
                if 0 < rn < e:
                    tangent = np.array([r[1], -r[0]]) / rn        # (r / |r|) x e_z, e_z = +z
                    if tangent @ (b - x) < 0:
                        tangent = -tangent                          # the sense that progresses towards B
                    vel = vel + g * c * tangent
        ref = ref + vel * dt
        x, forces = _equilibrium(ref, x, obstacles, r_link, k_robot)
        f_total = float(forces.sum())
        pos.append(x.copy())
        frc.append(f_total)
        per.append(forces)
    t = np.arange(len(pos)) * dt
    return ReachResult(time=t, position=np.array(pos).reshape(-1, 2), force=np.array(frc),
                       per_obstacle=np.array(per).reshape(len(pos), len(obstacles)), reached=reached,
                       time_to_target=t_hit)


def _equilibrium(ref, x0, obstacles, r_link, k_robot, iterations: int = 12):
    """Quasi-static position of the link: minimise the robot's impedance energy plus the obstacles'.

    E(x) = k_robot/2 |x - ref|^2 + sum_j k_j/2 max(pen_j(x), 0)^2, by Newton steps in the
    plane (piecewise quadratic, so a few steps converge). Returns (x (2,), forces (O,) N).
    """
    x = np.array(x0, float)
    for _ in range(iterations):
        grad = k_robot * (x - ref)
        hess = k_robot * np.eye(2)
        for o in obstacles:
            pen, n = o.penetration(x, r_link)
            if pen > 0:
                grad -= o.stiffness * pen * n
                hess += o.stiffness * np.outer(n, n)
        step = np.linalg.solve(hess, grad)
        x = x - step
        if float(np.hypot(*step)) < LENGTH_TOL:
            break
    forces = np.array([o.stiffness * max(o.penetration(x, r_link)[0], 0.0) for o in obstacles])
    return x, forces
