"""Pressing an object onto a skin through a soft layer: the public contact API.

:func:`press` poses a closed object mesh relative to the skin, moves it along the
press direction to a target force (or indentation), solves the elastic contact
on a grid over the layer's outer surface (see :mod:`vtcore.contact.elastic` for
the models and their sources) and reads each taxel as the mean, over its 4 mm
disc, of the stress that reaches the layer's base (Boussinesq spreading through
the thickness h). :func:`probe` finds the force at which the mean sensor
response reaches a target (seed 000's p-bar* = 4000 counts).

Geometry. The press direction ``u`` (default: minus the mean taxel normal) and
two tangents span a plane; the grid lives on it, the skin's outer surface
(taxel positions + h * normals) is a height field over it (a quadratic fit plus
linear interpolation of the residuals, so curved patches keep their shape), and
the gap is measured along ``-u`` between that surface and the posed object
(:func:`vtcore.contact.proximity.lower_envelope`). The flat-layer Green's
function is applied on this plane: fine for patches whose radius of curvature is
large against the contact (the demo's 60 mm), approximate on strongly curved
ones, where taxels facing away from the object (normal . -u < 0.1) read zero.
For those, ``geometry="unrolled"`` solves on the layout's flat coordinates with the
layer compressed along its own normals (:mod:`vtcore.contact.curved`, errors measured
there and in docs/contact.md).
"""

from __future__ import annotations

import numpy as np

from ..errors import InputError
from . import elastic
from .curved import press_unrolled
from .finish import (PressResult, check_compression, finish_press, footprint, moved, press_frame, require_contact,
                     travel_and_indentation)
from .fft import one_blas_thread
from .grid import TAXEL_RADIUS, ContactField, ContactGrid, digest, grid_cells
from .hyperelastic import contact_solver
from .materials import SoftLayer
from .proximity import envelope_posed, prepared_mesh

GEOMETRIES = ("plane", "unrolled")
#: Largest target force press() accepts, N (far past any skin; the solve overflows long before 1e300).
MAX_FORCE_N = 1e9


def _surface_height(xy, z, X, Y):
    """Height field through (xy, z): quadratic least squares + C1 (Clough-Tocher) interpolation of
    the residuals; a piecewise-linear surface would put ridges at the taxel triangles' edges, and a
    sphere pressed on a ridge gives grid-dependent pressure peaks."""
    from scipy.interpolate import CloughTocher2DInterpolator

    def design(x, y):
        cols = [np.ones_like(x), x, y, x * x, x * y, y * y]
        return np.stack(cols[: 6 if len(z) >= 6 else (3 if len(z) >= 3 else 1)], axis=-1)

    A = design(xy[:, 0], xy[:, 1])
    try:
        with np.errstate(all="ignore"):
            coef, *_ = np.linalg.lstsq(A, z, rcond=None)
            base = design(X, Y) @ coef
            res = z - A @ coef
        if not (np.isfinite(base).all() and np.isfinite(res).all()):
            raise np.linalg.LinAlgError
    except np.linalg.LinAlgError:
        # again in units of the patch's own size (a power of two, exact): the x^2 terms of a patch a
        # kilometre across, or heights far off its plane, overflow or stop the SVD converging
        s = 2.0 ** np.round(np.log2(max(float(np.abs(xy).max(initial=0.0)), float(np.abs(z).max(initial=0.0)),
                                        1e-300)))
        As = design(xy[:, 0] / s, xy[:, 1] / s)
        try:
            coef, *_ = np.linalg.lstsq(As, z / s, rcond=None)
        except np.linalg.LinAlgError:
            raise InputError(f"the layer's outer surface over the taxels cannot be fitted (heights up to {s:.3g} m):"
                             " check the layer's thickness and the layout's size", key="thickness") from None
        base = s * (design(X / s, Y / s) @ coef)
        res = z - s * (As @ coef)
    if len(z) >= 4 and np.ptp(xy[:, 0]) > 0 and np.ptp(xy[:, 1]) > 0 and np.abs(res).max() > 1e-12:
        try:
            from scipy.spatial import ConvexHull

            # only cells inside the taxels' hull are interpolated (the rest keeps the smooth fit, as
            # fill_value=0 did): scipy's simplex search falls back to a scan of every triangle for a
            # point outside the hull, 1.9 s for a 100 x 100 grid over 124 taxels against 8 ms here
            eq = ConvexHull(xy).equations
            q = np.column_stack([X.ravel(), Y.ravel()])
            inside = (q @ eq[:, :2].T + eq[:, 2] <= 1e-12 * max(float(np.abs(xy).max()), 1.0)).all(axis=1)
            add = np.zeros(len(q))
            add[inside] = CloughTocher2DInterpolator(xy, res, fill_value=0.0)(q[inside])
            base = base + add.reshape(X.shape)
        except Exception:  # degenerate (collinear) taxels: keep the smooth fit
            pass
    return base


def _grid_blame(rel, e1, e2, span, h) -> tuple[str, str]:
    """The key a too-large grid names: ``thickness`` when the layer's outer surface spreads much wider
    than the taxels themselves (a thick layer over a curved patch), else ``grid.spacing``."""
    bare = np.ptp(np.column_stack([rel @ e1, rel @ e2]), axis=0) if len(rel) else np.zeros(2)
    if h > 0 and np.max(span) > 4 * np.max(bare) + 0.1:
        return "thickness", f", as the outer surface of a layer {h:g} m thick over a curved patch spreads that wide"
    return "grid.spacing", ""


_SKIN_CACHE: dict = {}


def _skin_grid(layout, h, layer_extent, direction, grid, taxel_radius):
    """The grid on the layer's outer surface (frame, cells, surface heights), cached per layout."""
    key = (digest(np.asarray(layout.positions, float), np.asarray(layout.normals, float)), float(h),
           layer_extent, None if direction is None else tuple(np.asarray(direction, float).ravel()),
           grid.spacing, grid.margin, grid.extent, float(taxel_radius))
    hit = _SKIN_CACHE.get(key)
    if hit is not None:
        return hit
    with one_blas_thread():  # cached: the same bits whoever computes it first
        hit = _skin_values(layout, h, layer_extent, direction, grid, taxel_radius)
    if len(_SKIN_CACHE) > 16:
        _SKIN_CACHE.clear()
    _SKIN_CACHE[key] = hit
    return hit


def _skin_values(layout, h, layer_extent, direction, grid, taxel_radius):
    u, n, e1, e2 = press_frame(layout, direction)
    pos = np.asarray(layout.positions, float)
    nrm = np.asarray(layout.normals, float)
    with np.errstate(over="ignore", invalid="ignore"):
        outer = pos + h * nrm
    if not np.isfinite(outer).all() or np.abs(outer).max() > 1e6:
        raise InputError(f"a layer {h:g} m thick puts its outer surface beyond any skin ({np.abs(outer).max():.3g} m "
                         "from the taxels' origin)", key="thickness")
    facing = nrm @ n > 0.1
    if not facing.any():
        raise InputError("no taxel faces the press direction", key="direction")
    origin = outer[facing].mean(axis=0)
    rel = outer[facing] - origin
    xy, z = np.column_stack([rel @ e1, rel @ e2]), rel @ n
    dx = grid.spacing
    lo = xy.min(axis=0) - taxel_radius - grid.margin
    hi = xy.max(axis=0) + taxel_radius + grid.margin
    extent = grid.extent if grid.extent is not None else layer_extent
    if extent is not None:
        lo = np.minimum(lo, -extent)
        hi = np.maximum(hi, extent)
    X, Y = grid_cells(lo, hi, dx, *_grid_blame(pos[facing] - origin, e1, e2, hi - lo, h))
    mx, my = X.shape
    S = _surface_height(xy, z, X, Y)
    skin = np.ones_like(X, dtype=bool)
    if extent is not None:
        skin &= np.hypot(X, Y) <= extent
    pts = origin + X[..., None] * e1 + Y[..., None] * e2 + S[..., None] * n
    return {"u": u, "n": n, "e1": e1, "e2": e2, "origin": origin, "x": X[:, 0], "y": Y[0], "X": X, "Y": Y, "S": S,
            "skin": skin, "pts": pts}


def _check_press_args(force, indentation, layer, pose, spreading, model, geometry, precision) -> np.ndarray:
    """Raise InputError (naming the key and what is valid) for a bad argument of :func:`press`;
    returns the pose as a (4, 4) float array."""
    if spreading not in elastic.SPREADINGS:
        raise InputError(f"spreading must be one of {', '.join(elastic.SPREADINGS)}, got {spreading!r}",
                         key="spreading")
    if model not in elastic.MODELS:
        raise InputError(f"model must be one of {', '.join(elastic.MODELS)}, got {model!r}", key="model")
    if force is not None and indentation is not None:
        raise InputError("give force or indentation, not both", key="force")
    if force is not None and not (np.isfinite(force) and 0 <= force <= MAX_FORCE_N):
        # past ~1e12 N the solve's products overflow and it reported force 0 (issue 13)
        raise InputError(f"must be a force in [0, {MAX_FORCE_N:g}] N, got {force}", key="force")
    if indentation is not None and not (np.isfinite(indentation) and indentation >= 0):
        raise InputError(f"must be >= 0 m, got {indentation}", key="indentation")
    if not isinstance(layer, SoftLayer):
        raise InputError("layer must be a vtcore.contact.SoftLayer", key="layer")
    if layer.thickness <= 0:
        raise InputError("press needs a soft layer of thickness > 0", key="layer.thickness")
    pose = np.asarray(pose, float).reshape(4, 4)
    if not np.all(np.isfinite(pose)):
        raise InputError("pose has non-finite entries", key="pose")
    if geometry not in GEOMETRIES:
        raise InputError(f"geometry must be one of {', '.join(GEOMETRIES)}, got {geometry!r}", key="geometry")
    if precision not in elastic.PRECISIONS:
        raise InputError(f"precision must be one of {', '.join(elastic.PRECISIONS)}, got {precision!r}",
                         key="precision")
    return pose


def _object_gap(sk, local, scene, pose, backend, dx) -> np.ndarray:
    """Gap (mx, my), m, along ``-u`` from each cell of the skin grid ``sk`` to the posed object; inf
    where the object is not above the cell."""
    xs, ys, S, n = sk["x"], sk["y"], sk["S"], sk["n"]
    gap = np.full(S.shape, np.inf)
    # only cells under the object's footprint can meet it: cast rays there alone (a window of
    # the regular grid, found by bisection rather than comparing every cell)
    bx, by = footprint(local, pose, sk["e1"], sk["e2"], sk["origin"])
    wx = slice(int(np.searchsorted(xs, bx.min() - dx, side="left")),
               int(np.searchsorted(xs, bx.max() + dx, side="right")))
    wy = slice(int(np.searchsorted(ys, by.min() - dx, side="left")),
               int(np.searchsorted(ys, by.max() + dx, side="right")))
    win = sk["skin"][wx, wy]
    if win.any():
        sub = np.full(win.shape, np.inf)
        sub[win] = envelope_posed(sk["pts"][wx, wy][win], n, local, scene, pose, backend)
        gap[wx, wy] = sub
    return gap


def _contact_box(sel, shape) -> tuple[int, int, int, int]:
    """Index box (i0, i1, j0, j1) around the cells ``sel`` (2 cells of padding), rounded up to
    multiples of 8 cells so trajectories reuse cached kernels."""
    mx, my = shape
    ii, jj = np.nonzero(sel)
    pad = 2
    i0, i1 = max(ii.min() - pad, 0), min(ii.max() + pad + 1, mx)
    j0, j1 = max(jj.min() - pad, 0), min(jj.max() + pad + 1, my)
    bi, bj = -(-(i1 - i0) // 8) * 8, -(-(j1 - j0) // 8) * 8
    i1, j1 = min(i0 + bi, mx), min(j0 + bj, my)
    i0, j0 = max(i1 - bi, 0), max(j1 - bj, 0)
    return i0, i1, j0, j1


def _solve_cropped(gap, finite, gmin, layer, model, dx, *, force, target_d, warm_start, tol, maxiter,
                   truncation, precision):
    """Elastic contact solve on the smallest box of cells that can touch, grown until every cell
    outside it stays clear of the object.

    gap : (mx, my) m, inf off the object; finite : its finite cells; gmin : its smallest value, m.
    Returns (pressure (mx, my) Pa, approach m, iterations, converged, kernel truncation).
    """
    h, area = layer.thickness, dx * dx
    iters, conv_ok, trunc = 0, True, 0.0
    # crop to the cells that can touch: contact cells have gap <= approach
    est = elastic.solve_local(gap, layer.e_star / h, area, force=force, approach=target_d).approach
    thresh = max(est, gmin) + 2 * dx + 0.5 * max(est - gmin, 0.0)
    p0_full = warm_start.field.pressure if (warm_start is not None and warm_start.field is not None and
                                            warm_start.field.pressure.shape == gap.shape) else None
    for _ in range(8):
        sel = finite & (gap <= thresh)
        if p0_full is not None:
            sel |= p0_full > 0
        if not sel.any():
            p, d = np.zeros_like(gap), (target_d or 0.0)
            break
        i0, i1, j0, j1 = _contact_box(sel, gap.shape)
        sub = gap[i0:i1, j0:j1]
        op, op32 = elastic.compliance_operators(sub.shape, dx, dx, layer, model,
                                                tol if truncation is None else truncation, precision)
        p0 = p0_full[i0:i1, j0:j1] if p0_full is not None else None
        sol = contact_solver(model, h)(sub, op, area, force=force, approach=target_d, p0=p0, tol=tol,
                                       maxiter=maxiter, conv32=op32)
        iters += sol.iterations
        trunc = sol.truncation
        conv_ok = sol.converged
        p = np.zeros_like(gap)
        p[i0:i1, j0:j1] = sol.pressure
        d = sol.approach
        # every cell outside the box must stay clear of the object
        outside = finite.copy()
        outside[i0:i1, j0:j1] = False
        if not (outside & (gap < d)).any():
            break
        thresh = d + 2 * dx + (d - gmin)
    return p, d, iters, conv_ok, trunc


def _solve_contact(gap, finite, gmin, layer, model, dx, *, force, indentation, **solve):
    """Pressure on the grid for a target force, an indentation or the pose as it is.

    Returns (pressure (mx, my) Pa, approach m, iterations, converged, kernel truncation)."""
    h, area = layer.thickness, dx * dx
    if not finite.any() or (force is not None and force == 0) or (indentation is not None and indentation == 0):
        return np.zeros_like(gap), (gmin if np.isfinite(gmin) else 0.0), 0, True, 0.0
    target_d = None if force is not None else (gmin + indentation if indentation is not None else 0.0)
    if model == "local":
        sol = elastic.solve_local(gap, layer.e_star / h, area, force=force, approach=target_d)
        return sol.pressure, sol.approach, 0, True, 0.0
    return _solve_cropped(gap, finite, gmin, layer, model, dx, force=force, target_d=target_d, **solve)


def press(layout, mesh, pose, layer: SoftLayer, *, force=None, indentation=None, direction=None,
          model: str = "finite_layer", compliance=None, grid: ContactGrid | None = None,
          spread: bool = True, spreading: str = "layer", samples_per_taxel: int = 7, taxel_radius: float = TAXEL_RADIUS,
          backend: str | None = None, open_mesh: str = "error", warm_start: PressResult | None = None,
          tol: float = 1e-7, maxiter: int = 1000, geometry: str = "plane", truncation: float | None = None,
          precision: str = "float64") -> PressResult:
    """Press ``mesh`` onto the skin of ``layout`` through ``layer``.

    layout : vtcore.layout.Layout (positions, normals (N, 3), end-effector frame, metres).
    mesh : trimesh.Trimesh, closed (see ``open_mesh``), any float dtype, metres, object frame.
    pose : (4, 4), the object's pose in the end-effector frame before pressing.
    layer : SoftLayer. force : N, target total normal force; or indentation : m,
        travel beyond first contact; neither: the pose is used as it is.
    direction : (3,), the object's motion (default: minus the mean taxel normal).
    model : "finite_layer" (default), "halfspace" or "local" (Winkler, E*/h).
    compliance : object stiffness in N/m in series with the layer: a number, a
        callable ``(points (M, 3) object frame) -> (M,)`` or per-vertex values (V,).
    grid : ContactGrid. spread : spread the surface pressure to the taxels' depth.
    spreading : "layer" (exact base stress of the layer on its rigid base, default) or
        "boussinesq" (half-space stress at depth h, half-maximum width 1.13 h).
    samples_per_taxel : points averaged over each 4 mm taxel disc.
    backend : proximity back-end ("open3d" / "numpy"). warm_start : a previous
        PressResult on the same layout (trajectories).
    geometry : "plane" (default: the contact is solved on the plane normal to the press
        direction, fast, exact for flat patches) or "unrolled" (solved on the layout's flat
        coordinates with the layer compressed along its own normals; for strongly curved
        patches, see :mod:`vtcore.contact.curved`).
    truncation : largest kernel value the compliance operator may drop, relative to its peak, to
        shrink its transforms (None: the solver tolerance ``tol``, so the cut stays at the level of
        the solve's own error; 0: the exact, fully padded convolution, the reference). Only a kernel
        that decays within the grid (a layer: within a few thicknesses) is cut; what was dropped is
        reported as ``PressResult.kernel_truncation``.
    precision : "float64" (default) or "float32": the solver's iterations run with single-precision
        transforms, then finish in double precision to ``tol`` (see ``elastic.solve_pk``).

    Raises UnreachableTargetError when the force cannot be reached: the object
    misses the skin, or the layer would be compressed through its whole thickness.
    """
    pose = _check_press_args(force, indentation, layer, pose, spreading, model, geometry, precision)
    h = layer.thickness
    grid = grid or ContactGrid()
    local, scene = prepared_mesh(mesh, open_mesh)
    if geometry == "unrolled":
        return press_unrolled(layout, local, scene, pose, layer, force=force, indentation=indentation,
                              direction=direction, model=model, compliance=compliance, grid=grid, spread=spread,
                              spreading=spreading, samples_per_taxel=samples_per_taxel, taxel_radius=taxel_radius,
                              backend=backend, warm_start=warm_start, tol=tol, maxiter=maxiter,
                              truncation=truncation, precision=precision)
    sk = _skin_grid(layout, h, layer.extent, direction, grid, taxel_radius)
    u, dx = sk["u"], grid.spacing
    gap = _object_gap(sk, local, scene, pose, backend, dx)
    finite = np.isfinite(gap)
    area = dx * dx
    fld = ContactField(sk["x"], sk["y"], sk["origin"], sk["e1"], sk["e2"], sk["n"], sk["S"], gap, np.zeros_like(gap),
                       thickness=h)
    gmin = float(gap[finite].min()) if finite.any() else np.inf
    require_contact(finite, force, u)
    p, d, iters, conv_ok, trunc = _solve_contact(gap, finite, gmin, layer, model, dx, force=force,
                                                 indentation=indentation, warm_start=warm_start, tol=tol,
                                                 maxiter=maxiter, truncation=truncation, precision=precision)
    p = np.where(np.isfinite(p) & (p > 0), p, 0.0)
    fld.pressure = p
    max_c, bottomed = check_compression(np.where(p > 0, d - np.where(finite, gap, d), 0.0), h, force, model)
    travel, indent = travel_and_indentation(d, gmin, force, indentation)
    fld.gap = np.where(finite, gap - travel, np.inf)
    return finish_press(layout, fld, p, sk["pts"], pose=moved(pose, travel, u), u=u, layer=layer,
                        force=float(p.sum() * area), indent=indent, travel=travel,
                        contact_area=float((p > 0).sum() * area), max_compression=max_c, bottomed=bottomed,
                        model=model, iterations=iters, converged=conv_ok, spread=spread, spreading=spreading,
                        samples_per_taxel=samples_per_taxel, taxel_radius=taxel_radius, compliance=compliance,
                        local=local, truncation=trunc)


def press_sequence(layout, mesh, poses, layer: SoftLayer, *, force=None, indentation=None, **kw):
    """Press along a trajectory, warm-starting each frame from the previous one.

    poses : (T, 4, 4). force, indentation : None, a number or (T,) per frame.
    Other keywords as :func:`press`. Returns a list of T PressResults.
    """
    poses = np.asarray(poses, float).reshape(-1, 4, 4)
    t = len(poses)
    fs = [None] * t if force is None else list(np.broadcast_to(np.asarray(force, float), (t,)))
    ds = [None] * t if indentation is None else list(np.broadcast_to(np.asarray(indentation, float), (t,)))
    from .._progress import progress

    out, prev = [], None
    for i in progress(range(t), desc="pressing frames", total=t, unit="frame"):
        prev = press(layout, mesh, poses[i], layer, force=fs[i], indentation=ds[i], warm_start=prev, **kw)
        out.append(prev)
    return out
