"""Compliance-aware path following (seed 000, Sect. 4.2, Eq. 5, Fig. 9).

The end-effector slides along a path on an object while pushing with a force
set-point that follows the local tactile colour of the augmented point cloud,
queried on the fly at the contact point ``x_r``:

    p̄* = c(x_r) * p̄*_max / c_max                                      (Eq. 5)

so the robot pushes hardest where the object is stiffest. The mean taxel
response p̄ is tracked by an integral force controller acting on the
commanded indentation, through the robot's own (second-order) position
dynamics; the contact is the object's local stiffness in series with the
soft layer, i.e. ``p̄ = c_true(x) * max(indentation - gap, 0)`` where
``c_true`` is the same quantity the probes measure (Eq. 1) and ``gap`` is how
far the real surface lies below the planned straight path (grooves, curvature:
the robot can lose contact, as in the paper at 0.025 m).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np

from ..errors import InputError


def force_setpoint(c, p_max: float, c_max: float) -> np.ndarray:
    """Eq. 5: ``p̄* = c * p̄*_max / c_max`` (counts), for tactile colours ``c`` (counts/m).

    c : float or (T,) array; c_max : the colour of the stiffest points (> 0).
    Colours above ``c_max`` give set-points above ``p_max``, clipped to ``p_max``
    so that the robot never pushes harder than the limit; negative colours give 0.
    """
    if not (np.isfinite(c_max) and c_max > 0):
        raise InputError(f"c_max must be a positive colour, got {c_max}", key="c_max")
    if not (np.isfinite(p_max) and p_max > 0):
        raise InputError(f"p_max must be a positive number of counts, got {p_max}", key="p_max")
    return np.clip(np.asarray(c, dtype=np.float64) * (p_max / c_max), 0.0, p_max)


@dataclass
class ForceController:
    """Integral force control of the mean response through the robot's position loop.

    ki : m / (count s), integral gain from force error to commanded indentation rate.
    omega : rad/s and zeta : the robot's closed position loop along the normal
    (a second-order lag; what makes steps overshoot). noise : counts, std of the
    measured p̄. dt : s, control period. setpoint_period : s, how often the
    augmented cloud is queried (on the fly, like a 100 Hz outer loop).
    """

    ki: float = 4e-6
    omega: float = 25.0
    zeta: float = 0.6
    noise: float = 8.0
    dt: float = 2e-3
    setpoint_period: float = 1e-2


@dataclass
class PathFollowingResult:
    """Time series of one run; all (T,) arrays.

    time (s), s (m, arc length), setpoint (counts, p̄*), response (counts, p̄
    measured), colour (counts/m, c(x_r) queried), indentation (m), contact (bool).
    """

    time: np.ndarray
    s: np.ndarray
    setpoint: np.ndarray
    response: np.ndarray
    colour: np.ndarray
    indentation: np.ndarray
    contact: np.ndarray

    def tracking_error(self) -> float:
        """Mean |p̄ - p̄*| over the path, counts (the paper's force-tracking error)."""
        return float(np.mean(np.abs(self.response - self.setpoint)))

    def peak_error(self) -> float:
        """Largest |p̄ - p̄*|, counts (after a set-point step it measures the controller's lag)."""
        return float(np.max(np.abs(self.response - self.setpoint), initial=0.0))

    def setpoint_max_jump(self) -> float:
        """Largest change of p̄* between two consecutive queries, counts (steps vs smooth)."""
        d = np.abs(np.diff(self.setpoint))
        return float(d.max(initial=0.0))


def follow_path(start, end, query: Callable[[np.ndarray], np.ndarray],
                plant_c: Callable[[np.ndarray], np.ndarray], *, gap: Callable[[np.ndarray], np.ndarray] | None = None,
                speed: float = 1.5e-3, p_max: float = 2000.0, c_max: float, controller: ForceController | None = None,
                rng=None) -> PathFollowingResult:
    """Slide from ``start`` to ``end`` (straight, metres) at ``speed`` m/s with the Eq. 5 set-point.

    query : (P, 3) -> (P,) tactile colour of the augmented cloud (e.g.
    ``SmoothPropagation(...).fit(...).predict``), called on the fly every
    ``controller.setpoint_period``. plant_c : (P, 3) -> (P,) the true colour
    (counts/m) of the object under the end-effector. gap : (P, 3) -> (P,)
    metres between the planned path and the real surface (>= 0 where the surface
    falls away). The robot starts in contact at the start set-point.
    """
    a, b = np.asarray(start, float), np.asarray(end, float)
    length = float(np.linalg.norm(b - a))
    if length <= 0 or not np.isfinite(length):
        raise InputError("the path has zero length: start and end coincide", key="path")
    if not speed > 0:
        raise InputError(f"must be > 0 m/s, got {speed}", key="speed")
    ctl = controller or ForceController()
    rng = np.random.default_rng(rng)
    direction = (b - a) / length
    steps = int(np.ceil(length / speed / ctl.dt)) + 1
    t = np.arange(steps) * ctl.dt
    s = np.minimum(t * speed, length)
    x = a + s[:, None] * direction
    # the on-the-fly query: one call per set-point period, at the current contact point
    every = max(1, int(round(ctl.setpoint_period / ctl.dt)))
    q_idx = np.arange(0, steps, every)
    colour_q = np.asarray(query(x[q_idx]), dtype=np.float64).reshape(-1)
    colour = colour_q[np.minimum(np.arange(steps) // every, len(q_idx) - 1)]
    setpoint = force_setpoint(colour, p_max, c_max)
    c_true = np.asarray(plant_c(x), dtype=np.float64).reshape(-1)
    g = np.zeros(steps) if gap is None else np.asarray(gap(x), dtype=np.float64).reshape(-1)
    noise = rng.normal(0.0, ctl.noise, steps)

    # sequential in time (a controller), vectorised over nothing else: a plain loop is the clear way
    u = setpoint[0] / max(c_true[0], 1e-12) + g[0]   # start at equilibrium
    v = 0.0
    cmd = u
    resp = np.empty(steps)
    ind = np.empty(steps)
    w2, damp = ctl.omega ** 2, 2.0 * ctl.zeta * ctl.omega
    for i in range(steps):
        pen = u - g[i]
        p = c_true[i] * pen if pen > 0 else 0.0
        meas = p + noise[i]
        resp[i], ind[i] = meas, pen
        cmd += ctl.ki * (setpoint[i] - meas) * ctl.dt
        acc = w2 * (cmd - u) - damp * v           # semi-implicit Euler of the position loop
        v += acc * ctl.dt
        u += v * ctl.dt
    return PathFollowingResult(time=t, s=s, setpoint=setpoint, response=resp, colour=colour, indentation=ind,
                               contact=ind > 0)
