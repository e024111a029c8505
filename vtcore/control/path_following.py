"""Compliance-aware path following (seed 000, Sect. 4.2, Eq. 5, Fig. 9).

The end-effector slides along a path on an object while pushing with a force
set-point that follows the local tactile colour of the augmented point cloud,
queried on the fly at the contact point ``x_r``:

    p̄* = c(x_r) * p̄*_max / c_max                                      (Eq. 5)

so the robot pushes hardest where the object is stiffest. The mean taxel
response p̄ is tracked by an integral force controller acting on the
commanded indentation, through the robot's own (second-order) position
dynamics. The plant is either the contact simulator's response along the path
(:mod:`vtcore.control.response_table`: the module pressed on the object's real
surface, so a groove or rib the module cannot bridge lifts it off) or a linear
series model ``p̄ = c_true(x) * max(indentation - gap, 0)`` with ``gap`` how far the
real surface lies below the planned straight path.

The measured p̄ carries the skin's read noise: per taxel, clipped at 0, where the
plant gives each taxel's reading (the real read-out: an unloaded taxel reads the
positive half of its noise), else on the mean. The paper's comparison is the mean
tracking error; here also the contact-loss intervals (where the noise-free
response is zero), the error outside them, and the overshoots of the
noise-free response (:meth:`PathFollowingResult.overshoots`).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np

from ..errors import InputError
from ..inputs import need_memory, need_time
from ..tolerances import EPS
from .response_table import ResponseTable, contact_response_table  # noqa: F401  (the plant's table)

#: Optimistic CPU seconds of one control step (measured 1.6 us with the series plant; the contact table's
#: per-taxel plant costs more): the time guard refuses only loops that surely exceed the budget.
STEP_S = 1e-6
#: float64 values one step keeps besides its per-taxel noise (time, arc length, contact point (3),
#: colour, set-point, response, true and expected response, indentation, ...), rounded up.
STEP_VALUES = 16


def check_steps(length: float, speed: float, dt: float, taxels: int = 1, *, key: str = "dt", file=None,
                remedy: str | None = None) -> None:
    """Refuse, before any array is sized, a path of ``length / speed / dt`` control steps (x ``taxels``
    noise columns) that needs more time or memory than the budgets; a dt or speed of 1e-320 is
    infinitely many steps, not an ``int(inf)``."""
    steps = float(length) / float(speed) / float(dt)
    what = f"a {length:g} m path at {speed:g} m/s with a {dt:g} s control period"
    remedy = remedy or f"raise {key} or the speed, or shorten the path"
    need_memory(8.0 * (max(int(taxels), 1) + STEP_VALUES) * steps, key=key, what=what, file=file, remedy=remedy)
    need_time(steps, STEP_S, key=key, what=what, file=file, remedy=remedy)


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
    (a second-order lag; what makes steps overshoot). noise : counts, std of one
    taxel's reading (per-taxel plants) or of the measured p̄ (mean-only plants; pass
    ``sigma / sqrt(taxels)`` there). dt : s, control period. setpoint_period : s, how
    often the augmented cloud is queried (on the fly, like a 100 Hz outer loop).
    The gains are our choices: the paper gives none ("the same control gains were
    used in the two experiments").
    """

    ki: float = 4e-6
    omega: float = 25.0
    zeta: float = 0.6
    noise: float = 8.0
    dt: float = 2e-3
    setpoint_period: float = 1e-2

    def __post_init__(self):
        why = position_loop_problem(self.omega, self.zeta, self.dt)
        if why:
            raise InputError(why, key="omega")


def position_loop_problem(omega: float, zeta: float, dt: float) -> str | None:
    """Why the robot's position loop, integrated every ``dt`` s (semi-implicit Euler of the second-order
    lag, :func:`follow_path`), is unstable at ``omega`` rad/s and damping ``zeta``, or None. Unstable:
    the update's spectral radius exceeds 1, so the indentation grows without bound to infinity, then NaN
    (omega x dt near 2 and beyond, or a large zeta x omega x dt); omega 1e308 overflowed outright."""
    w, z, dt = float(omega), float(zeta), float(dt)
    grow = float("inf")
    if np.isfinite(w * dt) and w * dt <= 2.0 and np.isfinite(z * w * dt):
        d = 2.0 * z * w * dt
        a = np.array([[1.0 - (w * dt) ** 2, dt * (1.0 - d)], [-w * w * dt, 1.0 - d]])
        grow = float(np.max(np.abs(np.linalg.eigvals(a))))
    if grow < 1.0:
        return None
    how = f"it grows {grow:.3g} times a step" if np.isfinite(grow) else f"omega x dt = {w * dt:.3g}, zeta {z:g}"
    return (f"the robot's position loop (omega {w:g} rad/s, zeta {z:g}) is unstable at a {dt:g} s control period "
            f"({how}); lower omega, zeta or dt")


@dataclass
class PathFollowingResult:
    """Time series of one run; all (T,) arrays.

    time (s), s (m, arc length), setpoint (counts, p̄*), response (counts, p̄
    measured, with the read noise), response_true (counts, the noise-free p̄),
    colour (counts/m, c(x_r) queried), indentation (m beyond first contact),
    contact (bool: the module touches the object, noise-free response > 0),
    response_expected (counts, the measured p̄ without its noise: with per-taxel noise
    clipped at 0 an unloaded taxel reads ``sigma / sqrt(2 pi)`` on average, so this is what
    the controller tracks; equal to ``response_true`` for mean-only plants).
    """

    time: np.ndarray
    s: np.ndarray
    setpoint: np.ndarray
    response: np.ndarray
    colour: np.ndarray
    indentation: np.ndarray
    contact: np.ndarray
    response_true: np.ndarray | None = None
    response_expected: np.ndarray | None = None

    def tracking_error(self, in_contact_only: bool = False) -> float:
        """Mean |p̄ - p̄*| over the path, counts (the paper's force-tracking error); with
        ``in_contact_only`` over the samples outside the contact-loss intervals."""
        e = np.abs(self.response - self.setpoint)
        if in_contact_only:
            e = e[self.contact]
        return float(np.mean(e)) if len(e) else float("nan")

    def peak_error(self) -> float:
        """Largest |p̄ - p̄*|, counts (after a set-point step it measures the controller's lag, not an overshoot)."""
        return float(np.max(np.abs(self.response - self.setpoint), initial=0.0))

    def setpoint_max_jump(self) -> float:
        """Largest change of p̄* between two consecutive queries, counts (steps vs smooth)."""
        d = np.abs(np.diff(self.setpoint))
        return float(d.max(initial=0.0))

    def contact_loss_intervals(self) -> list[tuple[float, float]]:
        """``[(s_start, s_end)]`` metres of path where the module had lost contact."""
        lost = ~np.asarray(self.contact, bool)
        if not lost.any():
            return []
        edges = np.flatnonzero(np.diff(np.concatenate([[0], lost.astype(np.int8), [0]])))
        return [(float(self.s[a]), float(self.s[min(b, len(self.s) - 1)])) for a, b in zip(edges[::2], edges[1::2])]

    def contact_lost_length(self) -> float:
        """Metres of path without contact (sum of :meth:`contact_loss_intervals`)."""
        return float(sum(b - a for a, b in self.contact_loss_intervals()))

    def overshoots(self, threshold: float) -> list[tuple[float, float]]:
        """``[(s m, size counts)]``: each time the response crosses the set-point after having been
        more than ``threshold`` counts on the other side, how far it then goes past it (until it
        crosses back). A set-point step or a lost contact that the controller closes without
        crossing is lag, not overshoot, and does not count; nor does a crossing the set-point makes
        by jumping over the response. Uses the noise-free expected reading (``response_expected``,
        else ``response_true``): the measured response's noise would cross at every step."""
        p = next((a for a in (self.response_expected, self.response_true) if a is not None), self.response)
        sp = np.asarray(self.setpoint, float)
        e = np.asarray(p, float) - sp
        sign = np.sign(e)
        nz = np.flatnonzero(sign)                        # samples on one side or the other (0: exactly on it)
        if len(nz) == 0:
            return []
        # runs of one sign among the nonzero samples: an excursion each
        breaks = np.flatnonzero(np.diff(sign[nz]) != 0) + 1
        runs = np.split(nz, breaks)
        out = []
        for before, after in zip(runs[:-1], runs[1:]):
            a, b = after[0], before[-1]
            moved_over = np.sign(p[a] - sp[b]) != np.sign(e[b])  # the response crossed the old set-point
            if moved_over and np.abs(e[before]).max() > threshold:
                k = after[int(np.argmax(np.abs(e[after])))]
                out.append((float(self.s[k]), float(np.abs(e[k]))))
        return out


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
    from the contact simulator (:func:`contact_response_table`; with its per-taxel
    readings the noise is added per taxel and clipped at 0). The robot starts in
    contact at the start set-point.
    """
    a, b = np.asarray(start, float), np.asarray(end, float)
    length = float(np.linalg.norm(b - a))
    if length <= 0 or not np.isfinite(length):
        raise InputError("the path has zero length: start and end coincide", key="path")
    if not speed > 0:
        raise InputError(f"must be > 0 m/s, got {speed}", key="speed")
    if (plant_c is None) == (response is None):
        raise InputError("give the plant as plant_c (series model) or response (contact table), not both",
                         key="plant")
    ctl = controller or ForceController()
    rng = np.random.default_rng(rng)
    direction = (b - a) / length
    per_taxel = response is not None and response.taxels is not None
    check_steps(length, speed, ctl.dt, response.taxels.shape[2] if per_taxel else 1)
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
    plant, u = _plant(response, plant_c, gap, x, s, setpoint[0])
    noise = rng.normal(0.0, ctl.noise, (steps, response.taxels.shape[2]) if per_taxel else steps)

    # sequential in time (a controller), vectorised over nothing else: a plain loop is the clear way
    v = 0.0
    cmd = u
    resp, true, expect, ind = np.empty(steps), np.empty(steps), np.empty(steps), np.empty(steps)
    w2, damp = ctl.omega ** 2, 2.0 * ctl.zeta * ctl.omega
    for i in range(steps):
        p, pen, taxels = plant(i, u)
        if per_taxel:
            meas, expect[i] = float(np.mean(np.clip(taxels + noise[i], 0.0, None))), _clipped_mean(taxels, ctl.noise)
        else:
            meas, expect[i] = p + noise[i], p
        resp[i], true[i], ind[i] = meas, p, pen
        cmd += ctl.ki * (setpoint[i] - meas) * ctl.dt
        acc = w2 * (cmd - u) - damp * v           # semi-implicit Euler of the position loop
        v += acc * ctl.dt
        u += v * ctl.dt
    return PathFollowingResult(time=t, s=s, setpoint=setpoint, response=resp, colour=colour, indentation=ind,
                               contact=true > 0, response_true=true, response_expected=expect)


def _clipped_mean(mu, sigma: float) -> float:
    """Mean over taxels of E[max(mu + sigma Z, 0)], Z standard normal: the expected clipped reading."""
    if sigma <= 0:
        return float(np.mean(np.clip(mu, 0.0, None)))
    from scipy.special import ndtr

    z = np.asarray(mu, float) / sigma
    return float(np.mean(mu * ndtr(z) + sigma * np.exp(-0.5 * z * z) / np.sqrt(2 * np.pi)))


def _plant(response, plant_c, gap, x, s, p0):
    """``(plant(i, u) -> (p̄ counts, indentation m, taxels (N,) or None), u0 m)``: the object under the
    end-effector at step ``i`` and commanded displacement ``u``, and the equilibrium at ``p0``."""
    if response is None:
        c_true = np.asarray(plant_c(x), dtype=np.float64).reshape(-1)
        g = np.zeros(len(s)) if gap is None else np.asarray(gap(x), dtype=np.float64).reshape(-1)

        def plant(i, u):
            pen = u - g[i]
            return (c_true[i] * pen if pen > 0 else 0.0), pen, None
        return plant, p0 / max(c_true[0], EPS) + g[0]

    if response.taxels is not None:
        def plant(i, u):
            tx = response.taxel_response(s[i], u)
            return float(tx.mean()), u - response.response_gap(s[i]), tx
    else:
        def plant(i, u):
            return response.response(s[i], u), u - response.response_gap(s[i]), None
    return plant, response.displacement_for(s[0], p0)
