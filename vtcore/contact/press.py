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

from dataclasses import dataclass
from dataclasses import field as dc_field

import numpy as np

from ..errors import InputError, UnreachableTargetError
from ..geometry import tangent_basis
from . import elastic
from .materials import SoftLayer
from .proximity import lower_envelope, prepare_mesh

TAXEL_RADIUS = 2e-3  # m, CySkin taxels are 4 mm discs (seed 000, 001)
GEOMETRIES = ("plane", "unrolled")


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


@dataclass
class PressResult:
    """Outcome of one press.

    pressure : (N,) Pa, stress at the taxels (base of the layer), mean over each
        taxel's disc (after spreading through the layer when ``spread=True``;
        equal to ``surface_pressure`` otherwise).
    surface_pressure : (N,) Pa on the layer's outer surface above each taxel (disc mean).
    force : N, total normal force. indentation : m, travel of the object beyond first
        contact. contact_area : m^2. pose : (4, 4), the object's pose at the solution.
    travel : m, distance moved along ``direction`` from the given pose.
    displacement : m, end-effector displacement from first contact, = indentation +
        the object's own deflection (object compliance; seed 000 Eq. 1).
    bottomed_out : bool, the layer would be compressed by more than its thickness.
    max_compression : m. model : str. iterations, converged : solver report.
    field : ContactField on the grid. contact_point, contact_point_object : (3,) m,
    the force-weighted centre of the contact in the end-effector / object frame (NaN without contact).
    """

    pressure: np.ndarray
    surface_pressure: np.ndarray
    force: float
    indentation: float
    contact_area: float
    pose: np.ndarray
    travel: float = 0.0
    displacement: float = 0.0
    object_deflection: float = 0.0
    bottomed_out: bool = False
    max_compression: float = 0.0
    model: str = "finite_layer"
    iterations: int = 0
    converged: bool = True
    direction: np.ndarray = dc_field(default_factory=lambda: np.array([0.0, 0.0, -1.0]))
    field: ContactField | None = None
    spread: bool = True
    contact_point: np.ndarray = dc_field(default_factory=lambda: np.full(3, np.nan))
    contact_point_object: np.ndarray = dc_field(default_factory=lambda: np.full(3, np.nan))


def _frame(layout, direction):
    nrm = np.asarray(layout.normals, float)
    if direction is None:
        m = nrm.mean(axis=0)
        if np.linalg.norm(m) < 1e-9:
            raise InputError("taxel normals cancel out; give the press direction explicitly", key="direction")
        u = -m / np.linalg.norm(m)
    else:
        u = np.asarray(direction, float).reshape(3)
        if not np.all(np.isfinite(u)) or np.linalg.norm(u) < 1e-12:
            raise InputError(f"must be a non-zero 3-vector, got {direction}", key="direction")
        u = u / np.linalg.norm(u)
    n = -u
    e1, e2 = tangent_basis(n)
    return u, n, e1, e2


def _surface_height(xy, z, X, Y):
    """Height field through (xy, z): quadratic least squares + C1 (Clough-Tocher) interpolation of
    the residuals; a piecewise-linear surface would put ridges at the taxel triangles' edges, and a
    sphere pressed on a ridge gives grid-dependent pressure peaks."""
    from scipy.interpolate import CloughTocher2DInterpolator

    def design(x, y):
        cols = [np.ones_like(x), x, y, x * x, x * y, y * y]
        return np.stack(cols[: 6 if len(z) >= 6 else (3 if len(z) >= 3 else 1)], axis=-1)

    A = design(xy[:, 0], xy[:, 1])
    coef, *_ = np.linalg.lstsq(A, z, rcond=None)
    base = design(X, Y) @ coef
    res = z - A @ coef
    if len(z) >= 4 and np.ptp(xy[:, 0]) > 0 and np.ptp(xy[:, 1]) > 0 and np.abs(res).max() > 1e-12:
        try:
            base = base + CloughTocher2DInterpolator(xy, res, fill_value=0.0)(X, Y)
        except Exception:  # degenerate (collinear) taxels: keep the smooth fit
            pass
    return base


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


def _sample(field_xy, values, x, y):
    """Bilinear interpolation of cell-centred ``values`` (mx, my) at points (..., 2); 0 outside."""
    from scipy.ndimage import map_coordinates

    dx = x[1] - x[0] if len(x) > 1 else 1.0
    dy = y[1] - y[0] if len(y) > 1 else 1.0
    ci = (field_xy[..., 0] - x[0]) / dx
    cj = (field_xy[..., 1] - y[0]) / dy
    return map_coordinates(values, [ci.ravel(), cj.ravel()], order=1, mode="constant", cval=0.0).reshape(ci.shape)


def _bilinear_matrix(field_xy, x, y, weights=None):
    """Sparse (M, mx*my) matrix of :func:`_sample`'s bilinear interpolation (zero outside, as
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
    key = (_digest(pos, nrm, fld.origin, fld.e1, fld.e2, fld.n, *([layout.flat] if flat else [])), fld.domain,
           float(fld.x[0]), float(fld.y[0]), len(fld.x), len(fld.y), fld.spacing, float(fld.thickness),
           int(samples_per_taxel), float(radius))
    a = _SAMPLER_CACHE.get(key)
    if a is None:
        pts = fld.taxel_xy(layout)[:, None, :] + disc_offsets(samples_per_taxel, radius)[None, :, :]
        a = _bilinear_matrix(pts, fld.x, fld.y)
        # on the plane, taxels facing away have no point above them; in the flat domain every
        # taxel has its own patch of the layer
        facing = nrm @ fld.n > 0.1 if not flat else np.ones(len(pos), bool)
        if not facing.all():
            from scipy.sparse import diags

            a = (diags(facing.astype(float)) @ a).tocsr()
            a.eliminate_zeros()
        if len(_SAMPLER_CACHE) > 32:
            _SAMPLER_CACHE.clear()
        _SAMPLER_CACHE[key] = a
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


def spread_field(fld: ContactField, layer, spreading: str = "layer") -> np.ndarray:
    """Stress (Pa) at the layer's base under the surface pressure of ``fld``.

    layer : SoftLayer (or a thickness in metres, then Boussinesq is used).
    spreading : "layer" (exact base stress of the layer on its rigid base) or
    "boussinesq" (half-space stress at depth h).
    """
    if not isinstance(layer, SoftLayer):
        h, nu, base, spreading = float(layer), 0.49, "bonded", "boussinesq"
    else:
        h, nu, base = layer.thickness, layer.poisson, layer.base
    if h <= 0:
        return fld.pressure.copy()
    dx = fld.spacing or 1.0
    op = elastic.spreading_operator(fld.pressure.shape, dx, dx, h, spreading, nu, base)
    return op(fld.pressure)


def _object_stiffness(compliance, mesh_local, pose, point_world):
    """Stiffness (N/m) of the object at a contact point; None when no compliance is given."""
    if compliance is None:
        return None
    inv = np.linalg.inv(pose)
    p_obj = inv[:3, :3] @ point_world + inv[:3, 3]
    if callable(compliance):
        k = float(np.asarray(compliance(p_obj[None, :]), float).reshape(-1)[0])
    elif np.ndim(compliance) == 0:
        k = float(compliance)
    else:
        vals = np.asarray(compliance, float).reshape(-1)
        if len(vals) != len(mesh_local.vertices):
            raise InputError(f"per-vertex compliance has {len(vals)} values but the mesh has "
                             f"{len(mesh_local.vertices)} vertices", key="compliance")
        from scipy.spatial import cKDTree

        _, i = cKDTree(np.asarray(mesh_local.vertices, float)).query(p_obj, k=min(4, len(vals)))
        k = float(np.mean(vals[np.atleast_1d(i)]))
    if not (k > 0 and np.isfinite(k)):
        raise InputError(f"object stiffness must be > 0 N/m, got {k}", key="compliance")
    return k


# --- caches: what stays fixed along a trajectory is built once ---------------------------

_CORNERS = np.array([[a, b, c] for a in (0, 1) for b in (0, 1) for c in (0, 1)], float)
_MESH_CACHE: dict = {}
_SKIN_CACHE: dict = {}


def _digest(*arrays) -> int:
    import zlib

    c = 0
    for a in arrays:
        a = np.ascontiguousarray(a)
        c = zlib.crc32(a.view(np.uint8).reshape(-1), c)
        c = zlib.crc32(str(a.shape).encode(), c)
    return c


def _prepared(mesh, open_mesh):
    """(checked float64 mesh, lazily built open3d scene holder) for ``mesh``, cached by content."""
    try:  # trimesh keeps a content hash that is cached until the arrays change: ~10 us
        content = hash(mesh)
    except TypeError:
        content = _digest(np.asarray(mesh.vertices), np.asarray(mesh.faces))
    key = (id(mesh), content, open_mesh)
    hit = _MESH_CACHE.get(key)
    if hit is None:
        if len(_MESH_CACHE) > 16:
            _MESH_CACHE.clear()
        hit = (prepare_mesh(mesh, open_mesh=open_mesh), {})
        _MESH_CACHE[key] = hit
    return hit


def _envelope_posed(points, n, local, scene, pose, backend):
    """lower_envelope of the posed mesh, computed in the object's frame (distances are rigid-invariant),
    so the object's BVH is built once per mesh, not once per pose."""
    from .proximity import default_backend

    r, t = pose[:3, :3], pose[:3, 3]
    # einsum, not @: OpenBLAS threads a (M, 3) x (3, 3) product for large M and its idle
    # threads then spin, doubling the CPU time on a shared machine for no gain
    p_obj = np.einsum("mi,ij->mj", np.asarray(points, float) - t, r)
    n_obj = np.asarray(n, float) @ r
    backend = backend or default_backend()
    if backend == "open3d":
        return _envelope_open3d(p_obj, n_obj, local, scene)
    return lower_envelope(p_obj, n_obj, local, backend)


def _envelope_open3d(pts, n, local, holder):
    import open3d as o3d

    if "scene" not in holder:
        v = np.asarray(local.vertices, float)
        f = np.asarray(local.faces, np.int64)
        o = v.mean(axis=0)
        sc = o3d.t.geometry.RaycastingScene()
        sc.add_triangles(o3d.core.Tensor((v - o).astype(np.float32)), o3d.core.Tensor(f.astype(np.uint32)))
        tri = v[f]
        holder.update(scene=sc, o=o, tri=tri, nrm=np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]),
                      radius=float(np.linalg.norm(v - o, axis=1).max()))
    o = holder["o"]
    n = n / np.linalg.norm(n)
    pl = pts - o
    # start every ray below the mesh's bounding sphere (any start below the mesh is exact: t is
    # recomputed in float64 from the hit triangle's plane); cheaper than projecting the vertices
    start = max(0.0, float(np.einsum("mi,i->m", pl, n).max()) + holder["radius"]) + 1e-3
    rays = np.hstack([pl - start * n, np.broadcast_to(n, pl.shape)]).astype(np.float32)
    # few rays (a footprint of a few thousand cells): one thread; waking open3d's pool costs more
    # than the casting on a loaded machine (0.9 ms wall for 0.2 ms of work at 350 rays)
    ans = holder["scene"].cast_rays(o3d.core.Tensor(rays), nthreads=1 if len(rays) < 20000 else 0)
    hit = ans["t_hit"].numpy().astype(np.float64)
    out = np.full(len(pts), np.inf)
    ok = np.isfinite(hit)
    if ok.any():
        prim = ans["primitive_ids"].numpy().astype(np.int64)[ok]
        nrm, a = holder["nrm"][prim], holder["tri"][prim, 0]
        den = np.einsum("mi,i->m", nrm, n)
        good = np.abs(den) > 1e-30
        exact = np.einsum("ij,ij->i", nrm, a - pts[ok]) / np.where(good, den, 1.0)
        out[ok] = np.where(good, exact, hit[ok] - start)  # float64 plane intersection
    return out


def grid_cells(lo, hi, dx):
    """Cell centres ``X, Y`` (mx, my) metres of a grid of spacing ``dx`` covering [lo, hi] (2,).

    An even number of cells centred on the box: cell centres sit half a cell off the
    box's axes, so the edges of objects centred on the patch fall between cells.
    """
    mx, my = 2 * np.ceil((np.asarray(hi) - np.asarray(lo)) / (2 * dx)).astype(int)
    if mx * my > 4_000_000:
        raise InputError(f"grid of {mx} x {my} cells is too large; increase grid.spacing", key="grid.spacing")
    cx, cy = (np.asarray(lo) + np.asarray(hi)) / 2
    xs = cx + dx * (np.arange(mx) - (mx - 1) / 2)
    ys = cy + dx * (np.arange(my) - (my - 1) / 2)
    return np.meshgrid(xs, ys, indexing="ij")


def _skin_grid(layout, h, layer_extent, direction, grid, taxel_radius):
    """The grid on the layer's outer surface (frame, cells, surface heights), cached per layout."""
    key = (_digest(np.asarray(layout.positions, float), np.asarray(layout.normals, float)), float(h),
           layer_extent, None if direction is None else tuple(np.asarray(direction, float).ravel()),
           grid.spacing, grid.margin, grid.extent, float(taxel_radius))
    hit = _SKIN_CACHE.get(key)
    if hit is not None:
        return hit
    u, n, e1, e2 = _frame(layout, direction)
    pos = np.asarray(layout.positions, float)
    nrm = np.asarray(layout.normals, float)
    outer = pos + h * nrm
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
    X, Y = grid_cells(lo, hi, dx)
    mx, my = X.shape
    S = _surface_height(xy, z, X, Y)
    skin = np.ones_like(X, dtype=bool)
    if extent is not None:
        skin &= np.hypot(X, Y) <= extent
    pts = origin + X[..., None] * e1 + Y[..., None] * e2 + S[..., None] * n
    hit = {"u": u, "n": n, "e1": e1, "e2": e2, "origin": origin, "x": X[:, 0], "y": Y[0], "X": X, "Y": Y, "S": S,
           "skin": skin, "pts": pts}
    if len(_SKIN_CACHE) > 16:
        _SKIN_CACHE.clear()
    _SKIN_CACHE[key] = hit
    return hit


def press(layout, mesh, pose, layer: SoftLayer, *, force=None, indentation=None, direction=None,
          model: str = "finite_layer", compliance=None, grid: ContactGrid | None = None,
          spread: bool = True, spreading: str = "layer", samples_per_taxel: int = 7, taxel_radius: float = TAXEL_RADIUS,
          backend: str | None = None, open_mesh: str = "error", warm_start: PressResult | None = None,
          tol: float = 1e-7, maxiter: int = 1000, geometry: str = "plane") -> PressResult:
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

    Raises UnreachableTargetError when the force cannot be reached: the object
    misses the skin, or the layer would be compressed through its whole thickness.
    """
    if spreading not in elastic.SPREADINGS:
        raise InputError(f"spreading must be one of {', '.join(elastic.SPREADINGS)}, got {spreading!r}",
                         key="spreading")
    if model not in elastic.MODELS:
        raise InputError(f"model must be one of {', '.join(elastic.MODELS)}, got {model!r}", key="model")
    if force is not None and indentation is not None:
        raise InputError("give force or indentation, not both", key="force")
    if force is not None and not (np.isfinite(force) and force >= 0):
        raise InputError(f"must be a finite force >= 0 N, got {force}", key="force")
    if indentation is not None and not (np.isfinite(indentation) and indentation >= 0):
        raise InputError(f"must be >= 0 m, got {indentation}", key="indentation")
    if not isinstance(layer, SoftLayer):
        raise InputError("layer must be a vtcore.contact.SoftLayer", key="layer")
    h = layer.thickness
    if h <= 0:
        raise InputError("press needs a soft layer of thickness > 0", key="layer.thickness")
    grid = grid or ContactGrid()
    pose = np.asarray(pose, float).reshape(4, 4)
    if not np.all(np.isfinite(pose)):
        raise InputError("pose has non-finite entries", key="pose")
    if geometry not in GEOMETRIES:
        raise InputError(f"geometry must be one of {', '.join(GEOMETRIES)}, got {geometry!r}", key="geometry")
    local, scene = _prepared(mesh, open_mesh)
    if geometry == "unrolled":
        from .curved import press_unrolled

        res = press_unrolled(layout, local, scene, pose, layer, force=force, indentation=indentation,
                             direction=direction, model=model, grid=grid, spread=spread, spreading=spreading,
                             samples_per_taxel=samples_per_taxel, taxel_radius=taxel_radius, backend=backend,
                             warm_start=warm_start, tol=tol, maxiter=maxiter)
        if compliance is not None and res.force > 0:
            res.object_deflection = res.force / _object_stiffness(compliance, local, res.pose, res.contact_point)
            res.displacement = res.indentation + res.object_deflection
        return res
    sk = _skin_grid(layout, h, layer.extent, direction, grid, taxel_radius)
    u, n, e1, e2, origin = sk["u"], sk["n"], sk["e1"], sk["e2"], sk["origin"]
    xs, ys, S, dx = sk["x"], sk["y"], sk["S"], grid.spacing
    gap = np.full(S.shape, np.inf)
    # only cells under the object's footprint can meet it: cast rays there alone (a window of
    # the regular grid, found by bisection rather than comparing every cell)
    box = local.bounds[0] + _CORNERS * (local.bounds[1] - local.bounds[0])
    box = box @ pose[:3, :3].T + pose[:3, 3] - origin
    bx, by = box @ e1, box @ e2
    wx = slice(int(np.searchsorted(xs, bx.min() - dx, side="left")),
               int(np.searchsorted(xs, bx.max() + dx, side="right")))
    wy = slice(int(np.searchsorted(ys, by.min() - dx, side="left")),
               int(np.searchsorted(ys, by.max() + dx, side="right")))
    win = sk["skin"][wx, wy]
    if win.any():
        sub = np.full(win.shape, np.inf)
        sub[win] = _envelope_posed(sk["pts"][wx, wy][win], n, local, scene, pose, backend)
        gap[wx, wy] = sub
    finite = np.isfinite(gap)
    area = dx * dx
    mx, my = gap.shape

    fld = ContactField(xs, ys, origin, e1, e2, n, S, gap, np.zeros_like(gap), thickness=h)
    gmin = float(gap[finite].min()) if finite.any() else np.inf
    if force is not None and force > 0 and not finite.any():
        raise UnreachableTargetError(
            f"the object never meets the skin along the press direction {np.round(u, 3).tolist()}: "
            f"no force can be reached (target {force} N)")

    # --- contact solve -----------------------------------------------------------
    iters, conv_ok = 0, True
    if not finite.any() or (force is not None and force == 0) or (indentation is not None and indentation == 0):
        p = np.zeros_like(gap)
        d = gmin if np.isfinite(gmin) else 0.0
    elif model == "local":
        k = layer.e_star / h
        sol = elastic.solve_local(gap, k, area, force=force,
                                  approach=None if force is not None else
                                  (gmin + indentation if indentation is not None else 0.0))
        p, d = sol.pressure, sol.approach
    else:
        target_d = None if force is not None else (gmin + indentation if indentation is not None else 0.0)
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
            ii, jj = np.nonzero(sel)
            pad = 2
            i0, i1 = max(ii.min() - pad, 0), min(ii.max() + pad + 1, mx)
            j0, j1 = max(jj.min() - pad, 0), min(jj.max() + pad + 1, my)
            # round the box up to multiples of 8 cells so trajectories reuse cached kernels
            bi, bj = -(-(i1 - i0) // 8) * 8, -(-(j1 - j0) // 8) * 8
            i1, j1 = min(i0 + bi, mx), min(j0 + bj, my)
            i0, j0 = max(i1 - bi, 0), max(j1 - bj, 0)
            sub = gap[i0:i1, j0:j1]
            op = elastic.compliance_operator(sub.shape, dx, dx, layer, model)
            p0 = p0_full[i0:i1, j0:j1] if p0_full is not None else None
            sol = elastic.solve_pk(sub, op, area, force=force, approach=target_d, p0=p0, tol=tol, maxiter=maxiter)
            iters += sol.iterations
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
    p = np.where(np.isfinite(p) & (p > 0), p, 0.0)
    fld.pressure = p
    total = float(p.sum() * area)
    compress = np.where(p > 0, d - np.where(finite, gap, d), 0.0)
    max_c = float(compress.max()) if p.any() else 0.0
    bottomed = max_c > h * (1 + 1e-9)
    if force is not None and force > 0 and bottomed:
        raise UnreachableTargetError(
            f"{force} N would compress the {h * 1e3:.3g} mm layer by {max_c * 1e3:.3g} mm (model {model}): "
            "the object bottoms out on the end-effector before reaching the target force; use a thicker or "
            "stiffer layer or a lower force (docs/contact.md, 'The mug rim at 15 N')")
    travel = float(d) if np.isfinite(d) else 0.0
    if force is None and indentation is None:
        travel = 0.0
    new_pose = pose.copy()
    new_pose[:3, 3] += travel * u
    fld.gap = np.where(finite, gap - travel, np.inf)
    indent = max(travel - gmin, 0.0) if np.isfinite(gmin) else 0.0
    if force is None and indentation is None and np.isfinite(gmin):
        indent = max(-gmin, 0.0)
    surf, taxel = taxel_readings(layout, fld, p, layer, spread, spreading, samples_per_taxel, taxel_radius)
    defl = 0.0
    cpt = np.full(3, np.nan)
    cpt_obj = np.full(3, np.nan)
    if total > 0:
        on = p > 0  # the contact cells only: the grid can be large and the contact small
        cpt = np.einsum("m,mi->i", p[on], sk["pts"][on]) / p[on].sum()
        r_, t_ = new_pose[:3, :3], new_pose[:3, 3]
        cpt_obj = r_.T @ (cpt - t_)  # rigid inverse
    if compliance is not None and total > 0:
        k_obj = _object_stiffness(compliance, local, new_pose, cpt)
        defl = total / k_obj
    return PressResult(
        pressure=taxel, surface_pressure=surf, force=total, indentation=indent,
        contact_area=float((p > 0).sum() * area), pose=new_pose, travel=travel,
        displacement=indent + defl, object_deflection=defl, bottomed_out=bool(bottomed),
        max_compression=max_c, model=model, iterations=iters, converged=bool(conv_ok),
        direction=u, field=fld, spread=spread, contact_point=cpt, contact_point_object=cpt_obj)


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


# --- foundation helpers, kept for callers of the first skeleton -------------------------

def boussinesq_kernel(r: np.ndarray, h: float) -> np.ndarray:
    """Vertical stress at depth h under a unit point load at radial distance r (1/m^2)."""
    return elastic.boussinesq_kernel(r, h)


def spread_through_layer(positions, surface_pressure, thickness, taxel_area):
    """Stress reaching the taxels at depth ``thickness`` from per-taxel surface pressure (dense Boussinesq).

    positions : (N, 3) metres. surface_pressure : (N,) or (T, N) pascals. Returns the same shape.
    """
    p = np.asarray(positions, float)
    q = np.asarray(surface_pressure, float)
    if thickness <= 0:
        return q.copy()
    r = np.linalg.norm(p[:, None, :] - p[None, :, :], axis=-1)
    kernel = boussinesq_kernel(r, thickness) * taxel_area
    return q @ kernel.T


def median_taxel_area(positions) -> float:
    """Skin area (m^2) one taxel stands for on a triangular lattice of its median spacing."""
    from scipy.spatial import cKDTree

    d, _ = cKDTree(positions).query(positions, k=2)
    return float(np.sqrt(3) / 2 * np.median(d[:, 1]) ** 2)
