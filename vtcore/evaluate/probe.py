"""The standard probe and its precomputed layer response (the linear shortcut behind every map).

A design map asks, for thousands of surface points, what each taxel reads when a fingertip-size
probe presses there. Pressing press by press would cost one contact solve per point and force.
Instead the probe is pressed **once per force** at the centre of a flat, unbounded layer, and the
stress it leaves at the layer's base is read as a taxel disc mean at every offset of a fine grid:
:class:`ResponseTable` ``r(F, dx, dy)`` Pa, the reading of a taxel whose centre lies ``(dx, dy)``
from the probe, in the probe's tangent frame. A taxel's reading anywhere on the skin is then a
table look-up at its offset from the probe (translation invariance of a uniform layer).

Where this holds (measured in docs/evaluate.md and ``vtcore bench evaluate``): exactly on a flat
patch whose layer extends a few thicknesses beyond the probe (the table is the same solve);
approximately on a curved link (offsets are measured in the probe's tangent plane, rescaled to the
3-D distance, error grows as (contact radius / radius of curvature)^2); not at a layer's free edge.
Between tabulated forces the peak reading is interpolated log-log (it is a power law of the force
to a good approximation); below the smallest force it is taken proportional to the force, which is
exact in the limit where the contact is much smaller than the layer thickness (the base stress is
then the force times the layer's point-load Green's function). Two simultaneous probes are the sum
of two tables (the layer is linear elastic; the contacts do not feel each other once they are more
than a contact diameter apart: see two_point.py).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..errors import InputError

#: kind -> dimensions overriding vtcore.contact's defaults (metres). "fingerpad" (the standard probe):
#: the contact package's finger pad, a capsule 16 mm wide and 40 mm long lying on the skin, the
#: footprint the one-finger CySkin recordings show; "sphere": a fingertip-size ball (r 8 mm, the
#: radius of an index fingertip's cross-section is 7-10 mm), round where the pad is elongated.
PROBES = {
    "fingerpad": {},
    "sphere": {"radius": 0.008, "subdivisions": 4},
}

#: The layer's base stress beyond this many thicknesses is below 1e-3 of its peak (bonded
#: Ecoflex, measured on the tables): the table reaches that far beyond the contact.
REACH_THICKNESSES = 6.0


@dataclass
class Probe:
    """The standard probe: ``kind`` of :data:`PROBES` with ``dims`` overriding its defaults (metres),
    turned by ``yaw`` radians about the surface normal from the sample's first tangent."""

    kind: str = "fingerpad"
    dims: dict = field(default_factory=dict)
    yaw: float = 0.0

    def __post_init__(self):
        if self.kind not in PROBES:
            raise InputError(f"unknown probe {self.kind!r}; known: {', '.join(PROBES)}", key="probe.kind")
        self.dims = dict(self.dims)
        if not np.isfinite(self.yaw):
            raise InputError(f"must be finite, got {self.yaw}", key="probe.yaw")

    def mesh(self):
        """The probe as a closed trimesh resting on z = 0, pressed face up (vtcore.contact convention)."""
        from ..contact import make_object

        return make_object(self.kind, **{**PROBES[self.kind], **self.dims})

    def size(self) -> float:
        """Largest half-extent of the probe's footprint, metres (bounds the contact radius)."""
        m = self.mesh()
        ext = m.bounds[1] - m.bounds[0]
        return float(0.5 * max(ext[0], ext[1]))

    def width(self) -> float:
        """Width of the probe across its long axis (its y extent), metres: two probes side by side closer
        than this overlap and are one wider object, not two touches."""
        b = self.mesh().bounds
        return float(b[1][1] - b[0][1])

    def describe(self) -> str:
        from ..contact.objects import DEFAULTS

        full = {**DEFAULTS[self.kind], **PROBES[self.kind], **self.dims}
        dims = ", ".join(f"{k} {v * 1e3:g} mm" for k, v in sorted(full.items())
                         if isinstance(v, (int, float)) and k not in ("subdivisions", "sections"))
        return f"{self.kind} ({dims})" if dims else self.kind


@dataclass
class ResponseTable:
    """Taxel readings around one probe at several forces.

    forces : (F,) N, increasing. x, y : (gx,), (gy,) m, offsets of a taxel centre from the probe in the
    probe's tangent frame (a regular grid). values : (F, gx, gy) Pa, the taxel's disc-mean stress at the
    layer's base (0 beyond the grid). peak : (F,) Pa, the largest value of each force.
    tail : largest value on the grid's rim relative to the peak (what the table's reach cuts off).
    seconds : time the solves took. bottomed_at : N or None, the first force the layer could not carry.
    """

    forces: np.ndarray
    x: np.ndarray
    y: np.ndarray
    values: np.ndarray
    tail: float
    seconds: float = 0.0
    bottomed_at: float | None = None
    contact_radius: np.ndarray | None = None

    @property
    def reach(self) -> float:
        """Largest offset the table holds, metres."""
        return float(min(self.x[-1], self.y[-1]))

    @property
    def peak(self) -> np.ndarray:
        return self.values.reshape(len(self.forces), -1).max(axis=1)

    def radius(self, k: int, level: float) -> float:
        """Largest offset (m) at which force row ``k`` reads at least ``level`` Pa (0 when nowhere): no
        taxel farther from the probe can reach that level."""
        X, Y = np.meshgrid(self.x, self.y, indexing="ij")
        on = self.values[k] >= level
        step = self.x[1] - self.x[0]
        return float(np.hypot(X[on], Y[on]).max() + step) if on.any() else 0.0

    def index(self, force: float) -> int:
        """Row of ``force`` (it must be one of the tabulated forces)."""
        k = np.flatnonzero(np.isclose(self.forces, force, rtol=1e-9, atol=0))
        if not len(k):
            raise InputError(f"{force} N is not a tabulated force ({self.forces.tolist()})", key="force")
        return int(k[0])

    def lookup(self, k: int, dx, dy) -> np.ndarray:
        """Readings (Pa) at offsets ``dx, dy`` (any equal shapes, m) for tabulated force row ``k``:
        bilinear on the grid, 0 beyond it."""
        from scipy.ndimage import map_coordinates

        dx = np.asarray(dx, float)
        dy = np.asarray(dy, float)
        step = self.x[1] - self.x[0]
        ci = (dx - self.x[0]) / step
        cj = (dy - self.y[0]) / step
        out = map_coordinates(self.values[k], [ci.ravel(), cj.ravel()], order=1, mode="constant", cval=0.0)
        return out.reshape(dx.shape)


def disc_means(field: np.ndarray, offsets: np.ndarray, spacing: float) -> np.ndarray:
    """The mean of a cell-centred ``field`` (mx, my) over ``offsets`` (S, 2) m around every cell centre,
    each read bilinearly (0 beyond the grid): one correlation with the offsets' bilinear weights, the
    same numbers as :func:`vtcore.contact.grid.sample_bilinear` at every cell and offset, in one pass."""
    from scipy.ndimage import correlate

    f = np.asarray(offsets, float) / spacing
    i0 = np.floor(f).astype(int)
    t = f - i0
    r = int(np.abs(i0).max()) + 1
    kern = np.zeros((2 * r + 1, 2 * r + 1))
    for (ix, iy), (tx, ty) in zip(i0, t):
        for dx, wx in ((0, 1 - tx), (1, tx)):
            for dy, wy in ((0, 1 - ty), (1, ty)):
                kern[r + ix + dx, r + iy + dy] += wx * wy  # a few offsets: the loop builds a tiny kernel
    return correlate(field, kern / len(f), mode="constant", cval=0.0)


def default_forces(reference: float, force_max: float, n: int = 9, force_min: float = 0.02) -> np.ndarray:
    """(F,) N: ``n`` forces spaced evenly in log from ``force_min`` to ``force_max``, plus ``reference``."""
    if not (0 < force_min < force_max) or not np.isfinite(force_max):
        raise InputError(f"need 0 < force_min < force_max, got {force_min}, {force_max}", key="force_max")
    if not (0 < reference <= force_max):
        raise InputError(f"must be in (0, force_max = {force_max}] N, got {reference}", key="reference_force")
    f = np.geomspace(force_min, force_max, max(int(n), 2))
    return np.unique(np.append(f, reference))


def response_table(probe: Probe, layer, *, forces, spacing: float | None = None, model: str = "finite_layer",
                   spreading: str | None = "layer", taxel_radius: float | None = None, disc_samples: int = 19,
                   reach: float | None = None) -> ResponseTable:
    """Press ``probe`` on a flat layer once per force and tabulate what a taxel reads around it.

    layer : vtcore.contact.SoftLayer (its ``extent`` is ignored: the table is for an unbounded layer).
    forces : (F,) N. spacing : m, the table's (and the contact grid's) cell (default: h / 6, within
    0.2-1 mm). reach : m, half-size of the table (default: the probe's footprint + 6 h + the taxel
    radius). Forces the layer cannot carry (the probe bottoms out) end the table there; a table
    needs at least its first force.
    """
    import time

    from ..contact import ContactGrid, SoftLayer, placement_pose, press
    from ..contact.grid import TAXEL_RADIUS, disc_offsets
    from ..errors import UnreachableTargetError
    from ..layout import Layout

    h = float(layer.thickness)
    if not h > 0:
        raise InputError("a design map needs a soft layer of thickness > 0", key="layer.thickness")
    taxel_radius = TAXEL_RADIUS if taxel_radius is None else float(taxel_radius)
    spacing = float(np.clip(h / 6, 2e-4, 1e-3)) if spacing is None else float(spacing)
    mesh = probe.mesh()
    if reach is None:
        reach = probe.size() + REACH_THICKNESSES * h + taxel_radius
    n_cells = (2 * reach / spacing) ** 2
    if n_cells > 1_000_000:  # a (gx, gy) table per force; grows with reach / spacing squared
        spacing = 2 * reach / 1000.0
    flat = SoftLayer(thickness=h, young_modulus=layer.young_modulus, poisson=layer.poisson, base=layer.base,
                     material=layer.material)
    one = Layout(np.zeros((1, 3)), [[0.0, 0.0, 1.0]], [0], [0])
    grid = ContactGrid(spacing=spacing, margin=0.0, extent=reach)
    # the table is in the probe's own frame (its long axis along x); the yaw turns the frame the
    # offsets are measured in (maps.frames), not the table
    pose0 = placement_pose(mesh, xy=(0.0, 0.0), top=h, gap=1e-4)
    forces = np.asarray(forces, float)
    t0 = time.perf_counter()
    rows, kept, radius, prev, bottomed = [], [], [], None, None
    offs = disc_offsets(disc_samples, taxel_radius)
    for f in forces:
        try:
            res = press(one, mesh, pose0, flat, force=float(f), grid=grid, model=model,
                        spread=spreading is not None, spreading=spreading or "layer",
                        samples_per_taxel=1, warm_start=prev)
        except UnreachableTargetError:
            bottomed = float(f)
            break
        fld = res.field
        rows.append(disc_means(fld.stress if fld.stress is not None else fld.pressure, offs, spacing))
        kept.append(f)
        radius.append(float(np.sqrt(res.contact_area / np.pi)))
        xs, ys, prev = fld.x, fld.y, res
    if not rows:
        raise InputError(f"the probe bottoms out through the {h * 1e3:g} mm layer already at {forces[0]:g} N",
                         key="force_min")
    values = np.stack(rows)
    # the grid is centred on the probe (an even number of cells): offsets are the cell centres
    rim = np.concatenate([values[:, 0, :], values[:, -1, :], values[:, :, 0], values[:, :, -1]], axis=1)
    tail = float((rim.max(axis=1) / np.maximum(values.reshape(len(rows), -1).max(axis=1), 1e-300)).max())
    return ResponseTable(np.asarray(kept), np.asarray(xs), np.asarray(ys), values, tail,
                         time.perf_counter() - t0, bottomed, np.asarray(radius))
