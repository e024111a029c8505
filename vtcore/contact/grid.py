"""The contact grid and what is read from it, shared by both press solvers (plane and unrolled).

:class:`ContactGrid` (resolution and extent), :class:`ContactField` (the solved contact on the
grid), :func:`grid_cells` (cell centres of a box), :func:`disc_offsets` (points covering a taxel
disc), bilinear reading of a grid field (:func:`sample_bilinear`, :func:`bilinear_matrix`), the
per-taxel disc means (:func:`taxel_sampler`, :func:`taxel_means`, :func:`taxel_readings`), the
stress spread through the layer (:func:`spread_field`) and :func:`digest`, the content key of the
caches that keep what stays fixed along a trajectory.
"""

from __future__ import annotations

import contextlib
import contextvars
import time
from dataclasses import dataclass

import numpy as np

from ..errors import InputError
from . import elastic
from .fft import one_blas_thread
from .materials import SoftLayer

TAXEL_RADIUS = 2e-3  # m, CySkin taxels are 4 mm discs (seed 000, 001)
#: Largest grid spacing and margin, m: a cell a metre wide says nothing about a 4 mm taxel.
MAX_SPACING_M = 1.0


@dataclass
class ContactGrid:
    """Resolution and extent of the contact grid on the skin's outer surface.

    spacing : m, cell size. margin : m of skin simulated beyond the outermost
    taxel discs. extent : m or None, radius of the layer around the patch centre
    (e.g. 0.04 for seed 001's 80 mm disc); None: the taxels' bounding box + margin.
    """

    spacing: float = 1e-3
    margin: float = 4e-3
    extent: float | None = None

    def __post_init__(self):
        for k in ("spacing", "margin"):
            v = float(getattr(self, k))
            if not (v > 0 if k == "spacing" else v >= 0) or not np.isfinite(v):
                raise InputError(f"must be {'> 0' if k == 'spacing' else '>= 0'} m, got {v}", key=f"grid.{k}")
            if v > MAX_SPACING_M:  # cells a metre wide average nothing over 4 mm taxels; 1e308 overflowed
                raise InputError(f"must be <= {MAX_SPACING_M:g} m, got {v:g}", key=f"grid.{k}")
            setattr(self, k, v)
        if self.extent is not None and not float(self.extent) > 0:
            raise InputError(f"must be > 0 m, got {self.extent}", key="grid.extent")


@dataclass
class ContactField:
    """The contact on the grid: everything needed to re-read or re-spread it.

    x (mx,), y (my,) : m, cell centres along e1, e2. origin (3,) m; e1, e2, n (3,):
    the grid frame (n = -press direction). surface (mx, my) : m, height of the
    layer's outer surface along n. gap (mx, my) : m, object above the surface
    along n at the solution pose before deformation (inf: no object; negative:
    interference). pressure (mx, my) : Pa on the surface. stress (mx, my) or None :
    Pa at depth h. thickness : m, the layer's (taxels are read below the surface point
    above them along their normal).
    """

    x: np.ndarray
    y: np.ndarray
    origin: np.ndarray
    e1: np.ndarray
    e2: np.ndarray
    n: np.ndarray
    surface: np.ndarray
    gap: np.ndarray
    pressure: np.ndarray
    stress: np.ndarray | None = None
    thickness: float = 0.0
    #: "plane": x, y are coordinates on the plane normal to the press direction (e1, e2, origin);
    #: "flat": x, y are the layout's flat (unrolled) coordinates, see vtcore.contact.curved
    domain: str = "plane"
    #: (mx, my, 3) m, the outer-surface points (flat domain; None: derived from the plane)
    points_3d: np.ndarray | None = None

    @property
    def spacing(self) -> float:
        return float(self.x[1] - self.x[0]) if len(self.x) > 1 else 0.0

    def points(self) -> np.ndarray:
        """(mx, my, 3) m, the grid's points on the layer's outer surface."""
        if self.points_3d is not None:
            return self.points_3d
        X, Y = np.meshgrid(self.x, self.y, indexing="ij")
        return (self.origin + X[..., None] * self.e1 + Y[..., None] * self.e2
                + self.surface[..., None] * self.n)

    def taxel_xy(self, layout) -> np.ndarray:
        """(N, 2) m, where each taxel's disc centre lies in the grid's (x, y) coordinates: its flat
        coordinates in the flat domain, else the projection of the point above it on the outer surface."""
        if self.domain == "flat":
            return np.asarray(layout.flat, float)
        rel = np.asarray(layout.positions, float) + self.thickness * np.asarray(layout.normals, float) - self.origin
        return np.column_stack([rel @ self.e1, rel @ self.e2])


def digest(*arrays) -> int:
    """CRC-32 of the arrays' bytes and shapes: the cache key of what a layout or grid derives."""
    import zlib

    c = 0
    for a in arrays:
        a = np.ascontiguousarray(a)
        c = zlib.crc32(a.view(np.uint8).reshape(-1), c)
        c = zlib.crc32(str(a.shape).encode(), c)
    return c


#: Most cells of one contact grid (2000 x 2000: a 2 m patch at 1 mm); raise ``grid.spacing`` instead.
MAX_GRID_CELLS = 4_000_000
#: Live (mx, my) float64 arrays at the peak of a press on the grid (cell centres, surface, gap,
#: pressure, stress, the (mx, my, 3) points, and the FFT solver's zero-padded 2x2 copies): a generous
#: count, not a measurement, so the guard errs towards refusing early.
GRID_COPIES = 48


def grid_cells(lo, hi, dx, key: str = "grid.spacing", why: str = ""):
    """Cell centres ``X, Y`` (mx, my) metres of a grid of spacing ``dx`` covering [lo, hi] (2,).

    An even number of cells centred on the box: cell centres sit half a cell off the
    box's axes, so the edges of objects centred on the patch fall between cells.
    The number of cells is counted in floating point first (a span of 1e9 m at 1 mm is 1e24
    cells, which wraps round in int64) and held to :data:`MAX_GRID_CELLS` and the memory budget
    (:func:`vtcore.inputs.need_memory`), before anything is allocated; the InputError names ``key``
    (the setting that makes the grid so large) and says ``why`` the grid spans what it spans.
    """
    from ..inputs import need_memory

    with np.errstate(over="ignore", divide="ignore", invalid="ignore"):
        span = np.asarray(hi, dtype=np.float64) - np.asarray(lo, dtype=np.float64)
        cells = 2.0 * np.maximum(np.ceil(span / dx / 2.0), 1.0)  # (2 * dx overflows at 1e308)
    total = float(np.prod(cells)) if np.isfinite(cells).all() else float("inf")
    what = (f"a contact grid of {cells[0]:.3g} x {cells[1]:.3g} cells ({span[0]:.3g} m x {span[1]:.3g} m at "
            f"{dx:.3g} m){why}")
    if not total <= MAX_GRID_CELLS:
        raise InputError(f"{what} is more than the {MAX_GRID_CELLS:,} cells a grid may have; raise the grid "
                         "spacing", key=key)
    need_memory(8.0 * GRID_COPIES * total, key=key, what=what)
    mx, my = (int(c) for c in cells)
    cx, cy = (np.asarray(lo) + np.asarray(hi)) / 2
    xs = cx + dx * (np.arange(mx) - (mx - 1) / 2)
    ys = cy + dx * (np.arange(my) - (my - 1) / 2)
    return np.meshgrid(xs, ys, indexing="ij")


def disc_offsets(samples: int, radius: float = TAXEL_RADIUS) -> np.ndarray:
    """(S, 2) m, ``samples`` points covering a disc evenly (the centre, then a sunflower spiral)."""
    if samples < 1:
        raise InputError(f"must be >= 1, got {samples}", key="samples_per_taxel")
    if samples == 1:
        return np.zeros((1, 2))
    k = np.arange(samples)
    r = radius * np.sqrt((k + 0.5) / samples)
    a = k * np.pi * (3 - np.sqrt(5))
    return np.column_stack([r * np.cos(a), r * np.sin(a)])


def sample_bilinear(field_xy, values, x, y):
    """Bilinear interpolation of cell-centred ``values`` (mx, my) at points (..., 2); 0 outside."""
    from scipy.ndimage import map_coordinates

    dx = x[1] - x[0] if len(x) > 1 else 1.0
    dy = y[1] - y[0] if len(y) > 1 else 1.0
    ci = (field_xy[..., 0] - x[0]) / dx
    cj = (field_xy[..., 1] - y[0]) / dy
    return map_coordinates(values, [ci.ravel(), cj.ravel()], order=1, mode="constant", cval=0.0).reshape(ci.shape)


def bilinear_matrix(field_xy, x, y, weights=None):
    """Sparse (M, mx*my) matrix of :func:`sample_bilinear`'s bilinear interpolation (zero outside, as
    ``map_coordinates(order=1, mode="constant")``), so a fixed set of points is read from any
    field with one sparse product instead of re-deriving the weights per frame.

    field_xy : (M, S, 2) m, S points per row averaged with ``weights`` (S,) (default: uniform).
    """
    from scipy.sparse import csr_matrix

    m, k = field_xy.shape[:2]
    mx, my = len(x), len(y)
    dx = x[1] - x[0] if mx > 1 else 1.0
    dy = y[1] - y[0] if my > 1 else 1.0
    ci = (field_xy[..., 0] - x[0]) / dx
    cj = (field_xy[..., 1] - y[0]) / dy
    # mode="constant": a point outside [0, n - 1] in either index reads 0 (no partial cells)
    valid = (ci >= 0) & (ci <= mx - 1) & (cj >= 0) & (cj <= my - 1)
    i0 = np.clip(np.floor(ci), 0, max(mx - 2, 0))
    j0 = np.clip(np.floor(cj), 0, max(my - 2, 0))
    fi, fj = ci - i0, cj - j0
    w = np.full(k, 1.0 / k) if weights is None else np.asarray(weights, float)
    rows, cols, vals = [], [], []
    row = np.broadcast_to(np.arange(m)[:, None], (m, k))
    for di, wi in ((0, 1 - fi), (1, fi)):
        for dj, wj in ((0, 1 - fj), (1, fj)):
            ii, jj = (i0 + di).astype(np.int64), (j0 + dj).astype(np.int64)
            ok = valid & (ii < mx) & (jj < my) & (wi * wj != 0)
            rows.append(row[ok])
            cols.append(ii[ok] * my + jj[ok])
            vals.append((wi * wj * w[None, :])[ok])
    a = csr_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))), shape=(m, mx * my))
    a.sum_duplicates()
    return a


_SAMPLER_CACHE: dict = {}


def taxel_sampler(layout, fld: ContactField, samples_per_taxel=7, radius=TAXEL_RADIUS):
    """Sparse (N, mx*my) matrix that averages a grid field over each taxel's disc (zero rows for
    taxels facing away), cached per layout, grid and sampling: built once along a trajectory."""
    pos = np.asarray(layout.positions, float)
    nrm = np.asarray(layout.normals, float)
    flat = fld.domain == "flat"
    key = (digest(pos, nrm, fld.origin, fld.e1, fld.e2, fld.n, *([layout.flat] if flat else [])), fld.domain,
           float(fld.x[0]), float(fld.y[0]), len(fld.x), len(fld.y), fld.spacing, float(fld.thickness),
           int(samples_per_taxel), float(radius))
    a = _SAMPLER_CACHE.get(key)
    if a is None:
        with one_blas_thread():  # cached: the same bits whoever computes it first
            a = _sampler(layout, fld, samples_per_taxel, radius, pos, nrm, flat)
        if len(_SAMPLER_CACHE) > 32:
            _SAMPLER_CACHE.clear()
        _SAMPLER_CACHE[key] = a
    return a


def _sampler(layout, fld, samples_per_taxel, radius, pos, nrm, flat):
    """The (N, mx*my) disc-averaging matrix behind :func:`taxel_sampler` (uncached)."""
    pts = fld.taxel_xy(layout)[:, None, :] + disc_offsets(samples_per_taxel, radius)[None, :, :]
    a = bilinear_matrix(pts, fld.x, fld.y)
    # on the plane, taxels facing away have no point above them; in the flat domain every
    # taxel has its own patch of the layer
    facing = nrm @ fld.n > 0.1 if not flat else np.ones(len(pos), bool)
    if not facing.all():
        from scipy.sparse import diags

        a = (diags(facing.astype(float)) @ a).tocsr()
        a.eliminate_zeros()
    return a


def taxel_means(layout, fld: ContactField, values, samples_per_taxel=7, radius=TAXEL_RADIUS):
    """Mean of a grid field (mx, my) over each taxel's disc -> (N,). Taxels facing away read 0.

    The disc is sampled at ``samples_per_taxel`` points (:func:`disc_offsets`) around the point
    below the taxel on the layer's outer surface, bilinearly (zero outside the grid).
    """
    a = taxel_sampler(layout, fld, samples_per_taxel, radius)
    return a @ np.asarray(values, float).ravel()


def taxel_readings(layout, fld: ContactField, surface_pressure, layer, spread: bool, spreading: str,
                   samples_per_taxel: int, radius: float):
    """Per-taxel ``(surface, taxel)`` pressures (N,) Pa: the surface pressure over each taxel disc,
    and (when ``spread``) the stress carried through the layer to it, else a copy of the surface's.
    Sets ``fld.stress`` when spreading."""
    surf = taxel_means(layout, fld, surface_pressure, samples_per_taxel, radius)
    if not spread:
        return surf, surf.copy()
    fld.stress = spread_field(fld, layer, spreading)
    return surf, taxel_means(layout, fld, fld.stress, samples_per_taxel, radius)


#: The clock of the open :func:`spread_timer` (None: spreading is not timed).
_SPREAD_CLOCK: contextvars.ContextVar = contextvars.ContextVar("vtcore_spread_clock", default=None)


@contextlib.contextmanager
def spread_timer():
    """Time every :func:`spread_field` call made inside the block, wherever it runs (a press, a probe,
    a solver): yields ``{"seconds": float, "calls": int}``, filled as the calls return. A nested
    timer takes the calls of its own block (a scene's soft_layer effect times its own)."""
    clock = {"seconds": 0.0, "calls": 0}
    token = _SPREAD_CLOCK.set(clock)
    try:
        yield clock
    finally:
        _SPREAD_CLOCK.reset(token)


def spread_field(fld: ContactField, layer, spreading: str = "layer") -> np.ndarray:
    """Stress (Pa) at the layer's base under the surface pressure of ``fld``.

    layer : SoftLayer (or a thickness in metres, then Boussinesq is used).
    spreading : "layer" (exact base stress of the layer on its rigid base) or
    "boussinesq" (half-space stress at depth h). Timed by an open :func:`spread_timer`.
    """
    t0 = time.perf_counter()
    try:
        return _spread(fld, layer, spreading)
    finally:
        clock = _SPREAD_CLOCK.get()
        if clock is not None:
            clock["seconds"] += time.perf_counter() - t0
            clock["calls"] += 1


def _spread(fld: ContactField, layer, spreading: str) -> np.ndarray:
    if not isinstance(layer, SoftLayer):
        h, nu, base, spreading = float(layer), 0.49, "bonded", "boussinesq"
    else:
        h, nu, base = layer.thickness, layer.poisson, layer.base
    if h <= 0:
        return fld.pressure.copy()
    dx = fld.spacing or 1.0
    p = fld.pressure
    if spreading == "layer":
        # the layer's base-stress kernel is zero beyond 20 h (elastic.spreading_kernel): the stress of a
        # contact much smaller than the skin is the convolution over a window round it alone, the same
        # numbers (a live drag over a 1,000-taxel skin spent 80 % of each frame on a whole-skin FFT)
        win = _spread_window(p, int(np.ceil(20.0 * h / dx)) + 2)
        if win is not None:
            out = np.zeros_like(p, dtype=float)
            op = elastic.spreading_operator(p[win].shape, dx, dx, h, spreading, nu, base)
            out[win] = op(p[win])
            return out
    op = elastic.spreading_operator(p.shape, dx, dx, h, spreading, nu, base)
    return op(p)


#: window sizes are rounded up to this many cells, so that a moving contact reuses cached operators
_WINDOW_STEP = 16


def _spread_window(p: np.ndarray, reach: int):
    """The (slice, slice) of grid ``p`` holding its non-zero cells plus ``reach`` cells round them, or
    None when that is not much smaller than the grid (or nothing is pressed)."""
    rows = np.flatnonzero(p.any(axis=1))
    if not len(rows):
        return None
    cols = np.flatnonzero(p.any(axis=0))
    box = []
    for lo, hi, n in ((rows[0], rows[-1] + 1, p.shape[0]), (cols[0], cols[-1] + 1, p.shape[1])):
        size = min(-(-(hi - lo + 2 * reach) // _WINDOW_STEP) * _WINDOW_STEP, n)
        start = int(np.clip(lo - reach, 0, n - size))
        box.append(slice(start, start + size))
    cells = (box[0].stop - box[0].start) * (box[1].stop - box[1].start)
    return tuple(box) if cells <= 0.5 * p.size else None

