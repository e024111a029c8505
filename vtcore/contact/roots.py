"""One root finder for the contact package: Illinois regula falsi on a bracket.

Used by :func:`vtcore.contact.force.solve_monotone` (the force at which the mean sensor
response reaches a target) and by the unrolled press (:mod:`vtcore.contact.curved`, the travel
at which the force along the press reaches its target). Both functions are non-decreasing and
piecewise smooth; regula falsi keeps the root bracketed, and the Illinois modification (halving
the retained end's value when the same end is kept twice) stops it from stalling on one side.
scipy.optimize.brentq does not fit: it cannot start from already evaluated ends (each
evaluation is a whole contact solve) nor treat an evaluation that raises as "too far".
"""

from __future__ import annotations

import numpy as np

from ..errors import UnreachableTargetError


def illinois(fn, target, lo, f_lo, hi, f_hi, *, ftol, xtol=0.0, max_steps=60, steps=0):
    """Refine ``fn(x) = target`` on the bracket [lo, hi] with ``f_lo < target <= f_hi``.

    fn : non-decreasing callable float -> float; it may raise UnreachableTargetError, which is
    taken as "beyond the reachable range" (the upper end moves there with f = inf).
    ftol : stop when ``|fn(x) - target| <= ftol``. xtol : stop when ``hi - lo < xtol``.
    max_steps : stop when ``steps`` (evaluations so far, counting from ``steps``) reaches it.
    Returns ``(x, fn(x), steps)`` of the last evaluation (starting from ``hi``); the caller
    decides whether an unmet tolerance is an error.
    """
    side = 0
    x, fx = hi, f_hi
    while abs(fx - target) > ftol and hi - lo >= xtol and steps < max_steps:
        if f_hi == f_lo:
            x = 0.5 * (lo + hi)
        else:
            x = hi - (f_hi - target) * (hi - lo) / (f_hi - f_lo)
            if not lo < x < hi:
                x = 0.5 * (lo + hi)
        steps += 1
        try:
            fx = float(fn(x))
        except UnreachableTargetError:
            hi, f_hi = x, np.inf
            x = 0.5 * (lo + x)
            continue
        if fx >= target:
            hi, f_hi = x, fx
            if side == 1:
                f_lo = target + (f_lo - target) / 2
            side = 1
        else:
            lo, f_lo = x, fx
            if side == -1:
                f_hi = target + (f_hi - target) / 2
            side = -1
    return x, fx, steps
