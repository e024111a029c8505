"""Finite-element reference for a rigid indenter pressed into a hyperelastic layer bonded to a rigid base.

Why scikit-fem (pinned 12.0.2): a pure-Python wheel on PyPI (numpy/scipy only) that installs the
same in both Python lanes, small, with hyperelasticity among its examples; sfepy needs compiled
extensions and a larger stack, torch-fem brings torch. Used by the benchmark
(``vtcore bench layer``) and slow tests only, never by a scene.

The problem. A layer of thickness h (z from 0, the base, to h, the top), compressible neo-Hookean
(``W = mu/2 (I1 - 3) - mu ln J + lambda/2 (ln J)^2``, mu and lambda from the layer's E and nu: the
same small-strain stiffness as the linear models), bonded to the rigid end-effector at z = 0
(u = 0), frictionless top contact with a rigid profile :class:`vtcore.contact.indenters.Indenter`
lowered by ``d``: a top point (X, h) moved to (X + u_x, h + u_z) penetrates by
``g = u_z + d - f(X + u_x)``, resisted by a penalty pressure ``k <g>`` over the top surface
(``k = 1000 E / h``: the penetration at a pressure E is a thousandth of the thickness). Quadratic
triangles (P2, displacement only: at nu = 0.49 the bulk-to-shear ratio is 50, where P2 does not
lock), axisymmetric (sphere, punch: the hoop stretch ``1 + u_r / r``) or plane strain (cube edge,
finger pad: force per unit length). Newton's method on each indentation step, the steps from
``d = 0`` up to the largest asked compression. The far side (at several thicknesses beyond the
contact) is traction free.

Reported per step: the force (N, or N/m in plane strain), the peak pressure on the deformed,
projected top surface (Pa) and the contact radius (half-width, m) in the deformed configuration.
"""

from __future__ import annotations

import time
import warnings
from dataclasses import dataclass

import numpy as np

from ..errors import InputError
from .indenters import Indenter


@dataclass
class ReferenceResult:
    """Reference curves of one indenter into one layer.

    compression : (S,) d / h. force : (S,) N (axisymmetric) or N/m (plane strain).
    peak_pressure : (S,) Pa. contact_radius : (S,) m. seconds : wall time of the whole sweep, s.
    newton : (S,) Newton iterations per step. dofs : degrees of freedom.
    """

    compression: np.ndarray
    force: np.ndarray
    peak_pressure: np.ndarray
    contact_radius: np.ndarray
    seconds: float
    newton: np.ndarray
    dofs: int
    #: process CPU time of the sweep, s (wall time depends on the machine's load)
    cpu_seconds: float = 0.0


def _axis(h, reach, fine):
    """Lateral node coordinates (m): ``fine`` spacing to ``reach``, then growing by 1.25 per cell to
    ``reach + 8 h`` (the far side, where a bonded layer's response has decayed)."""
    xs = list(np.linspace(0.0, reach, max(int(np.ceil(reach / fine)), 2) + 1))
    step, end = fine, reach + 8 * h
    while xs[-1] < end:
        step *= 1.25
        xs.append(xs[-1] + step)
    return np.array(xs)


def _mesh(h, reach, fine):
    from skfem import MeshTri

    zs = h * (1 - (1 - np.linspace(0.0, 1.0, 9)) ** 1.5)  # finer towards the top, where the contact is
    return MeshTri.init_tensor(_axis(h, reach, fine), zs)


def _deformation(grad, value, x, axi):
    """F (3, 3, ...) from a displacement's gradient (2, 2, ...) and value (2, ...) at radii x."""
    F = np.zeros((3, 3) + grad.shape[2:])
    F[0, 0] = 1 + grad[0, 0]
    F[0, 1] = grad[0, 1]
    F[1, 0] = grad[1, 0]
    F[1, 1] = 1 + grad[1, 1]
    F[2, 2] = 1 + value[0] / x if axi else 1.0
    return F


#: the five components of F (row, column) a 2-D or axisymmetric displacement can vary
_COMPONENTS = ((0, 0), (0, 1), (1, 0), (1, 1), (2, 2))


def _variation(v, x, axi):
    """The five variable components of dF (5, ...) for a test or trial function ``v``."""
    g = v.grad
    return np.stack([g[0, 0], g[0, 1], g[1, 0], g[1, 1], v[0] / x if axi else 0 * g[0, 0]])


def _stress(F, mu, lam):
    """First Piola stress P (5, ...) and tangent dP/dF (5, 5, ...) of the neo-Hookean solid, on the
    components :data:`_COMPONENTS`; F (3, 3, ...)."""
    Fm = np.moveaxis(F, (0, 1), (-2, -1))
    J = np.linalg.det(Fm)
    if not (J > 0).all():
        raise FloatingPointError("element inverted")
    Fi = np.moveaxis(np.linalg.inv(Fm), (-2, -1), (0, 1))  # Fi[J, i] = (F^-1)_Ji
    lnJ = np.log(J)
    P = np.stack([mu * (F[i, j] - Fi[j, i]) + lam * lnJ * Fi[j, i] for i, j in _COMPONENTS])
    A = np.empty((5, 5) + F.shape[2:])
    for a, (i, j) in enumerate(_COMPONENTS):
        for b, (k, m) in enumerate(_COMPONENTS):
            # d/dF_km of P_ij: mu delta_ik delta_jm + (mu - lam ln J) Fi_jk Fi_mi + lam Fi_ji Fi_mk
            A[a, b] = (mu * (i == k) * (j == m) + (mu - lam * lnJ) * Fi[j, k] * Fi[m, i]
                       + lam * Fi[j, i] * Fi[m, k])
    return P, A


def _forms(indenter: Indenter, kpen, axi):
    from skfem import BilinearForm, LinearForm

    def wt(x):
        return 2 * np.pi * x if axi else 1.0 + 0 * x

    @LinearForm
    def residual(v, w):
        return np.einsum("a...,a...->...", w.P, _variation(v, w.x[0], axi)) * wt(w.x[0])

    @BilinearForm
    def tangent(u, v, w):
        Au = np.einsum("ab...,b...->a...", w.A, _variation(u, w.x[0], axi))
        return np.einsum("a...,a...->...", Au, _variation(v, w.x[0], axi)) * wt(w.x[0])

    def gap(w):
        f, fp = indenter.profile(w.x[0] + w.prev[0])
        return w.prev[1] + w.d - f, fp

    def curvature(w):
        """f'' at the deformed top point (1/m), by a central difference of the slope: the contact
        force turns with the surface there, which Newton's tangent needs at a rounded edge."""
        x, eps = w.x[0] + w.prev[0], 1e-7 * max(indenter.edge_radius or indenter.radius, 1e-6)
        return (indenter.profile(x + eps)[1] - indenter.profile(x - eps)[1]) / (2 * eps)

    @LinearForm
    def c_residual(v, w):
        g, fp = gap(w)
        return kpen * np.maximum(g, 0) * (v[1] - fp * v[0]) * wt(w.x[0])

    @BilinearForm
    def c_tangent(u, v, w):
        g, fp = gap(w)
        # d/du of <g> (v_z - f'(x) v_x), x = X + u_x: the active penalty along the normal, and the normal's
        # turn, -<g> f'' u_x v_x (without it Newton converges only linearly where the layer wraps an edge)
        return kpen * ((g > 0) * (u[1] - fp * u[0]) * (v[1] - fp * v[0])
                       - np.maximum(g, 0) * curvature(w) * u[0] * v[0]) * wt(w.x[0])

    return residual, tangent, c_residual, c_tangent


def _damped(basis, x, dx, axi):
    """x + s dx with the largest s in 1, 1/2, ... 1/32 that inverts no element (Newton's first steps
    into a new contact can overshoot)."""
    X = basis.global_coordinates()[0]
    for k in range(6):
        y = x + dx / 2**k
        w = basis.interpolate(y)
        F = _deformation(w.grad, w, X, axi)
        if (np.linalg.det(np.moveaxis(F, (0, 1), (-2, -1))) > 0).all():
            return y
    raise FloatingPointError("the Newton step inverts an element however it is damped")


def _newton_solver(basis, fb, fixed, forms, mu, lam, axi, h, max_newton):
    """``solve(x, d) -> (x, iterations)``: Newton's method from ``x`` at the indenter's depth ``d`` (m);
    raises FloatingPointError when it folds an element or does not converge."""
    from scipy.sparse.linalg import spsolve
    from skfem import asm, condense

    residual, tangent, c_res, c_tan = forms
    X = basis.global_coordinates()[0]
    free = basis.complement_dofs(fixed)

    def solve(x, d):
        x = x.copy()
        for it in range(1, max_newton + 1):
            pw, pf = basis.interpolate(x), fb.interpolate(x)
            P, A = _stress(_deformation(pw.grad, pw, X, axi), mu, lam)
            R = asm(residual, basis, P=P) + asm(c_res, fb, prev=pf, d=d)
            K = asm(tangent, basis, A=A) + asm(c_tan, fb, prev=pf, d=d)
            dx = np.zeros_like(x)
            dx[free] = spsolve(*condense(K, -R, D=fixed, expand=False))
            x = _damped(basis, x, dx, axi)
            if np.abs(dx).max() < 1e-4 * h:  # a tenth of the penalty's own penetration at p = E
                return x, it
        raise FloatingPointError(f"Newton did not converge in {max_newton} iterations at d = {d:g} m")

    return solve


def _contact_state(fb, x, d, indenter, kpen, axi):
    """(force, peak pressure on the deformed projected surface, contact radius) at displacement x."""
    w = fb.interpolate(x)
    X = fb.global_coordinates()[0]
    ux, uz = w[0], w[1]
    f, _ = indenter.profile(X + ux)
    pen = np.maximum(uz + d - f, 0.0)
    dx = fb.dx  # quadrature weights x facet lengths (nfacets, nqp)
    ring = 2 * np.pi * X if axi else 2.0  # plane strain: the mesh is the half x >= 0 of a symmetric press
    force = float(np.sum(kpen * pen * ring * dx))
    stretch = 1 + w.grad[0, 0] * 1.0  # d(X + u_x)/dX along the top surface
    if axi:
        stretch = stretch * (X + ux) / np.maximum(X, 1e-300)
    p = kpen * pen / np.maximum(stretch, 1e-9)
    radius = float((X + ux)[pen > 0].max()) if (pen > 0).any() else 0.0
    return force, float(p.max()), radius


def reference_press(indenter: Indenter, thickness: float, young_modulus: float, poisson: float,
                    compressions, *, reach: float | None = None, fine: float | None = None,
                    max_newton: int = 16, max_seconds: float | None = None) -> ReferenceResult:
    """Press ``indenter`` into a neo-Hookean layer of ``thickness`` (m) by each of ``compressions``
    (d / h, increasing, in (0, 0.8]); returns a :class:`ReferenceResult`.

    young_modulus : Pa, poisson : - (the small-strain constants: mu = E / 2(1 + nu),
    lambda = E nu / (1 + nu)(1 - 2 nu)). reach : m, the finely meshed lateral span (default:
    the indenter's radius or half-width plus 3 h). fine : m, the mesh spacing there (default h / 8,
    at most a third of a rounded edge's radius). max_newton : iterations per load step.
    Steps between them adapt: halved when Newton fails, grown after an easy one; compressions it cannot
    reach on steps down to 1e-4 h are left out of the result (a RuntimeWarning says where it stopped),
    as are those not reached within ``max_seconds`` of wall time (s; None: no limit).
    """
    from skfem import Basis, ElementTriP2, ElementVector, FacetBasis

    c = np.asarray(compressions, float)
    if c.ndim != 1 or not len(c) or not (np.diff(c) > 0).all() or c[0] <= 0 or c[-1] > 0.8:
        raise InputError(f"compressions must increase within (0, 0.8], got {c}", key="compressions")
    h, E, nu = float(thickness), float(young_modulus), float(poisson)
    if not (h > 0 and E > 0 and 0 <= nu < 0.5):
        raise InputError(f"needs h > 0, E > 0, 0 <= nu < 0.5; got {h}, {E}, {nu}", key="thickness")
    t0, c0 = time.perf_counter(), time.process_time()
    axi = indenter.geometry == "axisymmetric"
    mu, lam = E / (2 * (1 + nu)), E * nu / ((1 + nu) * (1 - 2 * nu))
    kpen = 1000 * E / h
    fine = fine or min(h / 8, indenter.edge_radius / 3 if indenter.edge_radius else h / 8)
    reach = reach or (indenter.radius if indenter.kind in ("punch", "cube_edge")
                      else min(indenter.radius, np.sqrt(2 * indenter.radius * c[-1] * h) * 1.3)) + 3 * h
    mesh = _mesh(h, reach, fine)
    basis = Basis(mesh, ElementVector(ElementTriP2()), intorder=4)
    top = mesh.facets_satisfying(lambda x: np.isclose(x[1], h))
    fb = FacetBasis(mesh, basis.elem, facets=top, intorder=6)
    base = basis.get_dofs(lambda x: np.isclose(x[1], 0.0)).all()
    axis = basis.get_dofs(lambda x: np.isclose(x[0], 0.0)).all("u^1")
    fixed = np.unique(np.concatenate([base, axis]))
    x = np.zeros(basis.N)
    solve = _newton_solver(basis, fb, fixed, _forms(indenter, kpen, axi), mu, lam, axi, h, max_newton)
    x, done, step = np.zeros(basis.N), 0.0, min(c[0], 0.025)
    out = {k: [] for k in ("f", "p", "a", "n")}
    for target in c:
        while done < target - 1e-12:
            if max_seconds is not None and time.perf_counter() - t0 > max_seconds:
                break
            s = min(done + step, target)
            try:
                y, it = solve(x, s * h)
            except FloatingPointError:
                step /= 2  # Newton left the basin (an element folded, or no convergence): a smaller step
                if step < 1e-4:
                    break
                continue
            x, done = y, s
            step = min(step * 1.5, 0.05) if it <= 6 else step
        if done < target - 1e-12:
            # the deepest compressions it could not reach are left out, and said (warning), rather than
            # losing the whole sweep: the bench compares over what the reference reached
            warnings.warn(f"the finite-element reference stopped at {done:.0%} compression ({indenter.kind} into "
                          f"{h * 1e3:g} mm): Newton did not converge on smaller steps or the time ran out",
                          RuntimeWarning, stacklevel=2)
            break
        force, peak, radius = _contact_state(fb, x, target * h, indenter, kpen, axi)
        for key, v in zip("fpan", (force, peak, radius, it)):
            out[key].append(v)
    return ReferenceResult(c[:len(out["f"])], np.array(out["f"]), np.array(out["p"]), np.array(out["a"]),
                           time.perf_counter() - t0, np.array(out["n"]), basis.N, time.process_time() - c0)
