"""Contact on a curved patch solved in the layout's flat (unrolled) domain: ``press(..., geometry="unrolled")``.

Why. :func:`vtcore.contact.press` solves the contact on the plane normal to the press
direction: the layer's compliance acts along the press direction and the gap is measured
along it. Where the patch is tilted by theta against that plane, the layer is really
compressed along its own normal by ``cos(theta)`` times the interference along the press
direction and pushes back along its normal, so the plane solve over-estimates the
pressure where the patch is tilted, and the taxel discs and the spreading are projected
(foreshortened). Measured on seed 002's curved patch (local model, against a per-point
local model along the true normals on a 0.25 mm unrolled grid; docs/contact.md): 1-2 %
error when pressing along the normal at the contact, 3-7 % at 25 degrees off it, 10-21 %
at 46 degrees, 12 % near the end of the 90-degree arc.

What. The grid lives on the layout's flat coordinates (``Layout.flat``, the exact unrolling
for a developable patch such as seed 002's cylinder; approximate for others). Each cell
gets its point and normal on the end-effector surface by C1 (Clough-Tocher) interpolation
of the taxels' positions and normals over the flat coordinates (linear extrapolation from
the nearest taxels outside their hull). The object moves rigidly along ``u``; with ``g``
the gap along ``-u`` from the cell's outer-surface point (exact for the rigid motion, the
same query as the plane solve, both proximity back-ends) and ``c = n_cell . (-u)``, the
layer's compression along its normal after a travel ``d`` is ``c (d - g)`` (exact where
the object's surface is parallel to the skin at the contact, first order otherwise).
The elastic problem (local, half-space or finite layer) is solved on the flat grid with
that non-uniform approach, the travel ``d`` found by bracketing the force along ``u``,
``F = sum(p c dA)``, and ``dA`` the outer surface's area (longer than the base on a convex
patch by ``1 + h / R``).

Cost: a finite-layer solve per bracketing step (5-15 steps), so several times the plane
solve; the local model stays a single sort.
"""

from __future__ import annotations

import functools

import numpy as np

from ..errors import InputError, UnreachableTargetError
from . import elastic
from .finish import check_compression, finish_press, footprint, moved, press_frame, require_contact, \
    travel_and_indentation
from .fft import one_blas_thread
from .grid import ContactField, digest, grid_cells
from .hyperelastic import contact_solver
from .proximity import envelope_posed
from .roots import illinois

_CACHE: dict = {}


def _surface_map(flat, pos, nrm, U, V):
    """Points (M, 3) and unit normals (M, 3) of the end-effector surface at flat coordinates (U, V)."""
    from scipy.interpolate import CloughTocher2DInterpolator
    from scipy.spatial import cKDTree

    q = np.column_stack([U.ravel(), V.ravel()])
    pts = np.full((len(q), 3), np.nan)
    nr = np.full((len(q), 3), np.nan)
    try:
        pts = CloughTocher2DInterpolator(flat, pos)(q)
        nr = CloughTocher2DInterpolator(flat, nrm)(q)
    except Exception:  # degenerate (collinear) flat coordinates: extrapolate everywhere
        pass
    out = ~np.all(np.isfinite(pts), axis=1) | ~np.all(np.isfinite(nr), axis=1)
    if out.any():
        # outside the taxels' hull: a quadratic patch of the nearest taxel, fitted on its nearest
        # neighbours by vectorised least squares (a tangent plane would put the skin 0.4 mm above a
        # 45 mm cylinder 6 mm beyond the last taxel); its normal from the patch's derivatives
        k = min(10, len(flat))
        tree = cKDTree(flat)
        _, nb = tree.query(flat, k=k)
        d = flat[nb] - flat[:, None, :]                                    # (N, k, 2)
        quad = k >= 6
        A = np.concatenate([d, d ** 2 / 2, d[..., :1] * d[..., 1:]], axis=-1) if quad else d
        B = pos[nb] - pos[:, None, :]                                      # (N, k, 3)
        ata = np.einsum("nki,nkj->nij", A, A) + 1e-14 * np.eye(A.shape[-1])
        coef = np.linalg.solve(ata, np.einsum("nki,nkj->nij", A, B))      # (N, 2 or 5, 3)
        _, i = tree.query(q[out])
        e = q[out] - flat[i]
        c = coef[i]
        if quad:
            ea = np.column_stack([e, e ** 2 / 2, e[:, :1] * e[:, 1:]])
            du = c[:, 0] + e[:, :1] * c[:, 2] + e[:, 1:] * c[:, 4]         # d pos / d u at e
            dv = c[:, 1] + e[:, 1:] * c[:, 3] + e[:, :1] * c[:, 4]
        else:
            ea, du, dv = e, c[:, 0], c[:, 1]
        pts[out] = pos[i] + np.einsum("mi,mij->mj", ea, c)
        m = np.cross(du, dv)
        m *= np.sign(np.einsum("ij,ij->i", m, nrm[i]))[:, None]
        good = np.linalg.norm(m, axis=1) > 0
        nr[out] = np.where(good[:, None], m, nrm[i])
    nr /= np.linalg.norm(nr, axis=1, keepdims=True)
    return pts, nr


def unrolled_skin(layout, h, layer_extent, grid, taxel_radius):
    """The contact grid on the layout's flat coordinates, cached per layout: cell centres ``x, y``,
    outer-surface points ``pts (mx, my, 3)``, normals ``nrm (mx, my, 3)``, outer-surface area per
    flat area ``area_factor (mx, my)`` and the ``skin`` mask (inside the layer's extent)."""
    if layout.flat is None:
        raise InputError("geometry = \"unrolled\" needs the layout's flat coordinates (Layout.flat)",
                         key="geometry")
    flat = np.asarray(layout.flat, float)
    pos = np.asarray(layout.positions, float)
    nrm = np.asarray(layout.normals, float)
    key = (digest(flat, pos, nrm), float(h), layer_extent, grid.spacing, grid.margin, grid.extent,
           float(taxel_radius))
    hit = _CACHE.get(key)
    if hit is not None:
        return hit
    with one_blas_thread():  # cached: the same bits whoever computes it first
        hit = _flat_values(flat, pos, nrm, h, layer_extent, grid, taxel_radius)
    if len(_CACHE) > 8:
        _CACHE.clear()
    _CACHE[key] = hit
    return hit


def _flat_values(flat, pos, nrm, h, layer_extent, grid, taxel_radius):
    """The flat grid's cells, outer-surface points, normals, area factor and skin mask (uncached)."""
    dx = grid.spacing
    lo = flat.min(axis=0) - taxel_radius - grid.margin
    hi = flat.max(axis=0) + taxel_radius + grid.margin
    centre = flat.mean(axis=0)
    extent = grid.extent if grid.extent is not None else layer_extent
    if extent is not None:
        lo, hi = np.minimum(lo, centre - extent), np.maximum(hi, centre + extent)
    X, Y = grid_cells(lo, hi, dx)
    mx, my = X.shape
    base, nr = _surface_map(flat, pos, nrm, X, Y)
    pts = (base + h * nr).reshape(mx, my, 3)
    nr = nr.reshape(mx, my, 3)
    # area of the outer surface per unit flat area, |dS/dx x dS/dy| (1 + h / R on a convex cylinder)
    if mx > 1 and my > 1:
        sx = np.gradient(pts, dx, axis=0)
        sy = np.gradient(pts, dx, axis=1)
        area = np.linalg.norm(np.cross(sx, sy), axis=-1)
    else:
        area = np.ones((mx, my))
    skin = np.ones((mx, my), bool)
    if extent is not None:
        skin &= np.hypot(X - centre[0], Y - centre[1]) <= extent
    return {"x": X[:, 0], "y": Y[0], "X": X, "Y": Y, "pts": pts, "nrm": nr, "area_factor": area, "skin": skin}


def _local_force_travel(g, w, force):
    """Travel d with sum(w (d - g)+) = force (w > 0, weights of the Winkler cells)."""
    o = np.argsort(g)
    gs, ws = g[o], w[o]
    W = np.cumsum(ws)
    S = np.cumsum(ws * gs)
    f_at = W * gs - S                    # force when d = gs[j] (cells 0..j-1 in contact)
    j = int(np.searchsorted(f_at, force))
    m = min(max(j, 1), len(gs))          # cells in contact
    return float((force + S[m - 1]) / W[m - 1])


def press_unrolled(layout, local, scene, pose, layer, *, force, indentation, direction, model, compliance, grid,
                   spread, spreading, samples_per_taxel, taxel_radius, backend, warm_start, tol, maxiter,
                   truncation=None, precision="float64"):
    """:func:`vtcore.contact.press` with ``geometry="unrolled"`` (arguments already checked)."""
    h = layer.thickness
    sk = unrolled_skin(layout, h, layer.extent, grid, taxel_radius)
    u, n, e1, e2 = press_frame(layout, direction)
    pts, dx = sk["pts"], grid.spacing
    gap, c = _cell_gaps(sk, n, e1, e2, local, scene, pose, backend, dx)
    finite = np.isfinite(gap)
    gmin = float(gap[finite].min()) if finite.any() else np.inf
    require_contact(finite, force, u)
    cell = dx * dx
    afac = sk["area_factor"]
    cf = np.where(finite, c, 0.0)
    normal_gap = functools.partial(_normal_gap, gap, finite, cf)
    iters, conv_ok, trunc = 0, True, 0.0
    if not finite.any() or (force is not None and force == 0) or (indentation is not None and indentation == 0):
        pflat = np.zeros_like(gap)
        d = gmin if np.isfinite(gmin) else 0.0
    elif model == "local":
        k = layer.e_star / h
        if force is not None:
            # force along u per cell: k c (d - g) c dA, dA = afac dx^2
            d = _local_force_travel(gap[finite], (k * cf * cf * afac * cell)[finite], force)
        else:
            d = gmin + indentation if indentation is not None else 0.0
        pflat = np.where(finite, k * np.clip(-normal_gap(d), 0.0, None) * afac, 0.0)
    else:
        solver = _FlatSolver(gap, finite, cf, afac, dx, layer, model, tol, maxiter, truncation, precision,
                             warm_start)
        trunc = solver.op.truncation
        d = _solve_travel(solver, gap, finite, cf, afac, cell, gmin, layer, model, force, indentation)
        pflat, iters, conv_ok = solver.pflat, solver.iterations, solver.converged
    pflat = np.where(np.isfinite(pflat) & (pflat > 0), pflat, 0.0)
    p = pflat / afac                          # pressure on the outer surface, Pa
    max_c, bottomed = check_compression(np.where(p > 0, -normal_gap(d), 0.0), h, force, model,
                                        where=" along its normal (unrolled)")
    travel, indent = travel_and_indentation(d, gmin, force, indentation)
    fld = ContactField(sk["x"], sk["y"], np.zeros(3), np.array([1.0, 0, 0]), np.array([0, 1.0, 0]), n,
                       np.zeros_like(gap), np.where(finite, normal_gap(travel), np.inf), p, thickness=h,
                       domain="flat", points_3d=pts)
    return finish_press(layout, fld, pflat * cf, pts, pose=moved(pose, travel, u), u=u, layer=layer,
                        force=float((pflat * cf).sum() * cell), indent=indent, travel=travel,
                        contact_area=float(afac[p > 0].sum() * cell), max_compression=max_c, bottomed=bottomed,
                        model=model, iterations=iters, converged=conv_ok, spread=spread, spreading=spreading,
                        samples_per_taxel=samples_per_taxel, taxel_radius=taxel_radius, compliance=compliance,
                        local=local, truncation=trunc)


def _cell_gaps(sk: dict, n, e1, e2, local, scene, pose, backend, dx: float):
    """``(gap (mx, my) m, c (mx, my))``: each skin cell's gap to the object along ``-u`` from its
    outer-surface point (inf where the object is absent) and the cosine of its tilt against the
    motion. Only cells under the object's footprint (projected along ``u``) are queried."""
    pts, nr = sk["pts"], sk["nrm"]
    c = np.einsum("xyi,i->xy", nr, n)  # cos of the tilt between cell normal and motion
    ok = sk["skin"] & (c > 0.1) & np.all(np.isfinite(pts), axis=-1)
    gap = np.full(c.shape, np.inf)
    b1, b2 = footprint(local, pose, e1, e2)
    p1, p2 = np.einsum("xyi,i->xy", pts, e1), np.einsum("xyi,i->xy", pts, e2)  # einsum: no BLAS threads
    cand = ok & (p1 >= b1.min() - dx) & (p1 <= b1.max() + dx) & (p2 >= b2.min() - dx) & (p2 <= b2.max() + dx)
    if cand.any():
        gap[cand] = envelope_posed(pts[cand], n, local, scene, pose, backend)
    return gap, c


def _normal_gap(gap, finite, cf, d):
    """Gap along each cell's normal after a travel d (inf where the object is absent)."""
    return np.where(finite, cf * (np.where(finite, gap, 0.0) - d), np.inf)


class _FlatSolver:
    """The elastic layer on the flat grid, on a window round the cells the object can meet (padded
    to multiples of 8 for the FFTs). Calling it with a travel ``d`` solves, keeps the pressure per
    flat area in ``pflat`` (the next solve's warm start) and returns the force (N) along the press."""

    def __init__(self, gap, finite, cf, afac, dx, layer, model, tol, maxiter, truncation, precision, warm_start):
        mx, my = gap.shape
        ii, jj = np.nonzero(finite)
        bi, bj = -(-(ii.max() + 1 - ii.min() + 4) // 8) * 8, -(-(jj.max() + 1 - jj.min() + 4) // 8) * 8
        i1, j1 = min(max(ii.min() - 2, 0) + bi, mx), min(max(jj.min() - 2, 0) + bj, my)
        i0, j0 = max(i1 - bi, 0), max(j1 - bj, 0)
        self.win = (slice(i0, i1), slice(j0, j1))
        self.op, self.op32 = elastic.compliance_operators((i1 - i0, j1 - j0), dx, dx, layer, model,
                                                          tol if truncation is None else truncation, precision)
        self.gap, self.finite, self.cf, self.cell = gap, finite, cf, dx * dx
        self.tol, self.maxiter = tol, maxiter
        self.solve = contact_solver(model, layer.thickness)  # the layer model's solver (linear or large-compression)
        self.iterations, self.converged = 0, True
        self.p, self.pflat = None, None
        if warm_start is not None and warm_start.field is not None and warm_start.field.domain == "flat" \
                and warm_start.field.pressure.shape == gap.shape:
            self.p = (warm_start.field.pressure * afac)[self.win]

    def __call__(self, d: float) -> float:
        sol = self.solve(_normal_gap(self.gap, self.finite, self.cf, d)[self.win], self.op, self.cell,
                         approach=0.0, p0=self.p, tol=self.tol, maxiter=self.maxiter, conv32=self.op32)
        self.iterations += sol.iterations
        self.converged = self.converged and sol.converged
        p = np.zeros_like(self.gap)
        p[self.win] = sol.pressure            # force per flat area, along the cell normals
        if p.any():
            self.p = sol.pressure
        self.pflat = p
        return float((p * self.cf).sum() * self.cell)


def _solve_travel(solve: _FlatSolver, gap, finite, cf, afac, cell, gmin, layer, model, force, indentation) -> float:
    """The travel ``d`` (m) of the press: ``gmin + indentation``, or the one whose force is ``force``
    (the local model's travel a bracket start, doubled steps until the force is passed, then
    Illinois). The last solve is at the returned ``d``; ``solve.pflat`` is its pressure."""
    h = layer.thickness
    if force is None:
        d = gmin + indentation if indentation is not None else 0.0
        solve(d)
        return d
    # the local model's travel is a bracket start; the elastic layer is stiffer or softer
    lo, f_lo = gmin, 0.0
    d = _local_force_travel(gap[finite], (layer.e_star / h * cf * cf * afac * cell)[finite], force)
    f = solve(d)
    step = max(d - gmin, 1e-6)
    hi, f_hi = (d, f) if f >= force else (None, None)
    while hi is None:
        lo, f_lo = d, f
        step *= 2
        d = d + step
        if d - gmin > 20 * h:
            raise UnreachableTargetError(
                f"{force} N not reached by a travel of {20 * h * 1e3:.3g} mm (model {model}, unrolled)")
        f = solve(d)
        if f >= force:
            hi, f_hi = d, f
    # F(d) is monotone and piecewise smooth; the last solve is at the returned d
    d, f, _ = illinois(solve, force, lo, f_lo, hi, f_hi, ftol=1e-9 * force, xtol=1e-13, max_steps=60)
    if f > 0:
        solve.pflat = solve.pflat * (force / f)  # removes the last 1e-9 of force mismatch
    return d
