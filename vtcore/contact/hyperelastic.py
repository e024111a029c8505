"""The fast large-compression layer model (``model = "hyperelastic"``): the finite layer solved in a
Seth-Hill strain.

A nearly incompressible layer bonded to the rigid end-effector stiffens as it is squeezed: the
material has to flow out sideways through a gap that closes. The linear finite layer
(:mod:`vtcore.contact.elastic`) answers the interference ``i = d - g`` (m) of the rigid object with a
pressure linear in it. This model keeps that kernel (its spreading, its bonded base, its
incompressibility at small strain) and replaces the interference it is asked to impose by

    i' = h phi(i / h),   phi(c) = (1 - (1 - c)^m) / m      (m = 0: -ln(1 - c))

the Seth-Hill strain of order m of the local stretch ``1 - c`` (c the compression, i / h): m = 1 is
the linear layer, m = 0 the logarithmic strain, m < 0 stiffer still; phi(c) grows without bound as
the layer's thickness closes, so the layer never has a negative thickness. The order is fitted
once to the neo-Hookean finite-element reference (:mod:`vtcore.contact.fem_reference`,
``vtcore bench layer``) over the four reference indenters, three thicknesses and 5-60 %
compression: :data:`SETH_HILL_ORDER`. At small compression phi(c) = c + (1 - m) c^2 / 2 + ...: the
model equals the linear finite layer.

Cost: under an approach the solve is the linear one on a transformed gap; under a target force the
approach is found by a secant in log force, each step a warm-started approach-controlled solve
(:func:`solve_large`).

Limits (stated, tested): past :data:`FITTED_COMPRESSION` of the thickness the model is outside its
fitted range (a :class:`vtcore.contact.materials.LargeDeformationWarning` from the caller); a target
that needs more than :data:`BOTTOM_OUT` of the thickness raises
:class:`vtcore.errors.UnreachableTargetError` (the object bottoms out on the end-effector).
"""

from __future__ import annotations

import warnings

import numpy as np

from ..errors import UnreachableTargetError
from .elastic import ContactSolution, solve_pk
from .materials import LargeDeformationWarning, compression_note

#: Seth-Hill order m of the strain the layer is linear in, fitted to the finite-element reference
SETH_HILL_ORDER = 0.4
#: compression (share of the thickness) beyond which a target is refused: the object bottoms out
BOTTOM_OUT = 0.90


def strain(c, m: float = SETH_HILL_ORDER):
    """phi(c), the Seth-Hill strain of order ``m`` at compression ``c`` (any shape, share of h).

    Defined for every c: below -1 (a gap wider than the layer) and above :data:`BOTTOM_OUT` it
    continues along its tangent, so a solver exploring there never meets NaN or infinity.
    """
    c = np.asarray(c, dtype=float)
    lo, hi = -1.0, BOTTOM_OUT
    cc = np.clip(c, lo, hi)
    lam = 1.0 - cc
    if abs(m) < 1e-12:
        phi, slope = -np.log(lam), 1.0 / lam
    else:
        phi, slope = (1.0 - lam**m) / m, lam ** (m - 1.0)
    return phi + slope * (c - cc)


def compression_at(phi, m: float = SETH_HILL_ORDER) -> float:
    """The compression c (share of h) whose Seth-Hill strain of order ``m`` is ``phi`` >= 0 (:func:`strain`'s
    inverse there), at most :data:`BOTTOM_OUT`."""
    top = float(strain(BOTTOM_OUT, m))
    if phi >= top:
        return BOTTOM_OUT
    c = 1.0 - np.exp(-phi) if abs(m) < 1e-12 else 1.0 - (1.0 - m * phi) ** (1.0 / m)
    return float(min(c, BOTTOM_OUT))


def _transformed(gap, approach, h, m):
    """Gap (m) whose linear solve at approach 0 imposes the transformed interference."""
    with np.errstate(invalid="ignore"):
        return np.where(np.isfinite(gap), -h * strain((approach - gap) / h, m), np.inf)


def _at_approach(gap, conv, cell_area, h, m, d, p0, tol, maxiter, conv32):
    sol = solve_pk(_transformed(gap, d, h, m), conv, cell_area, approach=0.0, p0=p0, tol=tol, maxiter=maxiter,
                   conv32=conv32)
    sol.approach = float(d)
    return sol


def solve_large(gap, conv, cell_area, thickness, *, force=None, approach=None, p0=None, tol=1e-7, maxiter=1000,
                conv32=None, order: float = SETH_HILL_ORDER) -> ContactSolution:
    """Contact of a rigid object with the large-compression layer (arguments as :func:`solve_pk`).

    gap : (mx, my) m (inf where the object is absent). conv : the linear finite layer's compliance
    operator. thickness : h, m. force : N, or approach : m. Returns a ContactSolution whose
    ``displacement`` is the surface's (m, ``approach - gap`` in the contact) and ``approach`` the
    object's. Raises UnreachableTargetError when the force needs more than :data:`BOTTOM_OUT` x h.
    """
    g = np.asarray(gap, float)
    h = float(thickness)
    if approach is not None:
        sol = _at_approach(g, conv, cell_area, h, order, float(approach), p0, tol, maxiter, conv32)
        return _physical(sol, g, h)
    lin = solve_pk(g, conv, cell_area, force=force, p0=p0, tol=max(tol, 1e-4), maxiter=maxiter, conv32=conv32)
    if not lin.pressure.any():
        return lin
    sol, f, iters = _force_secant(g, conv, cell_area, h, order, force, lin, tol, maxiter, conv32)
    if f < force * (1 - 1e-3):
        raise UnreachableTargetError(
            f"{force} N would squeeze the {h * 1e3:.3g} mm layer by more than {BOTTOM_OUT:.0%} of its thickness "
            "(model hyperelastic): the object bottoms out on the end-effector; use a thicker or stiffer layer or a "
            "lower force")
    sol.iterations = iters
    return _physical(sol, g, h)


def _force_secant(g, conv, cell_area, h, order, force, lin, tol, maxiter, conv32):
    """(solution, its force N, iterations): the travel d whose transformed press carries ``force``.

    Each step is a force-controlled linear solve on the gap transformed at the current d, warm-started:
    its rigid shift s says by how much the transformed interference is short (s < 0) or long, and d
    moves by s over the strain's mean slope in the contact. At the answer s = 0: the force is exact at
    every step, the consistency of d is what converges (to 1e-6 h).
    """
    gmin = float(g[np.isfinite(g)].min())
    top = gmin + BOTTOM_OUT * h
    # first guess: the travel whose strain at the first contact equals the linear layer's compression there
    d = gmin + h * compression_at(max(lin.approach - gmin, 0.0) / h, order)
    sol, iters, shift = lin, lin.iterations, np.inf
    for k in range(40):
        tight = abs(shift) < 1e-4 * h
        sol = solve_pk(_transformed(g, d, h, order), conv, cell_area, force=force, p0=sol.pressure,
                       tol=tol if tight else max(tol, 1e-4), maxiter=maxiter, conv32=conv32)
        iters += sol.iterations
        shift = sol.approach
        if tight and abs(shift) < 1e-6 * h:
            break
        c = (d - np.where(np.isfinite(g), g, np.inf)[sol.pressure > 0]) / h
        slope = float(np.mean(_slope(c, order))) if c.size else 1.0
        d_new = d + shift / slope
        if d_new >= top and d >= top:
            break
        d = min(d_new, top)
    sol.approach = float(d)
    return sol, float(sol.pressure.sum() * cell_area) if abs(shift) < 1e-3 * h else 0.0, iters


def _slope(c, m):
    """d phi / d c at compressions c."""
    lam = 1.0 - np.clip(c, -1.0, BOTTOM_OUT)
    return lam ** (m - 1.0)


def _force(sol, cell_area):
    return float(sol.pressure.sum() * cell_area)


def _physical(sol, gap, h):
    """The surface displacement the object imposes (m): its interference where it presses; warns
    (LargeDeformationWarning) past the compression the model was fitted over."""
    sol.displacement = np.where(sol.pressure > 0, sol.approach - np.where(np.isfinite(gap), gap, 0.0),
                                sol.displacement)
    c = float(sol.displacement[sol.pressure > 0].max()) if sol.pressure.any() else 0.0
    note = compression_note(c, h, "the press", "hyperelastic")
    if note:
        warnings.warn(note, LargeDeformationWarning, stacklevel=3)
    return sol


def contact_solver(model: str, thickness: float):
    """The contact solve of ``model`` with :func:`vtcore.contact.elastic.solve_pk`'s arguments: this
    module's :func:`solve_large` for ``"hyperelastic"`` (bound to the layer's ``thickness``, m), else
    ``solve_pk`` itself."""
    if model != "hyperelastic":
        return solve_pk

    def solve(gap, conv, cell_area, **kw):
        return solve_large(gap, conv, cell_area, thickness, **kw)

    return solve
