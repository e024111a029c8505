"""Module geometry as data: the registry of skin module types.

A module type is an entry in :data:`MODULES` (taxel positions in the module's
flat frame, taxel roles, sensor numbers, outline, and how copies of it tile a
strip, a hexagon and a plane), never a code branch. New variants are added with
:func:`register_module`.

Geometry of the entries
-----------------------
``cyskin10`` (seeds 001, 002): 10 capacitive taxels of 4 mm diameter on a
triangular lattice of 7.5 mm pitch, arranged as a triangle with 4 taxels on a
side (rows of 4, 3, 2, 1). The module frame has its origin at the taxel
centroid (itself a taxel) and the apex towards +y. Six such modules, each
rotated by 60 degrees, make the hexagonal patch of seed 001 (61 lattice sites
of a hexagon of radius 4, the centre site belongs to no module, 60 taxels);
an "up" and a "down" module side by side make the 20-taxel planar patch of seed
002, and translating that pair by 5 pitches along x and by 4 rows straight up
(the lattice vector 4b - 2a) tiles the plane without gaps or duplicates.

``cyskin11``: the same triangle plus one taxel at the lattice site next to the
hub-side corner, which is where the centre taxel of a 61-taxel hexagon lies
(CySkin modules carry "up to 11" taxels; the format notes record a planar
hexagon of 61 taxels in 6 modules). This placement is our assumption, not a
datasheet value.

``icub12``: the iCub skin triangle (30 mm side, 12 slots, slots 6 and 10 are
thermal pads), slot pattern as drawn by the iCub skin GUI: the unit triangle
``(0,0)-(1,0)-(0.5, sin 60)`` scaled by 30 mm with slot offsets built from
``L = 2 sin(60)/9``. Origin at the outline centroid, apex towards +y. This is
the *old* iCub triangle (5.0 mm pitch, taxel 3 off the origin).

``icub10``: the current iCub skin triangle, skinGui's ``triangle_10pad``
(icub-main ``src/tools/iCubSkinGui/src/include/Triangle_10pad.h``): 12 slots, 10
pressure pads and thermal pads at slots 6 and 10, slot numbering as the iCub
software has it. skinGui writes the offsets in mils (1/1000 inch, the PCB CAD
unit; the drawing divides them by 40): 257.2 mil = 6.533 mm from the centre
taxel 3, which sits at the module origin. The pressure pads lie on a triangular
lattice of that pitch, rows of 4, 3, 2, 1 (the CySkin pattern); the outline is
skinGui's drawn triangle (vertices ``(+-55/4, -32.5/4)`` and ``(0, 63/4)`` in the
same drawing units, about 28 mm a side). Copies tile at the spacing of skinGui's
own forearm layouts (neighbouring triangle centres 18.48 drawing units apart,
``left_forearm_V2.ini``), i.e. triangles of 32 drawing units a side.

Mirrored modules
----------------
skinGui layouts carry a ``mirror`` column: a mirrored triangle has every offset's
x negated in the module frame before it is rotated (``if (lrMirror==1) x=-x``),
and half the triangles of a real iCub forearm are mirror images. :meth:`ModuleType.mirror`
returns that mirror image (same name and slot numbering, ``mirrored`` set), whose
strip, hexagon and plane tiling are the mirror images of the original's, so every
patch kind and ``fill`` work with it unchanged; ``get_module(name, mirror=True)``
looks it up.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..errors import InputError
from .uids import cyskin_uids

PITCH = 7.5e-3  #: m, CySkin taxel pitch (seeds 001, 002)
MIL = 25.4e-6  #: m per mil (1/1000 inch), the unit of skinGui's triangle_10pad offsets
TAXEL_DIAMETER = 4.0e-3  #: m, CySkin taxel diameter

_A = np.array([1.0, 0.0])
_B = np.array([0.5, np.sqrt(3.0) / 2.0])


def _rot(theta: float) -> np.ndarray:
    c, s = np.cos(theta), np.sin(theta)
    return np.array([[c, -s], [s, c]])


@dataclass
class ModuleType:
    """One kind of skin module.

    name : registry key.
    taxels : (k, 2) float, metres, taxel centres in the module frame.
    sensors : (k,) int, sensor number of each taxel inside the module (the low
        bits of a CySkin UID, the slot of an iCub triangle).
    roles : (k,) str, ``"pressure"`` or ``"thermal"``.
    outline : (m, 2) float, metres, the board outline (counter-clockwise).
    pitch : float, metres, nominal taxel pitch.
    taxel_diameter : float, metres.
    edges : (e, 2) int, the module's own taxel graph (used for strain).
    strip : list of ``(angle_rad, (x, y))`` module poses inside one strip
        period, and ``strip_period`` (2,) the translation between periods.
    fill_row : (2,) float, metres, the translation between strip rows of a fill.
    hexagon : list of ``(angle_rad, (x, y))``, poses of the modules of a hexagon
        around its centre (the origin of the patch).
    slots : int, the number of slots per module in files that list every slot
        (iCub positions files: 12).
    id_scheme : ``"cyskin"`` (taxel UID ``(module + 1) << 4 | sensor``) or ``"icub"``
        (taxel id ``module * 12 + slot``, the row of a positions file).
    mirrored : True for the mirror image of the registered geometry (see :meth:`mirror`).
    """

    name: str
    taxels: np.ndarray
    sensors: np.ndarray
    roles: np.ndarray
    outline: np.ndarray
    pitch: float
    taxel_diameter: float
    strip: list
    strip_period: np.ndarray
    fill_row: np.ndarray
    hexagon: list
    edges: np.ndarray = None
    slots: int = 0
    id_scheme: str = "cyskin"
    mirrored: bool = False
    doc: str = ""
    meta: dict = field(default_factory=dict)

    def __post_init__(self):
        self.taxels = np.asarray(self.taxels, dtype=np.float64).reshape(-1, 2)
        self.sensors = np.asarray(self.sensors, dtype=np.int64).reshape(-1)
        self.roles = np.asarray(self.roles, dtype=object).reshape(-1)
        self.outline = np.asarray(self.outline, dtype=np.float64).reshape(-1, 2)
        self.strip_period = np.asarray(self.strip_period, dtype=np.float64)
        self.fill_row = np.asarray(self.fill_row, dtype=np.float64)
        if self.edges is None:
            self.edges = _short_edges(self.taxels, 1.25 * self.pitch)
        if not self.slots:
            self.slots = len(self.taxels)

    def __len__(self) -> int:
        return len(self.taxels)

    def placed(self, angle: float, centre) -> np.ndarray:
        """(k, 2) metres: the taxels after rotating by ``angle`` and moving the origin to ``centre``."""
        return self.taxels @ _rot(angle).T + np.asarray(centre, dtype=np.float64)

    def placed_outline(self, angle: float, centre) -> np.ndarray:
        return self.outline @ _rot(angle).T + np.asarray(centre, dtype=np.float64)

    def mirror(self) -> "ModuleType":
        """The mirror image (skinGui's ``mirror`` column): x negated in the module frame.

        Same name, sensors, roles and edges; the outline is re-ordered to stay
        counter-clockwise; strip, hexagon and plane-tiling poses are mirrored too
        (angle negated, x negated), so they still tile. Mirroring twice gives the original.
        """
        flip = np.array([-1.0, 1.0])

        def poses(ps):
            return [(-float(a), np.asarray(c, float) * flip) for a, c in ps]

        return ModuleType(
            name=self.name, taxels=self.taxels * flip, sensors=self.sensors.copy(), roles=self.roles.copy(),
            outline=(self.outline * flip)[::-1].copy(), pitch=self.pitch, taxel_diameter=self.taxel_diameter,
            strip=poses(self.strip), strip_period=self.strip_period * flip, fill_row=self.fill_row * flip,
            hexagon=poses(self.hexagon), edges=self.edges.copy(), slots=self.slots, id_scheme=self.id_scheme,
            mirrored=not self.mirrored, doc=self.doc, meta=dict(self.meta))

    @property
    def area(self) -> float:
        """Area of the outline, square metres."""
        x, y = self.outline.T
        return float(abs(x @ np.roll(y, -1) - np.roll(x, -1) @ y) / 2)

    @property
    def radius(self) -> float:
        """Largest distance from the module origin to its outline, metres."""
        return float(np.hypot(*self.outline.T).max())


def _short_edges(points: np.ndarray, max_len: float) -> np.ndarray:
    d = np.linalg.norm(points[:, None] - points[None], axis=-1)
    i, j = np.nonzero(np.triu(d <= max_len, k=1))
    return np.column_stack([i, j]).astype(np.int64)


MODULES: dict[str, ModuleType] = {}


def register_module(module: ModuleType) -> ModuleType:
    """Add (or replace) a module type in the registry and return it."""
    MODULES[module.name] = module
    return module


def get_module(name: str | ModuleType, mirror: bool = False) -> ModuleType:
    """The registered module type ``name`` (a :class:`ModuleType` passes through);
    ``mirror=True``: its mirror image (:meth:`ModuleType.mirror`)."""
    if isinstance(name, ModuleType):
        mod = name
    else:
        try:
            mod = MODULES[name]
        except KeyError:
            raise InputError(f"unknown module type {name!r}; known: {', '.join(sorted(MODULES))}",
                             key="module") from None
    return mod.mirror() if mirror else mod


def module_names() -> tuple[str, ...]:
    return tuple(sorted(MODULES))


def taxel_uids(module: ModuleType, module_ids, sensors) -> np.ndarray:
    """(N,) int taxel ids of ``sensors`` on modules ``module_ids`` under the module's id scheme."""
    module_ids = np.asarray(module_ids, dtype=np.int64)
    sensors = np.asarray(sensors, dtype=np.int64)
    if module.id_scheme == "icub":
        return module_ids * module.slots + sensors
    return cyskin_uids(module_ids, sensors)


# --- CySkin: a 4-per-side triangle of lattice sites ------------------------------------------
def _cyskin(pitch: float = PITCH, eleven: bool = False) -> ModuleType:
    ij = np.array([(i, j) for j in range(4) for i in range(4 - j)], dtype=float)
    # origin at the centroid, which is the lattice site (1, 1)
    sites = ij - 1.0
    sensors = np.arange(1, 11)
    if eleven:
        # the site next to the hub-side corner: -a from site (0, 0)
        sites = np.vstack([sites, [-2.0, -1.0]])
        sensors = np.arange(1, 12)
    taxels = (sites[:, :1] * _A + sites[:, 1:] * _B) * pitch
    # outline: the taxel triangle grown by half a row spacing plus the taxel radius margin
    corners = (np.array([[-1.0, -1.0], [2.0, -1.0], [-1.0, 2.0]])[:, :1] * _A
               + np.array([[-1.0, -1.0], [2.0, -1.0], [-1.0, 2.0]])[:, 1:] * _B) * pitch
    # inradius growth: taxel radius plus 1 mm, below the sqrt(3)/4 pitch at which the outlines of
    # neighbouring modules of a tiling would touch
    grow = 0.4 * pitch
    centroid = corners.mean(axis=0)
    inr = np.linalg.norm(corners[0] - centroid) / 2.0
    outline = centroid + (corners - centroid) * (inr + grow) / inr
    a, b = _A * pitch, _B * pitch
    hexagon = [(k * np.pi / 3, _rot(k * np.pi / 3) @ (2 * _A + _B) * pitch) for k in range(6)]
    return ModuleType(
        name="cyskin11" if eleven else "cyskin10", taxels=taxels, sensors=sensors,
        roles=np.full(len(sensors), "pressure", dtype=object), outline=outline, pitch=pitch,
        taxel_diameter=TAXEL_DIAMETER,
        strip=[(0.0, a + b), (np.pi, 3 * a + 2 * b)], strip_period=5 * a, fill_row=4 * b - 2 * a,
        hexagon=hexagon,
        doc=("CySkin triangular module, 11 taxels (10-taxel triangle plus the hub-side taxel)" if eleven
             else "CySkin triangular module, 10 taxels of 4 mm at 7.5 mm pitch (seeds 001, 002)"))


# --- iCub: the 12-slot triangle of the skin GUI -------------------------------------------------
def _icub12(side: float = 30e-3) -> ModuleType:
    h = np.sin(np.pi / 3)
    L = 2.0 * h / 9.0
    dx = np.empty(12)
    dy = np.empty(12)
    c30, s30 = np.cos(np.pi / 6), np.sin(np.pi / 6)
    dx[5] = L * c30
    dx[4], dx[2], dx[1] = 0.5 - dx[5], 0.5 + dx[5], 1.0 - dx[5]
    dx[6], dx[3], dx[0] = 0.25, 0.5, 0.75
    dx[7], dx[11] = 0.25 + dx[5], 0.75 - dx[5]
    dx[8], dx[10], dx[9] = dx[7], dx[11], 0.5
    dy[5] = L * s30
    dy[4] = dy[2] = dy[1] = dy[5]
    dy[6] = dy[0] = 0.5 * h - L
    dy[3] = L
    dy[7] = dy[11] = 0.5 * h - L * s30
    dy[8] = dy[10] = 0.5 * h + L * s30
    dy[9] = h - L
    # unit triangle (0,0)-(1,0)-(0.5,h) -> outline of ``side`` with its centroid at the origin
    taxels = np.column_stack([dx - 0.5, dy - h / 3.0]) * side
    outline = np.array([[-0.5, -h / 3], [0.5, -h / 3], [0.0, 2 * h / 3]]) * side
    roles = np.full(12, "pressure", dtype=object)
    roles[[6, 10]] = "thermal"
    hh = h * side
    hexagon = [(k * np.pi / 3, _rot(k * np.pi / 3) @ np.array([side / 2, hh / 3])) for k in range(6)]
    nn = np.sort(np.linalg.norm(taxels[:, None] - taxels[None], axis=-1), axis=1)[:, 1]
    pitch = float(np.median(nn))
    return ModuleType(
        name="icub12", taxels=taxels, sensors=np.arange(12), roles=roles, outline=outline,
        pitch=pitch, taxel_diameter=3.0e-3,
        strip=[(0.0, np.array([side / 2, hh / 3])), (np.pi, np.array([side, 2 * hh / 3]))],
        strip_period=np.array([side, 0.0]), fill_row=np.array([side / 2, hh]), hexagon=hexagon,
        edges=_short_edges(taxels, 1.5 * pitch), slots=12, id_scheme="icub",
        doc="iCub skin triangle: 12 slots (10 pressure taxels, thermal pads at slots 6 and 10), 30 mm side")


# --- iCub: the current 10-pad triangle (skinGui triangle_10pad) ----------------------------------
# Slot offsets in mils as Triangle_10pad.h lists them (icub-main, src/tools/iCubSkinGui/src/include/
# Triangle_10pad.h, dX[i], dY[i]); slots 6 and 10 are the thermal pads.
ICUB10_MIL = np.array([
    [257.2, 0.0], [385.83, -222.83], [128.62, -222.83], [0.0, 0.0], [-128.62, -222.83], [-385.83, -222.83],
    [-256.3, -147.64], [-257.2, 0.0], [-128.62, 222.83], [0.0, 445.54], [0.0, 296.55], [128.62, 222.83]])
#: skinGui's drawn outline of the triangle_10pad (dXv, dYv, drawing units of 40 mil)
ICUB10_OUTLINE_DRAW = np.array([[-55.0 / 4, -32.5 / 4], [55.0 / 4, -32.5 / 4], [0.0, 63.0 / 4]])
#: centre-to-centre distance of neighbouring triangles in skinGui's forearm layouts (drawing units):
#: e.g. left_forearm_V2.ini triangles 0 (100.00, -20.00) and 1 (109.24, -4.00)
ICUB10_NEIGHBOUR_DRAW = float(np.hypot(9.24, 16.0))


def _icub10() -> ModuleType:
    taxels = ICUB10_MIL * MIL
    roles = np.full(12, "pressure", dtype=object)
    roles[[6, 10]] = "thermal"
    pitch = float(np.linalg.norm(taxels[0]))  # centre taxel 3 to taxel 0: 6.533 mm
    outline = ICUB10_OUTLINE_DRAW * 40 * MIL
    # tiling: up and down triangles of side s, edge to edge, centroids 2 * inradius = s / sqrt(3) apart
    side = ICUB10_NEIGHBOUR_DRAW * 40 * MIL * np.sqrt(3.0)
    h = side * np.sqrt(3.0) / 2
    hexagon = [(k * np.pi / 3, _rot(k * np.pi / 3) @ np.array([side / 2, h / 3])) for k in range(6)]
    return ModuleType(
        name="icub10", taxels=taxels, sensors=np.arange(12), roles=roles, outline=outline,
        # skinGui draws a pad as a circle of radius 2.2 drawing units (m_RadiusOrig): 4.5 mm across
        pitch=pitch, taxel_diameter=2 * 2.2 * 40 * MIL,
        strip=[(0.0, np.array([side / 2, h / 3])), (np.pi, np.array([side, 2 * h / 3]))],
        strip_period=np.array([side, 0.0]), fill_row=np.array([side / 2, h]), hexagon=hexagon,
        slots=12, id_scheme="icub",
        doc=("iCub skin triangle_10pad (current iCub skin): 10 pressure pads 6.53 mm apart round the centre "
             "taxel 3 at the origin, thermal pads at slots 6 and 10"))


register_module(_cyskin())
register_module(_cyskin(eleven=True))
register_module(_icub12())
register_module(_icub10())
