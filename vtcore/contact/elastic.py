"""Elastic contact of a rigid object with a soft layer: compliance kernels and the solver.

Models (``model=``):

* ``"local"`` -- Winkler foundation, ``p = k (interference)`` with
  ``k = E* / h`` (E* = E / (1 - nu^2)). Fast, no interaction between points, so
  a flat punch gives a flat pressure (no edge concentration). Low accuracy.
* ``"halfspace"`` -- Boussinesq-Cerruti elastic half-space, influence
  coefficients of Love (1929) for uniform pressure on a rectangular cell
  (Johnson, *Contact Mechanics*, 1985, eq. 3.25); ignores the rigid base.
* ``"hyperelastic"`` -- the finite layer's kernel solved in a Seth-Hill strain of the local
  compression, for compressions past the linear range (:mod:`vtcore.contact.hyperelastic`).
* ``"finite_layer"`` (default) -- a layer of thickness h perfectly bonded to a
  rigid base, frictionless top. Its surface Green's function in Fourier space is
  ``w(k) = 2 C(kh) / (E* k) p(k)`` with

      C(t) = ((3 - 4 nu) sinh 2t - 2t) / ((3 - 4 nu) cosh 2t + 2 t^2 + 5 - 12 nu + 8 nu^2)

  (the bonded-layer correction used by ContactMechanics'
  ``PeriodicFFTElasticHalfSpace(thickness=...)``, after Johnson, Greenwood &
  Higginson 1985 / Stanley & Kato 1997). C -> 1 for kh -> oo (half-space) and
  C -> kh (1 - 2nu) / (2 (1 - nu)^2) for kh -> 0, i.e. a thin layer compresses
  with its confined modulus M = E (1 - nu) / ((1 + nu)(1 - 2 nu)) -- tested.
  In real space we use Love's exact cell integral for the half-space part plus
  the smooth, bounded correction ``(1 / (pi E* h)) F(r / h)``,
  ``F(rho) = int_0^oo (C(t) - 1) J0(t rho) dt``, tabulated once per nu and
  averaged over each cell; beyond r = 40 h the layer kernel is zero (it
  decays exponentially), so the FFT convolution on a zero-padded grid is a
  linear (non-periodic) one without wrap-around.

The contact problem (pressure >= 0, no interpenetration, given total force or
given approach) is solved with the constrained conjugate gradient of Polonsky &
Keer, Wear 231, 206 (1999), the displacements from an FFT convolution
(Hockney's zero-padding for a free surface), warm-startable from a previous
pressure field.

Stress at the taxels (depth h): the surface pressure is spread with the
Boussinesq vertical-stress kernel ``sigma_z = 3 P h^3 / (2 pi (r^2 + h^2)^(5/2))``
(half-maximum width 1.13 h, integrates to P). This is the half-space stress at
depth h; the rigid base under a bonded layer concentrates the stress
somewhat more (not modelled).
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from ..errors import InputError
from .fft import Convolver, one_blas_thread

MODELS = ("local", "halfspace", "finite_layer", "hyperelastic")
#: the compliance kernel each model solves with: the large-compression model (vtcore.contact.hyperelastic)
#: is the finite layer's kernel solved in a Seth-Hill strain
KERNELS = {"halfspace": "halfspace", "finite_layer": "finite_layer", "hyperelastic": "finite_layer"}
_RHO_MAX = 40.0  # layer kernel cut-off, in layer thicknesses


BASES = ("bonded", "frictionless")


def layer_factor(kh, poisson, base="bonded"):
    """C(kh): surface compliance of a layer on a rigid base relative to the half-space (dimensionless).

    bonded: ((3-4nu) sinh 2t - 2t) / ((3-4nu) cosh 2t + 2t^2 + 5 - 12nu + 8nu^2);
    frictionless (the layer slides on the base): (cosh 2t - 1) / (sinh 2t + 2t),
    independent of nu beyond E*; thin-layer limit h / E* (a Winkler layer).
    Both from the plane-strain Airy solution; :func:`layer_transfer` solves it numerically
    and the tests check the two agree.
    """
    t = np.asarray(kh, dtype=float)
    tt = np.minimum(t, 20.0)  # beyond t = 20, C = 1 to 1e-14; avoids overflow
    if base == "frictionless":
        with np.errstate(invalid="ignore"):
            c = np.where(tt > 0, (np.cosh(2 * tt) - 1) / np.where(tt > 0, np.sinh(2 * tt) + 2 * tt, 1.0), 0.0)
    else:
        fac = 3.0 - 4.0 * poisson
        off = 5.0 - 12.0 * poisson + 8.0 * poisson**2
        c = (fac * np.sinh(2 * tt) - 2 * tt) / (fac * np.cosh(2 * tt) + 2 * tt**2 + off)
    return np.where(t >= 20.0, 1.0, c)


def layer_transfer(kh, poisson, base="bonded"):
    """Solve the layer's plane-strain Airy problem for a surface load p cos(kx).

    Stress function phi = cos(kx) f(z), f = (A + B z) cosh kz + (C + D z) sinh kz,
    z from the base (0) to the top (h); top: sigma_zz = -p, sigma_xz = 0; base:
    u_x = u_z = 0 (bonded) or sigma_xz = u_z = 0 (frictionless).
    Returns (C (K,), T (K,)): the surface compliance relative to the half-space
    (= :func:`layer_factor`) and the base stress over the surface pressure (the
    transfer function of the stress reaching taxels at the base).
    """
    t = np.atleast_1d(np.asarray(kh, dtype=float))
    t = np.clip(t, 1e-6, 30.0)
    nu = poisson

    def basis(z):
        c, s = np.cosh(z), np.sinh(z)
        return (np.stack([c, z * c, s, z * s], -1), np.stack([s, c + z * s, c, s + z * c], -1),
                np.stack([c, 2 * s + z * c, s, 2 * c + z * s], -1), np.stack([s, 3 * c + z * s, c, 3 * s + z * c], -1))

    g, g1, g2, g3 = basis(t)
    G, G1, G2, G3 = (np.broadcast_to(a, g.shape) for a in basis(np.zeros_like(t)))
    if base == "frictionless":
        r3, r4 = G1, G3
    else:
        r3, r4 = (1 - nu) * G2 + nu * G, (1 - nu) * (2 * G1 - G3) + nu * G1
    m = np.stack([g, g1, r3, r4], axis=1)
    rhs = np.zeros((len(t), 4))
    rhs[:, 0] = 1.0
    coef = np.linalg.solve(m, rhs[..., None])[..., 0]
    c = np.abs(np.einsum("ij,ij->i", g3, coef)) / 2
    tr = np.abs(np.einsum("ij,ij->i", G, coef))
    return c, tr


def base_transfer(kh, poisson, base="bonded"):
    """T(kh): stress at the layer's base over the surface pressure, for wavenumber k (dimensionless)."""
    t = np.asarray(kh, dtype=float)
    flat = t.reshape(-1)
    out = np.zeros_like(flat)
    ok = flat < 30.0  # T ~ t exp(-t): nothing left beyond
    if ok.any():
        out[ok] = layer_transfer(flat[ok], poisson, base)[1]
    out[flat < 1e-6] = 1.0
    return out.reshape(t.shape)


@lru_cache(maxsize=16)
def _layer_table(poisson: float, base: str = "bonded"):
    """rho (R,), F(rho) (R,) = int_0^20 (C(t) - 1) J0(t rho) dt, trapezoid on a fine t grid."""
    with one_blas_thread():  # cached: the same bits whoever computes it first
        return _layer_table_values(poisson, base)


def _layer_table_values(poisson, base):
    from scipy.special import j0

    t = np.linspace(0.0, 20.0, 2001)  # 16 points per period of J0(t rho) at rho = 40
    g = layer_factor(t, poisson, base) - 1.0
    w = np.full_like(t, t[1] - t[0])
    w[[0, -1]] *= 0.5
    gw = g * w
    rho = np.linspace(0.0, _RHO_MAX, 2001)
    out = np.empty_like(rho)
    for s in range(0, len(rho), 250):  # chunks keep memory small
        r = rho[s:s + 250]
        out[s:s + 250] = j0(np.outer(r, t)) @ gw
    return rho, out


def _love_integral(x, y, a, b):
    """int int 1/r over the rectangle [x-a, x+a] x [y-b, y+b] around the origin offset (x, y), metres."""

    def F(u, v):
        with np.errstate(divide="ignore", invalid="ignore"):
            r1 = np.where(u != 0, u * np.arcsinh(v / np.abs(np.where(u != 0, u, 1.0))), 0.0)
            r2 = np.where(v != 0, v * np.arcsinh(u / np.abs(np.where(v != 0, v, 1.0))), 0.0)
        return r1 + r2

    return F(x + a, y + b) - F(x - a, y + b) - F(x + a, y - b) + F(x - a, y - b)


def _offsets(shape, dx, dy):
    """Offsets of a (2mx, 2my) zero-padded grid in FFT wrap order, metres."""
    mx, my = shape
    ix = np.fft.fftfreq(2 * mx, 1.0 / (2 * mx))
    iy = np.fft.fftfreq(2 * my, 1.0 / (2 * my))
    return np.meshgrid(ix * dx, iy * dy, indexing="ij")


def _cell_average(fun, X, Y, dx, dy, scale, near):
    """Average of ``fun(r)`` over each cell (centre X, Y), sub-sampled where the
    function varies on the length ``scale``; only cells where ``near`` is True."""
    out = np.zeros_like(X)
    s = int(np.clip(np.ceil(2.0 * max(dx, dy) / max(scale, 1e-12)), 1, 16))
    q = (np.arange(s) + 0.5) / s - 0.5
    xs, ys = X[near], Y[near]
    acc = np.zeros_like(xs)
    for qx in q:
        for qy in q:
            acc += fun(np.hypot(xs + qx * dx, ys + qy * dy))
    out[near] = acc / (s * s)
    return out


#: Sub-samples per cell side past which a kernel narrower than a cell is integrated in polar
#: coordinates instead (:func:`_polar_cells`): 16 x 16 points per cell sample a kernel of width h
#: only while h > dx / 8; at h = dx / 50 the sampled spreading kernel kept 8 % of the force.
MAX_CELL_SAMPLES = 16


def _under_resolved(dx, dy, h):
    """Whether the cell average of a kernel of width ``h`` (m) needs more than MAX_CELL_SAMPLES per side."""
    return 2.0 * max(dx, dy) / max(h, 1e-300) > MAX_CELL_SAMPLES


def _polar_cells(q, rho, shape, dx, dy, h, angles=256):
    """Integral over every cell of a radial kernel given by its ring density, (2 mx, 2 my) wrap order.

    q (R,): the kernel's integral over the ring [rho, rho + d rho] per unit d rho (rho in units of
    ``h``, m), i.e. 2 pi rho h^2 k(rho h); rho (R,) increasing, from 0. Each ring is cut into
    ``angles`` arcs and every arc's share is added to the cell its midpoint falls in: exact for a
    kernel much narrower than a cell (where sampling the cell misses it), to the ring's width
    (rho step x h) at the cell edges. Mass beyond the grid's offsets is dropped.
    """
    mx, my = shape
    mid = 0.5 * (rho[1:] + rho[:-1])
    w = 0.5 * (q[1:] + q[:-1]) * np.diff(rho) / angles
    th = (np.arange(angles) + 0.5) * (2 * np.pi / angles)
    ix = np.rint(np.outer(mid * h, np.cos(th)) / dx).astype(np.int64).ravel()
    iy = np.rint(np.outer(mid * h, np.sin(th)) / dy).astype(np.int64).ravel()
    ok = (np.abs(ix) < mx) & (np.abs(iy) < my)
    flat = np.mod(ix[ok], 2 * mx) * (2 * my) + np.mod(iy[ok], 2 * my)
    ww = np.broadcast_to(w[:, None], (len(w), angles)).ravel()[ok]
    return np.bincount(flat, weights=ww, minlength=4 * mx * my).reshape(2 * mx, 2 * my)


def influence_kernel(shape, dx, dy, layer, model="finite_layer"):
    """Surface displacement (m) at every offset per unit pressure (Pa) on one cell.

    shape : (mx, my) cells of the contact grid; dx, dy : cell size, metres.
    Returns (2 mx, 2 my) float64 in FFT wrap order (for a zero-padded linear convolution).
    """
    if model not in ("halfspace", "finite_layer"):
        raise InputError(f"no influence kernel for model {model!r}", key="model")
    X, Y = _offsets(shape, dx, dy)
    es = layer.e_star
    k = _love_integral(X, Y, dx / 2, dy / 2) / (np.pi * es)
    if model == "halfspace":
        return k
    h = layer.thickness
    rho_t, f_t = _layer_table(round(float(layer.poisson), 6), getattr(layer, "base", "bonded"))
    if _under_resolved(dx, dy, h):
        # A layer much thinner than a cell: the half-space's 1/r and the layer's correction cancel
        # beyond 40 h, so only their sum over r < 40 h counts; integrated per cell in polar form,
        # (1/r + F(r/h)/h) r dr dphi = h (1 + rho F(rho)) d rho dphi. Sampling the cell instead left
        # the half-space's compliance out to the cell's edge: a 10 um layer on a 1 mm grid took the
        # sphere 1.8 mm deep whatever the force.
        return _polar_cells(2 * np.pi * h * (1.0 + rho_t * f_t), rho_t, shape, dx, dy, h) / (np.pi * es)
    reach = _RHO_MAX * h
    near = np.hypot(np.abs(X) - dx / 2, np.abs(Y) - dy / 2) < reach  # conservative
    near &= (np.abs(X) < reach + dx) & (np.abs(Y) < reach + dy)
    corr = _cell_average(lambda r: np.interp(r / h, rho_t, f_t, right=np.nan), X, Y, dx, dy, h, near)
    far = ~near | ~np.isfinite(corr)
    k = k + corr * dx * dy / (np.pi * es * h)
    k[far] = 0.0  # the bonded layer's kernel has decayed to nothing beyond 40 h
    return k


def boussinesq_kernel(r, h):
    """Vertical stress at depth h under a unit point load at radial distance r (1/m^2).

    sigma_z(r) = 3 h^3 / (2 pi (r^2 + h^2)^(5/2)); integrates to 1 over the plane.
    """
    return 3.0 * h**3 / (2.0 * np.pi * (np.asarray(r, float) ** 2 + h**2) ** 2.5)


SPREADINGS = ("layer", "boussinesq")


@lru_cache(maxsize=16)
def _base_table(poisson: float, base: str):
    """rho (R,), G(rho) (R,) = int_0^30 T(t) J0(t rho) t dt: base stress x 2 pi h^2 per unit point load."""
    with one_blas_thread():  # cached: the same bits whoever computes it first
        return _base_table_values(poisson, base)


def _base_table_values(poisson, base):
    from scipy.special import j0

    t = np.linspace(0.0, 30.0, 3001)  # T(t) ~ t exp(-t): nothing beyond 30
    w = np.full_like(t, t[1] - t[0])
    w[[0, -1]] *= 0.5
    gw = base_transfer(t, poisson, base) * t * w
    rho = np.linspace(0.0, 20.0, 1001)
    out = np.empty_like(rho)
    for s in range(0, len(rho), 250):
        out[s:s + 250] = j0(np.outer(rho[s:s + 250], t)) @ gw
    return rho, out


def spreading_kernel(shape, dx, dy, h, kind="boussinesq", poisson=0.49, base="bonded"):
    """Stress at depth h (Pa) at every offset per unit pressure (Pa) on one cell, (2mx, 2my) wrap order.

    kind "boussinesq": half-space stress at depth h (the issue's kernel, width 1.13 h);
    "layer": the exact stress at the base of the layer on its rigid base (bonded or
    frictionless), from the Airy solution's transfer function T(kh) by a Hankel
    transform, zero beyond 20 h (it decays exponentially).
    """
    if _under_resolved(dx, dy, h):  # narrower than a cell: integrate per cell in polar form
        rho = np.linspace(0.0, 20.0, 4001)
        if kind == "boussinesq":  # 3 h^3 / (2 pi (r^2 + h^2)^(5/2)) x 2 pi r h per unit rho
            q = 3.0 * rho / (rho * rho + 1.0) ** 2.5
        else:
            rho_t, g_t = _base_table(round(float(poisson), 6), base)
            q = rho * np.interp(rho, rho_t, g_t, right=0.0)
        return _polar_cells(q, rho, shape, dx, dy, h)
    X, Y = _offsets(shape, dx, dy)
    if kind == "boussinesq":
        near = np.ones_like(X, dtype=bool)
        fun = lambda r: boussinesq_kernel(r, h)  # noqa: E731
    else:
        rho_t, g_t = _base_table(round(float(poisson), 6), base)
        near = (np.abs(X) < 20 * h + dx) & (np.abs(Y) < 20 * h + dy)
        fun = lambda r: np.interp(r / h, rho_t, g_t, right=0.0) / (2 * np.pi * h * h)  # noqa: E731
    k = _cell_average(fun, X, Y, dx, dy, h, near) * dx * dy
    return k


@lru_cache(maxsize=8)
def _cached_kernel(kind, shape, dx, dy, e, nu, h, base):
    """The (2 mx, 2 my) kernel behind an operator: shared by its precisions and truncations."""
    with one_blas_thread():  # cached: the same bits whoever computes it first
        return _kernel(kind, shape, dx, dy, e, nu, h, base)


def _kernel(kind, shape, dx, dy, e, nu, h, base):
    from .materials import SoftLayer

    if kind.startswith("spread:"):
        return spreading_kernel(shape, dx, dy, h, kind.split(":", 1)[1], nu, base)
    return influence_kernel(shape, dx, dy, SoftLayer(thickness=h, young_modulus=e, poisson=nu, base=base), kind)


@lru_cache(maxsize=32)
def _cached_convolver(kind, shape, dx, dy, e, nu, h, base, truncation=0.0, dtype="float64"):
    return Convolver(_cached_kernel(kind, shape, dx, dy, e, nu, h, base), shape, truncation=truncation,
                     dtype=np.dtype(dtype))


def compliance_operator(shape, dx, dy, layer, model, truncation=0.0, dtype=np.float64):
    """Cached ``u = K p`` for a grid of ``shape`` cells (displacement m from pressure Pa).

    truncation : largest kernel value that may be dropped, relative to its peak, to shrink the
    transforms (:func:`vtcore.contact.fft.kernel_reach`; 0, the default: the exact, fully padded
    operator, the reference). A layer's kernel decays within a few thicknesses and is cut there;
    the half-space's 1/r kernel never falls that low within a grid and keeps the full padding.
    dtype : float64 or float32 (transforms in single precision).
    The operator reports what it dropped (``.truncation``) and its transform size (``.fft_shape``).
    """
    tr = float(truncation)
    model = KERNELS.get(model, model)
    if not (tr >= 0 and np.isfinite(tr)):
        raise InputError(f"kernel truncation must be >= 0, got {truncation}", key="truncation")
    pad = getattr(layer, "pad", None)
    if pad is not None:     # a soft indenter (vtcore.contact.soft_finger): the two bodies' kernels in series
        return _cached_two_body(model, tuple(int(s) for s in shape), float(dx), float(dy), _params(layer),
                                _params(pad), tr, np.dtype(dtype).name)
    return _cached_convolver(model, tuple(int(s) for s in shape), float(dx), float(dy),
                             float(layer.young_modulus), float(layer.poisson), float(layer.thickness),
                             getattr(layer, "base", "bonded"), tr, np.dtype(dtype).name)


def _params(layer) -> tuple:
    return (float(layer.young_modulus), float(layer.poisson), float(layer.thickness), getattr(layer, "base", "bonded"))


@lru_cache(maxsize=8)
def _cached_two_body(kind, shape, dx, dy, skin, pad, truncation, dtype):
    """The compliance of the skin's layer and a soft indenter's pad in series: the sum of their
    kernels (both surfaces displace under the same contact pressure). skin, pad: (E, nu, h, base)."""
    k = _cached_kernel(kind, shape, dx, dy, *skin) + _cached_kernel(kind, shape, dx, dy, *pad)
    return Convolver(k, shape, truncation=truncation, dtype=np.dtype(dtype))


PRECISIONS = ("float64", "float32")


def compliance_operators(shape, dx, dy, layer, model, truncation=0.0, precision="float64"):
    """``(op, op32)``: the float64 compliance operator and, for ``precision="float32"``, its
    single-precision twin for :func:`solve_pk`'s ``conv32`` (else None)."""
    op = compliance_operator(shape, dx, dy, layer, model, truncation)
    if precision not in PRECISIONS:
        raise InputError(f"precision must be one of {', '.join(PRECISIONS)}, got {precision!r}", key="precision")
    op32 = compliance_operator(shape, dx, dy, layer, model, truncation, np.float32) if precision == "float32" else None
    return op, op32


def spreading_operator(shape, dx, dy, h, kind="boussinesq", poisson=0.49, base="bonded"):
    """Cached ``sigma_h = B p`` (stress at depth h from surface pressure, both Pa), exact (padded)."""
    if kind not in SPREADINGS:
        raise InputError(f"spreading must be one of {', '.join(SPREADINGS)}, got {kind!r}", key="spreading")
    return _cached_convolver(f"spread:{kind}", tuple(int(s) for s in shape), float(dx), float(dy), 1.0,
                             round(float(poisson), 6), float(h), base)


@dataclass
class ContactSolution:
    """Solution of one contact problem on a grid.

    pressure : (mx, my) Pa. displacement : (mx, my) m, surface displacement (positive
    = pushed into the layer). approach : m, rigid approach of the object measured
    from the gap's zero. iterations : int. converged : bool. residual : float.
    """

    pressure: np.ndarray
    displacement: np.ndarray
    approach: float
    iterations: int
    converged: bool
    residual: float
    #: largest kernel value the operator dropped, relative to its peak (0: exact, padded)
    truncation: float = 0.0
    #: iterations run with the single-precision operator (included in ``iterations``)
    iterations_float32: int = 0


def solve_local(gap, stiffness, cell_area, *, force=None, approach=None):
    """Winkler layer: ``p = stiffness * max(approach - gap, 0)``; exact force control by sorting.

    gap : (...) metres (inf where nothing can touch). stiffness : Pa/m. cell_area : m^2.
    """
    g = np.asarray(gap, float)
    if force is not None:
        fin = np.sort(g[np.isfinite(g)].ravel())
        if force <= 0 or len(fin) == 0:
            d = fin[0] if len(fin) else 0.0
        else:
            # F(d) = k a sum_{g_i < d} (d - g_i), piecewise linear and increasing
            cs = np.concatenate([[0.0], np.cumsum(fin)])
            n = np.arange(1, len(fin) + 1)
            f_at = stiffness * cell_area * (n * fin - cs[1:])  # force when d = fin[i]
            i = int(np.searchsorted(f_at, force))
            m = min(max(i, 1), len(fin))  # cells in contact
            d = (force / (stiffness * cell_area) + cs[m]) / m
        approach = d
    p = stiffness * np.clip(approach - g, 0.0, None)
    p[~np.isfinite(p)] = 0.0
    return ContactSolution(p, np.where(p > 0, p / stiffness, 0.0), float(approach), 1, True, 0.0)


def _pk_start(h, mask, cell_area, force, approach, p0):
    """Starting pressure (mx, my) Pa of :func:`solve_pk`: the warm start ``p0`` where it has contact, else
    the cells that touch first (load control, scaled to ``force``) or the rigid overlap (displacement
    control, ``approach`` m); None when nothing overlaps under displacement control.

    h : (mx, my) m, the gap with 0 where nothing can touch; mask : (mx, my) bool, where it can.
    """
    load = force is not None
    if p0 is not None and np.shape(p0) == h.shape and np.any(p0 > 0):
        p = np.where(mask, np.clip(p0, 0, None), 0.0)
    elif load:
        # start on the cells that would touch first: a Winkler guess is a good basin
        near = mask & (h <= h[mask].min() + 1e-12 + 0.25 * (np.ptp(h[mask]) if mask.sum() > 1 else 0))
        p = np.where(near, 1.0, 0.0)
    else:
        p = np.where(mask & (h < approach), approach - h, 0.0)
        if not p.any():
            return None
    if load:
        p *= force / (p.sum() * cell_area)
    return p


def _pk_iterate(conv, h, mask, p, cell_area, force, approach, tol, maxiter):
    """The Polonsky-Keer iterations of :func:`solve_pk` from the starting pressure ``p`` (mx, my) Pa.

    Returns (pressure, flat (mx * my,) Pa, iterations run, last relative change).
    """
    load = force is not None
    # The iteration works on flat index sets of the contact cells: only the displacement and the
    # search for penetrating cells need the whole grid, so the non-FFT work per iteration is a few
    # passes over the grid instead of ~30 (it was a third of the solve once the transforms shrank).
    shape, my = h.shape, h.shape[1]
    hf, maskf = h.ravel(), mask.ravel()
    p = np.ascontiguousarray(p, dtype=float).ravel()
    t = np.zeros_like(hf)
    delta, g_old = 0.0, 1.0
    it, eps = 0, np.inf
    for it in range(1, maxiter + 1):
        g = np.add(conv(p.reshape(shape)), h).ravel()   # gap after deformation
        if not load:
            g -= approach
        ic = np.flatnonzero(p > 0)
        if not ic.size:
            ic = np.flatnonzero(maskf & (g <= g[maskf].min()))
        gi = g[ic]
        shift = float(gi.mean()) if load else 0.0        # load control: the rigid approach
        if load:
            gi -= shift
        G = float(np.sum(gi ** 2))
        ti = gi + delta * (G / g_old) * t[ic]
        t.fill(0.0)
        t[ic] = ti
        g_old = max(G, 1e-300)
        ri = conv(t.reshape(shape))[ic // my, ic % my]
        if load:
            ri = ri - ri.mean()
        den = float(np.sum(ri * ti))
        tau = float(np.sum(gi * ti)) / den if den != 0 else 0.0
        p_old = p.copy()
        p[ic] -= tau * ti
        np.maximum(p, 0.0, out=p)
        cand = np.flatnonzero((g < shift) & maskf)         # cells the object penetrates ...
        iol = cand[p[cand] == 0]                           # ... without pressure on them
        if iol.size:
            delta = 0.0
            p[iol] -= tau * (g[iol] - shift)
        else:
            delta = 1.0
        if load:
            tot = p.sum() * cell_area
            if tot <= 0:
                p.fill(0.0)
                p[ic] = 1.0
                tot = p.sum() * cell_area
            p *= force / tot
            eps = np.abs(p - p_old).sum() * cell_area / force
        else:
            ref = max(np.abs(p).sum(), 1e-300)
            eps = np.abs(p - p_old).sum() / ref
        if eps < tol:
            break
    return p, it, eps


def solve_pk(gap, conv, cell_area, *, force=None, approach=None, p0=None, tol=1e-7, maxiter=1000, conv32=None,
             tol32=1e-5):
    """Polonsky-Keer constrained conjugate gradient for a rigid object on an elastic surface.

    gap : (mx, my) metres, initial separation of the object from the undeformed
        surface along the press direction (``inf`` where the object is absent).
    conv : callable, ``u = conv(p)`` surface displacement (m) from pressure (Pa), (mx, my).
    cell_area : m^2. force : N (load control) or approach : m (displacement
    control: the object advanced by ``approach`` beyond the gap's zero).
    p0 : (mx, my) Pa, warm start. tol : relative change of the pressure per iteration.
    conv32 : optional single-precision twin of ``conv``: the iterations run with it down to
        ``max(tol, tol32)``, then continue with ``conv`` from there until ``tol``, so the answer
        is checked (and finished) in double precision.

    Returns ContactSolution with p >= 0, ``gap + u - approach >= 0`` and = 0 where p > 0,
    and ``sum(p) cell_area = force`` under load control.
    """
    if conv32 is not None:
        first = solve_pk(gap, conv32, cell_area, force=force, approach=approach, p0=p0, tol=max(tol, tol32),
                         maxiter=maxiter)
        p1 = first.pressure.astype(float) if first.pressure.any() else p0
        sol = solve_pk(gap, conv, cell_area, force=force, approach=approach, p0=p1, tol=tol, maxiter=maxiter)
        sol.iterations += first.iterations
        sol.iterations_float32 = first.iterations
        return sol
    trunc = float(getattr(conv, "truncation", 0.0))
    g0 = np.asarray(gap, float)
    mask = np.isfinite(g0)
    h = np.where(mask, g0, 0.0)
    if (force is None) == (approach is None):
        raise InputError("give exactly one of force and approach", key="force")
    load = force is not None
    if load and (force <= 0 or not mask.any()):
        z = np.zeros_like(h)
        return ContactSolution(z, z.copy(), float(h[mask].min()) if mask.any() else 0.0, 0, True, 0.0, trunc)
    p = _pk_start(h, mask, cell_area, force, approach, p0)
    if p is None:  # displacement control and nothing touches
        z = np.zeros_like(h)
        return ContactSolution(z, z.copy(), float(approach), 0, True, 0.0, trunc)
    p, it, eps = _pk_iterate(conv, h, mask, p, cell_area, force, approach, tol, maxiter)
    p = p.reshape(h.shape)
    u = np.array(conv(p), dtype=float)
    ic = p > 0
    d = float((h + u)[ic].mean()) if (load and ic.any()) else float(approach if not load else 0.0)
    return ContactSolution(p, u, d, it, bool(eps < tol), float(eps), trunc)
