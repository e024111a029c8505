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
from ..tolerances import EPS


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


@dataclass
class ResponseTable:
    """The contact simulator's mean response along a path, tabulated for the control loop.

    s : (S,) metres, arc length of the stations. u : (S, U) metres, end-effector
    displacement beyond the planned path (increasing along each row; the first
    entry, at zero response, is the gap to the real surface). p : (S, U) counts,
    mean response p̄ at that displacement. Between stations and displacements the
    response is interpolated linearly; beyond the last displacement it is
    extrapolated with the last slope (the stiffest the table saw).
    """

    s: np.ndarray
    u: np.ndarray
    p: np.ndarray

    def response(self, s_value: float, u: float) -> float:
        j = int(np.clip(np.searchsorted(self.s, s_value) - 1, 0, len(self.s) - 2)) if len(self.s) > 1 else 0
        if len(self.s) == 1:
            return self._curve(0, u)
        w = float(np.clip((s_value - self.s[j]) / (self.s[j + 1] - self.s[j]), 0.0, 1.0))
        return (1.0 - w) * self._curve(j, u) + w * self._curve(j + 1, u)

    def response_gap(self, s_value: float) -> float:
        """Displacement (m) at which the module first touches the surface at ``s_value``."""
        return float(np.interp(s_value, self.s, self.u[:, 0]))

    def displacement_for(self, s_value: float, p_target: float) -> float:
        """Displacement (m) giving ``p_target`` counts at ``s_value`` (inverse of the nearest curve)."""
        j = int(np.argmin(np.abs(self.s - s_value)))
        uu, pp = self.u[j], self.p[j]
        if p_target <= pp[-1]:
            return float(np.interp(p_target, pp, uu))
        slope = (pp[-1] - pp[-2]) / max(uu[-1] - uu[-2], EPS)
        return float(uu[-1] + (p_target - pp[-1]) / max(slope, EPS))

    def _curve(self, j, u):
        uu, pp = self.u[j], self.p[j]
        if u <= uu[-1]:
            return float(np.interp(u, uu, pp, left=0.0))
        slope = (pp[-1] - pp[-2]) / max(uu[-1] - uu[-2], EPS)
        return float(pp[-1] + slope * (u - uu[-1]))


def contact_response_table(mesh, start, end, normal, layer, *, stiffness=None, counts=None, stations: int = 27,
                           forces=(0.02, 0.05, 0.1, 0.2, 0.4, 0.7, 1.0, 1.5, 2.5), layout=None,
                           **press_kw) -> ResponseTable:
    """Tabulate p̄(u) along a straight path with the contact simulator (one CySkin module).

    mesh : the object (metres). start, end : (3,) metres, the planned path.
    normal : (3,) or callable (P, 3) -> (P, 3), outward surface normal along it (the
    end-effector stays aligned with it). layer : vtcore.contact.SoftLayer.
    stiffness : callable ``(result) -> k`` N/m of the object at a press's contact
    (object compliance in series), or None for a rigid object. counts : callable
    pressure (N,) Pa -> counts (N,) (noise-free sensor transfer; default 0.1 counts/Pa).
    Each station is pressed at ``forces`` (N); other keywords go to ``press``.
    """
    from ..augment.probing import cyskin_module_layout, probe_pose
    from ..contact import press

    layout = layout or cyskin_module_layout()
    a, b = np.asarray(start, float), np.asarray(end, float)
    length = float(np.linalg.norm(b - a))
    s = np.linspace(0.0, length, max(int(stations), 1))
    pts = a + s[:, None] * (b - a) / max(length, EPS)
    nrm = normal(pts) if callable(normal) else np.broadcast_to(np.asarray(normal, float), pts.shape)
    counts = counts or (lambda pr: 0.1 * pr)
    pre = 2e-3                                   # start 2 mm off the planned point, subtract it after
    us, ps = [], []
    for i in range(len(s)):                      # one short force sweep per station
        pose = probe_pose(pts[i], nrm[i], layer.thickness, gap=pre)
        u_row, p_row, prev, gap0 = [], [], None, None
        for f in forces:
            r = press(layout, mesh, pose, layer, force=float(f), warm_start=prev, **press_kw)
            prev = r
            if gap0 is None:
                # zero response where the module first touches the real surface: travel minus indentation
                gap0 = r.travel - pre - r.indentation
            defl = f / float(stiffness(r)) if stiffness is not None else 0.0
            u_row.append(r.travel - pre + defl)
            p_row.append(float(np.mean(counts(r.pressure))))
        us.append([gap0] + u_row)
        ps.append([0.0] + p_row)
    u, p = np.asarray(us), np.asarray(ps)
    u = np.maximum.accumulate(u, axis=1)         # guard against solver round-off: keep each row monotone
    return ResponseTable(s=s, u=u, p=p)


def follow_path(start, end, query: Callable[[np.ndarray], np.ndarray],
                plant_c: Callable[[np.ndarray], np.ndarray] | None = None, *,
                gap: Callable[[np.ndarray], np.ndarray] | None = None, response: ResponseTable | None = None,
                speed: float = 1.5e-3, p_max: float = 2000.0, c_max: float, controller: ForceController | None = None,
                rng=None) -> PathFollowingResult:
    """Slide from ``start`` to ``end`` (straight, metres) at ``speed`` m/s with the Eq. 5 set-point.

    query : (P, 3) -> (P,) tactile colour of the augmented cloud (e.g.
    ``SmoothPropagation(...).fit(...).predict``), called on the fly every
    ``controller.setpoint_period``. The plant is either ``plant_c`` : (P, 3) -> (P,),
    the true colour (counts/m) of the object under the end-effector (linear series
    model, ``p̄ = c * (u - gap)``), with ``gap`` : (P, 3) -> (P,) metres between
    the planned path and the real surface; or ``response``, a :class:`ResponseTable`
    from the contact simulator (:func:`contact_response_table`). The robot starts in
    contact at the start set-point.
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
    if (plant_c is None) == (response is None):
        raise InputError("give the plant as plant_c (series model) or response (contact table), not both",
                         key="plant")
    if response is None:
        c_true = np.asarray(plant_c(x), dtype=np.float64).reshape(-1)
        g = np.zeros(steps) if gap is None else np.asarray(gap(x), dtype=np.float64).reshape(-1)
    noise = rng.normal(0.0, ctl.noise, steps)

    # sequential in time (a controller), vectorised over nothing else: a plain loop is the clear way
    if response is None:
        def plant(i, u):
            pen = u - g[i]
            return c_true[i] * pen if pen > 0 else 0.0, pen
        u = setpoint[0] / max(c_true[0], EPS) + g[0]   # start at equilibrium
    else:
        def plant(i, u):
            return response.response(s[i], u), u - response.response_gap(s[i])
        u = response.displacement_for(s[0], setpoint[0])
    v = 0.0
    cmd = u
    resp = np.empty(steps)
    ind = np.empty(steps)
    w2, damp = ctl.omega ** 2, 2.0 * ctl.zeta * ctl.omega
    for i in range(steps):
        p, pen = plant(i, u)
        meas = p + noise[i]
        resp[i], ind[i] = meas, pen
        cmd += ctl.ki * (setpoint[i] - meas) * ctl.dt
        acc = w2 * (cmd - u) - damp * v           # semi-implicit Euler of the position loop
        v += acc * ctl.dt
        u += v * ctl.dt
    return PathFollowingResult(time=t, s=s, setpoint=setpoint, response=resp, colour=colour, indentation=ind,
                               contact=ind > 0)
