"""The fast large-compression layer model (``model = "hyperelastic"``): the finite layer solved in a
Seth-Hill strain whose order depends on how the layer can flow out, with a local stiffening.

A nearly incompressible layer bonded to the rigid end-effector stiffens as it is squeezed: the
material has to flow out sideways through a gap that closes. The linear finite layer
(:mod:`vtcore.contact.elastic`) answers the interference ``i = d - g`` (m) of the rigid object with a
pressure linear in it. This model keeps that kernel (its spreading, its bonded base, its
incompressibility at small strain) and replaces the interference it is asked to impose by

    i' = h phi(i / h),   phi(c) = (1 - (1 - c)^m) / m      (m = 0: -ln(1 - c))

the Seth-Hill strain of order m of the local stretch ``1 - c`` (c the compression, i / h): m = 1 is
the linear layer, m = 0 the logarithmic strain, m < 0 stiffer still, m > 1 softer. Then the pressure
it answers is raised where the layer is squeezed, ``p (1 - c)^-k``: the thinned layer under the deepest
point carries more than the linear kernel spreads there.

Why the order is not one number. An incompressible neo-Hookean block compressed by a stretch l is nearly
linear in its true stress when it can bulge in every direction (uniaxial: ``mu (l^2 - 1/l)``, 9 % over
the linear 3 mu (l - 1) at l = 0.6) and stiffens much more when it can bulge in one only (plane strain:
``mu (l^2 - l^-2)``, 51 % over 4 mu (l - 1)). The finite-element reference shows the same: a sphere's force
stays within 7 % of the linear layer's to 60 % compression, a finger pad's (a cylinder) is 19-26 % over
it. The order is therefore taken per contact from its footprint: ``m = m_round + (m_strip - m_round) e``
with e the footprint's elongation (:func:`elongation`, 0 for a disc, towards 1 for a long strip). The
three constants (:class:`Law`) are fitted by least squares to the neo-Hookean finite-element reference
(:mod:`vtcore.contact.fem_reference`, :func:`vtcore.contact.layer_bench.fit_law`) on the sphere and the
finger pad into 3 and 10 mm; the 6 mm layers, the punch and the cube's edge are held out of the fit.
At small compression phi(c) = c + (1 - m) c^2 / 2 + ... and the stiffening 1 + k c: the model equals
the linear finite layer.

Cost: under an approach the solve is the linear one on a transformed gap; under a target force each
step of the travel's iteration is a warm-started force-controlled linear solve (:func:`solve_large`):
about twice the linear layer's time.

Limits (stated, tested): past :data:`FITTED_COMPRESSION` of the thickness the model is outside its
fitted range (a :class:`vtcore.contact.materials.LargeDeformationWarning` from the caller); a target
that needs more than :data:`BOTTOM_OUT` of the thickness raises
:class:`vtcore.errors.UnreachableTargetError` (the object bottoms out on the end-effector).
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np

from ..errors import UnreachableTargetError
from .elastic import ContactSolution, solve_pk
from .materials import LargeDeformationWarning, compression_note

#: Seth-Hill order of the strain under a round contact (the layer flows out of it in every direction, as
#: under a sphere or a punch) and under a long strip (it flows out sideways only: plane strain, as under a
#: cylinder or a cube's edge); fitted to the finite-element reference, see :func:`law`
ORDER_ROUND = 1.0
ORDER_STRIP = 0.278
#: k of the local stiffening ``(1 - c)^-k`` of the pressure where the layer is compressed by c: a
#: thinner layer under the deepest point carries more of the load than the linear kernel spreads there
CONCENTRATION = 0.095
#: compression (share of the thickness) beyond which a target is refused: the object bottoms out
BOTTOM_OUT = 0.90


@dataclass(frozen=True)
class Law:
    """The model's three constants: Seth-Hill orders under a round contact and a long strip (-), and the
    local stiffening exponent k (-). ``Law(m, m, 0)`` is one Seth-Hill order everywhere."""

    round: float = ORDER_ROUND
    strip: float = ORDER_STRIP
    concentration: float = CONCENTRATION


def law(order: float | None = None) -> Law:
    """The fitted :class:`Law`, or one Seth-Hill ``order`` everywhere without local stiffening."""
    return Law() if order is None else Law(float(order), float(order), 0.0)


def strain(c, m=ORDER_ROUND):
    """phi(c), the Seth-Hill strain of order ``m`` (a number, or an array broadcasting with c) at
    compression ``c`` (any shape, share of h).

    Defined for every c: below -1 (a gap wider than the layer) and above :data:`BOTTOM_OUT` it
    continues along its tangent, so a solver exploring there never meets NaN or infinity.
    """
    c = np.asarray(c, dtype=float)
    m = np.asarray(m, dtype=float)
    cc = np.clip(c, -1.0, BOTTOM_OUT)
    lam = 1.0 - cc
    log = np.abs(m) < 1e-12
    ms = np.where(log, 1.0, m)
    phi = np.where(log, -np.log(lam), (1.0 - lam**ms) / ms)
    return phi + _slope(c, m) * (c - cc)


def compression_at(phi, m: float = ORDER_ROUND) -> float:
    """The compression c (share of h) whose Seth-Hill strain of order ``m`` is ``phi`` >= 0 (:func:`strain`'s
    inverse there), at most :data:`BOTTOM_OUT`."""
    top = float(strain(BOTTOM_OUT, m))
    if phi >= top:
        return BOTTOM_OUT
    c = 1.0 - np.exp(-phi) if abs(m) < 1e-12 else 1.0 - (1.0 - m * phi) ** (1.0 / m)
    return float(min(c, BOTTOM_OUT))


def elongation(mask, spacing) -> np.ndarray:
    """(mx, my) in [0, 1): per cell of ``mask`` (bool, the contact's cells), how strip-like its connected
    contact is, ``1 - sqrt(l_min / l_max)`` of the area's second moments (0 for a disc or a square, 1 - b/a
    for an ellipse of semi-axes a >= b, towards 1 for a long strip); 0 outside ``mask``.
    spacing : (dx, dy) m, the cells' sides (the moments are taken in metres)."""
    from scipy import ndimage

    out = np.zeros(mask.shape)
    lab, n = ndimage.label(mask)
    if n == 0:
        return out
    i, j = np.nonzero(lab)
    k = lab[i, j]
    x, y = i * float(spacing[0]), j * float(spacing[1])
    w = np.bincount(k, minlength=n + 1)[1:].astype(float)

    def mean(v):
        return np.bincount(k, v, minlength=n + 1)[1:] / w

    mx, my = mean(x), mean(y)
    # each cell's own extent (d^2 / 12) keeps a one-cell contact round
    cxx = mean(x * x) - mx**2 + spacing[0] ** 2 / 12
    cyy = mean(y * y) - my**2 + spacing[1] ** 2 / 12
    cxy = mean(x * y) - mx * my
    half, root = (cxx + cyy) / 2, np.sqrt(((cxx - cyy) / 2) ** 2 + cxy**2)
    e = 1.0 - np.sqrt(np.maximum(half - root, 0.0) / (half + root))
    out[i, j] = e[k - 1]
    return out


def _orders(gap, approach, lw: Law, spacing):
    """Per-cell Seth-Hill order (mx, my): between the round and the strip order by the elongation of the
    object's footprint at ``approach`` (its interference, before the layer's response shapes it)."""
    if lw.round == lw.strip:
        return np.float64(lw.round)
    return lw.round + (lw.strip - lw.round) * elongation(np.isfinite(gap) & (gap < approach), spacing)


def _transformed(gap, approach, h, m):
    """Gap (m) whose linear solve at approach 0 imposes the transformed interference; m per cell or one."""
    with np.errstate(invalid="ignore"):
        return np.where(np.isfinite(gap), -h * strain((approach - gap) / h, m), np.inf)


def _stiffening(gap, approach, h, k):
    """(mx, my) local stiffening ``(1 - c)^-k`` of the pressure at compression c (1 outside the object)."""
    if k == 0:
        return np.float64(1.0)
    c = np.clip(np.where(np.isfinite(gap), (approach - gap) / h, 0.0), 0.0, BOTTOM_OUT)
    return (1.0 - c) ** -k


def _spacing(cell_area, spacing):
    return (np.sqrt(cell_area),) * 2 if spacing is None else tuple(float(s) for s in spacing)


def _at_approach(gap, conv, cell_area, h, lw, d, p0, tol, maxiter, conv32, spacing):
    sol = solve_pk(_transformed(gap, d, h, _orders(gap, d, lw, spacing)), conv, cell_area, approach=0.0, p0=p0,
                   tol=tol, maxiter=maxiter, conv32=conv32)
    sol.pressure = sol.pressure * _stiffening(gap, d, h, lw.concentration)
    sol.approach = float(d)
    return sol


def solve_large(gap, conv, cell_area, thickness, *, force=None, approach=None, p0=None, tol=1e-7, maxiter=1000,
                conv32=None, order: float | None = None, spacing=None) -> ContactSolution:
    """Contact of a rigid object with the large-compression layer (arguments as :func:`solve_pk`).

    gap : (mx, my) m (inf where the object is absent). conv : the linear finite layer's compliance
    operator. thickness : h, m. force : N, or approach : m. order : one Seth-Hill order everywhere, no
    local stiffening (the model before the round/strip law; None: the fitted :class:`Law`). spacing :
    (dx, dy) m, the cells' sides (None: square cells of ``cell_area``). Returns a ContactSolution whose
    ``displacement`` is the surface's (m, ``approach - gap`` in the contact) and ``approach`` the
    object's. Raises UnreachableTargetError when the force needs more than :data:`BOTTOM_OUT` x h.
    """
    g = np.asarray(gap, float)
    h = float(thickness)
    lw, sp = law(order), _spacing(cell_area, spacing)
    if approach is not None:
        sol = _at_approach(g, conv, cell_area, h, lw, float(approach), p0, tol, maxiter, conv32, sp)
        return _physical(sol, g, h)
    lin = solve_pk(g, conv, cell_area, force=force, p0=p0, tol=max(tol, 1e-4), maxiter=maxiter, conv32=conv32)
    if not lin.pressure.any():
        return lin
    sol, f, iters = _force_secant(g, conv, cell_area, h, lw, force, lin, (tol, maxiter, conv32), sp)
    if f < force * (1 - 1e-3):
        raise UnreachableTargetError(
            f"{force} N would squeeze the {h * 1e3:.3g} mm layer by more than {BOTTOM_OUT:.0%} of its thickness "
            "(model hyperelastic): the object bottoms out on the end-effector; use a thicker or stiffer layer or a "
            "lower force")
    sol.iterations = iters
    return _physical(sol, g, h)


def _force_secant(g, conv, cell_area, h, lw, force, lin, solver, spacing):
    """(solution, its force N, iterations): the travel d whose transformed press carries ``force``.

    Each step is a force-controlled linear solve on the gap transformed at the current d, warm-started:
    its rigid shift s says by how much the transformed interference is short (s < 0) or long, and d
    moves by s over the strain's mean slope in the contact. The linear solve is asked for the force
    that the local stiffening (:func:`_stiffening`) then brings to ``force``, its ratio taken from the
    step before. At the answer s = 0 and that ratio is steady: the consistency of d converges to 1e-6 h.
    """
    tol, maxiter, conv32 = solver
    gmin = float(g[np.isfinite(g)].min())
    top = gmin + BOTTOM_OUT * h
    # first guess: the travel whose strain at the first contact equals the linear layer's compression there
    d = gmin + h * compression_at(max(lin.approach - gmin, 0.0) / h, lw.round)
    # and the force to ask of the linear solve: the target over the stiffening the linear press would get
    f_lin = float((lin.pressure * _stiffening(g, lin.approach, h, lw.concentration)).sum() * cell_area)
    sol, iters, shift, asked, f = lin, lin.iterations, np.inf, float(force) ** 2 / f_lin, 0.0
    for k in range(60):
        tight = abs(shift) < 1e-4 * h
        m = _orders(g, d, lw, spacing)
        sol = solve_pk(_transformed(g, d, h, m), conv, cell_area, force=asked, p0=sol.pressure,
                       tol=tol if tight else max(tol, 1e-4), maxiter=maxiter, conv32=conv32)
        iters += sol.iterations
        shift = sol.approach
        stiff = _stiffening(g, d, h, lw.concentration)
        f = float((sol.pressure * stiff).sum() * cell_area)
        steady = abs(f / force - 1) < 1e-8
        if tight and abs(shift) < 1e-6 * h and steady:
            break
        asked *= force / f if f > 0 else 1.0
        c = (d - np.where(np.isfinite(g), g, np.inf)[sol.pressure > 0]) / h
        mc = m[sol.pressure > 0] if np.ndim(m) else m
        slope = float(np.mean(_slope(c, mc))) if c.size else 1.0
        d_new = d + shift / slope
        if d_new >= top and d >= top:
            break
        d = min(d_new, top)
    sol.pressure = sol.pressure * stiff
    sol.approach = float(d)
    return sol, f if abs(shift) < 1e-3 * h else 0.0, iters


def _slope(c, m):
    """d phi / d c at compressions c (order m, a number or an array broadcasting with c)."""
    lam = 1.0 - np.clip(c, -1.0, BOTTOM_OUT)
    return lam ** (np.asarray(m, float) - 1.0)


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
