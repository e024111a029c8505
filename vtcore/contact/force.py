"""Force control: the press that makes the mean sensor response reach a target.

Seed 000 (Sect. 2.1) controls the *mean* of the raw taxel values,
``p_bar = (1/M) sum_j p_j``, to a target ``p_bar* = 4000`` counts, then computes
the compliance attribute ``c = p_bar / ||v_ss - v||`` (Eq. 1) from the
end-effector's displacement. :func:`probe` does this in simulation: it brackets
the force monotonically (doubling), then refines with the Illinois
regula falsi, which keeps the bracket and converges in a bounded number of
steps; it raises :class:`UnreachableTargetError` when the target cannot be met
(no contact, the layer bottoms out, the sensor saturates below the target).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import InputError, UnreachableTargetError
from .finish import PressResult
from .press import press
from .roots import illinois
from .sensor import gain as _gain

DEFAULT_COUNTS_PER_PA = 0.1


@dataclass
class ProbeResult:
    """Outcome of :func:`probe`.

    force : N. mean_response : counts (p_bar at the solution). counts : (N,) per taxel.
    result : the PressResult. displacement : m, end-effector displacement from
    first contact (layer indentation + object deflection). compliance : p_bar /
    displacement (seed 000 Eq. 1, counts/m). steps : presses evaluated.
    """

    force: float
    mean_response: float
    counts: np.ndarray
    result: PressResult
    displacement: float
    compliance: float
    steps: int


def solve_monotone(fn, target, x0=1.0, x_max=1e3, rtol=1e-3, max_steps=60):
    """Find x > 0 with fn(x) = target for a non-decreasing fn with fn(0) <= target.

    fn may raise UnreachableTargetError beyond some x (treated as "too far").
    Returns (x, fn(x), steps). Raises UnreachableTargetError when the target is
    not bracketed below ``x_max`` or fn stops growing.
    """
    steps = 0
    lo, f_lo = 0.0, None
    hi, f_hi = None, None
    x = float(x0)
    last_err = None
    cap = None  # smallest x known to fail
    while hi is None:
        if x > x_max:
            break
        steps += 1
        try:
            fx = float(fn(x))
        except UnreachableTargetError as exc:
            last_err, cap = exc, x
            break
        if fx >= target:
            hi, f_hi = x, fx
        else:
            lo, f_lo = x, fx
            x *= 2.0
        if steps >= max_steps:
            break
    if hi is None and cap is not None:
        # the target lies beyond lo or in (lo, cap): bisect for the largest feasible x
        a, b = lo, cap
        for _ in range(12):
            steps += 1
            m = 0.5 * (a + b)
            try:
                fm = float(fn(m))
            except UnreachableTargetError:
                b = m
                continue
            if fm >= target:
                hi, f_hi = m, fm
                break
            a, lo, f_lo = m, m, fm
    if hi is None:
        best = f_lo if f_lo is not None else 0.0
        why = f" ({last_err})" if last_err else ""
        raise UnreachableTargetError(
            f"target {target:g} not reachable: the response reaches only {best:.6g} at {lo:.4g}{why}")
    if f_lo is None:
        f_lo = 0.0
    x, fx, steps = illinois(fn, target, lo, f_lo, hi, f_hi, ftol=rtol * abs(target), max_steps=max_steps,
                            steps=steps)
    if abs(fx - target) > rtol * abs(target):
        raise UnreachableTargetError(f"target {target:g} not met within {max_steps} steps (last {fx:.6g})")
    return x, fx, steps


def probe(layout, mesh, pose, layer, *, target: float = 4000.0, counts_per_pa: float = DEFAULT_COUNTS_PER_PA,
          sensor=None, force_max: float = 200.0, rtol: float = 1e-3, max_steps: int = 60,
          **press_kw) -> ProbeResult:
    """Press until the mean response over all taxels reaches ``target`` counts.

    layout, mesh, pose, layer : as :func:`vtcore.contact.press`. target : counts (p_bar*).
    counts_per_pa : sensor gain used when ``sensor`` is None. sensor : callable
    ``pressure (N,) Pa -> counts (N,)`` (must be non-decreasing in pressure).
    force_max : N, give up beyond this force. Other keywords go to ``press``
    (model, compliance, grid, direction, ...).
    """
    if not (np.isfinite(target) and target > 0):
        raise InputError(f"must be > 0 counts, got {target}", key="target")
    to_counts = sensor if sensor is not None else (lambda p: _gain(p, counts_per_pa))
    cache: dict[float, tuple] = {}
    state = {"prev": None}

    def mean_response(f):
        r = press(layout, mesh, pose, layer, force=f, warm_start=state["prev"], **press_kw)
        state["prev"] = r
        c = np.asarray(to_counts(r.pressure), float)
        cache[f] = (r, c)
        return float(c.mean())

    f, pbar, steps = solve_monotone(mean_response, target, x0=1.0, x_max=force_max, rtol=rtol,
                                    max_steps=max_steps)
    r, c = cache[f]
    disp = r.displacement
    comp = pbar / disp if disp > 0 else np.inf
    return ProbeResult(force=f, mean_response=pbar, counts=c, result=r, displacement=disp,
                       compliance=float(comp), steps=steps)
