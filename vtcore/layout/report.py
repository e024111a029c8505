"""What a placement did: the :class:`PlacementReport`, module-edge strain, overlaps, coverage.

Strain is the edge length on the surface, measured as the arc through both taxels with
their normals, over the flat length, minus one: bending is free for a flexible PCB,
stretching is not. Overlaps are taxels of different modules closer than
``OVERLAP_FRACTION`` of the pitch. Coverage is the area of a region under module outlines
over the region's area (in the flat domain of the log map).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy.spatial import cKDTree

from ..errors import InputError
from .model import Layout
from .patches import Patch

NORMAL_DEVIATION_DEG = 5.0  #: a taxel normal further than this from its face's is listed in the report
OVERLAP_FRACTION = 0.75  #: taxels of different modules closer than this many pitches overlap
#: fill's limit on module-edge stretch (fraction): modules straining more are left out (bending is
#: free for a flexible PCB; a stretched edge means its taxels are not where the layout says)
DEFAULT_MAX_STRAIN = 0.05
#: the stretch beyond which a placed patch (place: laid whole, as a person lays it) is refused unless
#: forced: a hexagon on a 40 mm sphere strains 7 % at its rim and passes; 29 % or 196 % do not
PLACE_MAX_STRAIN = 0.10


class PlacementRefused(InputError):
    """A placement the front ends refuse unless forced (taxels off the surface, over-strained,
    'at' far off the surface): the message is the first reason, ``reasons`` all of them."""

    def __init__(self, reasons: list, what: str = "placement"):
        self.reasons = list(reasons)
        more = f" (and {len(reasons) - 1} more problem{'s' if len(reasons) > 2 else ''})" if len(reasons) > 1 else ""
        super().__init__(f"{what} refused: {reasons[0]}{more}; force it to keep it anyway", key=None)


def check_trust(report: "PlacementReport", *, max_strain: float = DEFAULT_MAX_STRAIN, force: bool = False,
                what: str = "placement") -> list[str]:
    """The report's :meth:`PlacementReport.problems`; raises :class:`PlacementRefused` when there
    are any, unless ``force`` (then they are returned, for the caller to show as warnings)."""
    problems = report.problems(max_strain)
    if problems and not force:
        raise PlacementRefused(problems, what)
    return problems


@dataclass
class PlacementReport:
    """What a placement did to the patch.

    strain : (E,) float, per module edge, (length on the surface / flat length) - 1.
    strain_max : float, max |strain|. strain_mean : float, mean |strain|.
    module_strain : (M,) float, per module max |strain|.
    overlaps : list of (module_a, module_b) pairs of this patch that overlap each other.
    existing_overlaps : list of (existing_module, new_module) pairs: a module of this patch
        overlapping one already on the skin (``place(..., existing=layout)``); new module ids
        are the patch's own (0-based), existing ones as in ``existing.module_ids``.
    off_boundary : (K,) int, taxel indices that fell outside the mapped surface (off an open boundary,
        or past the cut locus of a closed surface where the log map is unreliable).
    coverage : float in [0, 1] or nan, fraction of the region under module outlines.
    surface_distance_max : float, metres, max distance of a taxel (before offset) from the mesh.
    method : "logmap" or "project"; notes : list of str.
    charts : how many log maps (charts) the placement grew through (1: a single log map).
    seam_modules : modules the seam pass of ``fill`` added where growth fronts met.
    normal_outliers : (K,) int, taxels whose normal is more than ``NORMAL_DEVIATION_DEG`` off the
        normal of the face they lie on; normal_deviation_max : degrees, the largest such angle.
    at_distance : metres from the requested ``at`` to the surface the patch was laid on.
    n_taxels : taxels placed. module_radius : metres, the module's outline radius (the tolerance
        of :meth:`problems` for ``at``).
    """

    strain: np.ndarray
    module_strain: np.ndarray
    overlaps: list
    off_boundary: np.ndarray
    coverage: float = float("nan")
    surface_distance_max: float = 0.0
    method: str = "logmap"
    seconds: float = 0.0
    notes: list = field(default_factory=list)
    existing_overlaps: list = field(default_factory=list)
    charts: int = 1
    seam_modules: int = 0
    normal_outliers: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int64))
    normal_deviation_max: float = 0.0
    at_distance: float = 0.0
    n_taxels: int = 0
    module_radius: float = 0.0

    def problems(self, max_strain: float = DEFAULT_MAX_STRAIN, at_tolerance: float | None = None) -> list[str]:
        """One line per reason not to trust this placement (empty when there is none): taxels off
        the surface, module edges stretched more than ``max_strain`` (a fraction), ``at`` farther
        from the surface than ``at_tolerance`` metres (default: the module's outline radius, so
        that the patch would not even touch the point asked for). Each line says what to do."""
        out = []
        tol = self.module_radius if at_tolerance is None else float(at_tolerance)
        if tol > 0 and self.at_distance > tol:
            out.append(f"'at' is {1e3 * self.at_distance:.1f} mm off the surface (more than {1e3 * tol:.1f} mm): "
                       "put it on the mesh (in Blender: the 3D cursor on the surface)")
        if len(self.off_boundary):
            of = f" of {self.n_taxels}" if self.n_taxels else ""
            out.append(f"{len(self.off_boundary)}{of} taxels fall off the surface (past an open edge, or past where "
                       "the surface's map can be trusted): move the patch, or lay fewer modules (triangle, fill)")
        if self.strain_max > max_strain:
            out.append(f"module edges stretch up to {100 * self.strain_max:.1f} % (limit {100 * max_strain:g} %): "
                       "the surface is too curved for this patch there; lay fewer modules (triangle, fill), "
                       "or raise the strain limit")
        return out

    @property
    def strain_max(self) -> float:
        return float(np.abs(self.strain).max()) if len(self.strain) else 0.0

    @property
    def strain_mean(self) -> float:
        return float(np.abs(self.strain).mean()) if len(self.strain) else 0.0

    def as_dict(self) -> dict:
        return {"method": self.method, "strain_max": self.strain_max, "strain_mean": self.strain_mean,
                # every overlapping pair an integrator has to act on: within the patch and with
                # modules already on the skin (the add-on shows this one number)
                "overlaps": len(self.overlaps) + len(self.existing_overlaps),
                "overlaps_within": len(self.overlaps), "overlaps_existing": len(self.existing_overlaps),
                "overlap_pairs": [list(map(int, p)) for p in self.overlaps],
                "existing_overlap_pairs": [list(map(int, p)) for p in self.existing_overlaps],
                "off_boundary": [int(i) for i in self.off_boundary], "coverage": _f(self.coverage),
                "surface_distance_max_m": float(self.surface_distance_max), "seconds": float(self.seconds),
                "charts": int(self.charts), "seam_modules": int(self.seam_modules),
                "normal_outliers": [int(i) for i in self.normal_outliers],
                "normal_deviation_max_deg": float(self.normal_deviation_max),
                "at_distance_m": float(self.at_distance),
                "notes": list(self.notes)}


def _f(x):
    return None if x is None or not np.isfinite(x) else float(x)


def arc_lengths(p: np.ndarray, q: np.ndarray, n_p: np.ndarray, n_q: np.ndarray) -> np.ndarray:
    """Length of the circular arc through ``p`` and ``q`` whose normals turn from ``n_p`` to ``n_q``:
    chord * (theta/2) / sin(theta/2). Exact on spheres and along circles of cylinders."""
    chord = np.linalg.norm(q - p, axis=1)
    cosang = np.clip(np.einsum("ij,ij->i", n_p, n_q), -1.0, 1.0)
    half = np.arccos(cosang) / 2
    factor = np.where(half > 1e-8, half / np.where(half > 1e-8, np.sin(half), 1.0), 1.0)
    return chord * factor


def layout_strain(layout: Layout, flat: np.ndarray, edges: np.ndarray) -> np.ndarray:
    """(E,) strain of ``edges`` (E, 2) of ``layout`` against ``flat`` (N, 2) coordinates."""
    if not len(edges):
        return np.zeros(0)
    i, j = edges[:, 0], edges[:, 1]
    lf = np.linalg.norm(flat[i] - flat[j], axis=1)
    ls = arc_lengths(layout.positions[i], layout.positions[j], layout.normals[i], layout.normals[j])
    return ls / np.where(lf > 0, lf, np.nan) - 1.0


def find_overlaps(positions: np.ndarray, module_ids: np.ndarray, min_distance: float) -> list:
    """Module pairs (a < b) that have taxels closer than ``min_distance`` metres."""
    if len(positions) < 2:
        return []
    pairs = cKDTree(positions).query_pairs(min_distance, output_type="ndarray")
    if not len(pairs):
        return []
    a, b = module_ids[pairs[:, 0]], module_ids[pairs[:, 1]]
    cross = a != b
    mp = np.unique(np.sort(np.column_stack([a[cross], b[cross]]), axis=1), axis=0)
    return [tuple(map(int, r)) for r in mp]


def find_overlaps_between(existing: Layout, positions: np.ndarray, module_ids: np.ndarray,
                          min_distance: float) -> list:
    """(existing_module, new_module) pairs with taxels closer than ``min_distance`` metres.

    existing : the layout already on the skin. positions : (n, 3) metres and module_ids :
    (n,) of the new taxels, in the same frame. A pair appears once.
    """
    if existing is None or len(existing) == 0 or len(positions) == 0:
        return []
    hits = cKDTree(np.asarray(existing.positions)).query_ball_point(np.asarray(positions), min_distance)
    counts = np.array([len(h) for h in hits])
    if not counts.sum():
        return []
    new = np.repeat(np.asarray(module_ids), counts)
    old = np.asarray(existing.module_ids)[np.concatenate([np.asarray(h, np.int64) for h in hits if len(h)])]
    mp = np.unique(np.column_stack([old, new]), axis=0)
    return [tuple(map(int, r)) for r in mp]


def overlap_note(pairs: list) -> str:
    a = len({p[1] for p in pairs})
    b = len({p[0] for p in pairs})
    return (f"{a} module(s) of this patch overlap {b} module(s) already on the skin "
            f"({len(pairs)} pairs; taxels closer than {OVERLAP_FRACTION} pitch)")


def coverage_of(mesh, patch: Patch, lm, region, extent) -> float:
    """Fraction of the region's area under module outlines (in the flat domain of the log map)."""
    if lm is None:
        return float("nan")
    F = np.asarray(lm.mesh.faces)
    area = lm.mesh.area_faces
    cent = lm.uv[F].mean(axis=1)
    reach = lm.reachable[F].all(axis=1)
    if region is None:
        sel = (np.hypot(*cent.T) <= float(np.hypot(*patch.flat.T).max())) & reach
    else:
        region = np.asarray(region, dtype=bool)
        if len(region) != len(mesh.faces):
            raise InputError(f"region has {len(region)} entries, the mesh {len(mesh.faces)} faces", key="region")
        # the log map's mesh is a cleaned crop: match faces by centroid
        c3 = np.asarray(lm.mesh.triangles_center)
        _, near = cKDTree(np.asarray(mesh.triangles_center)).query(c3)
        sel = region[near] & reach
    if not sel.any():
        return float("nan")
    inside = points_in_outlines(cent[sel], patch)
    return float(area[sel][inside].sum() / area[sel].sum())


def points_in_outlines(points: np.ndarray, patch: Patch) -> np.ndarray:
    """(n,) bool: which flat points (n, 2) lie inside some module outline of ``patch``."""
    out = np.zeros(len(points), bool)
    if not patch.n_modules or not len(points):
        return out
    outl = patch.outlines()  # (M, m, 2)
    tree = cKDTree(patch.poses[:, 1:])
    cand = tree.query_ball_point(points, patch.module.radius)
    rows = np.repeat(np.arange(len(points)), [len(c) for c in cand])
    mods = np.concatenate([np.asarray(c, dtype=np.int64) for c in cand]) if len(rows) else np.zeros(0, np.int64)
    if not len(rows):
        return out
    poly = outl[mods]  # (K, m, 2), counter-clockwise convex outlines
    edge = np.roll(poly, -1, axis=1) - poly
    rel = points[rows][:, None, :] - poly
    cross = edge[..., 0] * rel[..., 1] - edge[..., 1] * rel[..., 0]
    ins = np.all(cross >= 0, axis=1) | np.all(cross <= 0, axis=1)
    out[rows[ins]] = True
    return out


def coverage_by_frames(centres: np.ndarray, areas: np.ndarray, frames: np.ndarray, angles: np.ndarray,
                       mod) -> float:
    """Area of the faces (centres (F, 3), areas (F,)) under some module outline, each module
    given by its frame (M, 3, 3: origin, lattice x axis, normal) and its angle (M,) to the
    lattice x axis; a face centre is projected on a module's tangent plane (a module is small
    against the curvature it sits on)."""
    if not len(frames) or not len(centres):
        return 0.0
    o, x, n = frames[:, 0], frames[:, 1], frames[:, 2]
    y = np.cross(n, x)
    # the k nearest module origins within a module radius, as arrays (query_ball_point's lists of
    # lists cost seconds on 100k face centres); modules do not overlap, so a handful are near a
    # point: k doubles until the farthest answer is past the radius
    tree, k = cKDTree(o), min(8, len(o))
    while True:
        d, ms = tree.query(centres, k=k, distance_upper_bound=mod.radius, workers=-1)  # same answer, both cores
        d, ms = d.reshape(len(centres), -1), ms.reshape(len(centres), -1)
        if k >= len(o) or not np.isfinite(d[:, -1]).any():
            break
        k = min(2 * k, len(o))
    hit = np.isfinite(d)
    rows = np.nonzero(hit)[0]
    if not len(rows):
        return 0.0
    ms = ms[hit]
    rel = centres[rows] - o[ms]
    # within a module radius along the normal too: not the other side of a thin part
    near = np.abs(np.einsum("ij,ij->i", rel, n[ms])) < 0.5 * mod.radius
    u, v = np.einsum("ij,ij->i", rel, x[ms]), np.einsum("ij,ij->i", rel, y[ms])
    c, s = np.cos(angles[ms]), np.sin(angles[ms])
    local = np.column_stack([c * u + s * v, -s * u + c * v])
    poly = mod.outline
    edge = np.roll(poly, -1, axis=0) - poly
    r = local[:, None, :] - poly[None]
    cr = edge[None, :, 0] * r[..., 1] - edge[None, :, 1] * r[..., 0]
    ins = np.all(cr >= 0, axis=1) & near
    covered = np.zeros(len(centres), bool)
    covered[rows[ins]] = True
    return float(areas[covered].sum())


def module_edge_strain(layout: Layout, module) -> tuple[np.ndarray, np.ndarray]:
    """``(per_taxel (N,), edges (E,))``: the largest |strain| of the module edges at each taxel of
    ``layout``, and the |strain| of every module edge, judged against the
    module type's own flat geometry (``module``: a :class:`~vtcore.layout.modules.ModuleType`), so
    any skin can be judged, however it was made (patches merged, modules moved, files read).

    A taxel's sensor (slot) comes from its id (CySkin: the low 4 bits; iCub: id modulo the slots);
    an edge is a pair of the module's taxels at most 1.25 pitch apart in the flat module; its strain
    is the arc through both taxels' normals over the flat length, minus one (as
    :func:`layout_strain`). Taxels with no edge (a sensor the module type lacks) get 0.
    """
    from .uids import cyskin_sensors

    n = len(layout)
    out = np.zeros(n)
    if not n:
        return out, np.zeros(0)
    ids = np.asarray(layout.taxel_ids, np.int64)
    sensors = ids % module.slots if module.id_scheme == "icub" else cyskin_sensors(ids)
    row_of = np.full(max(int(module.sensors.max()), int(sensors.max())) + 1, -1, np.int64)
    row_of[module.sensors] = np.arange(len(module.sensors))
    rows = row_of[np.clip(sensors, 0, len(row_of) - 1)]
    mods, mi = np.unique(layout.module_ids, return_inverse=True)
    table = np.full((len(mods), len(module.taxels)), -1, np.int64)
    ok = rows >= 0
    table[mi[ok], rows[ok]] = np.flatnonzero(ok)
    e = module.edges
    i, j = table[:, e[:, 0]].ravel(), table[:, e[:, 1]].ravel()
    flat = np.tile(np.linalg.norm(module.taxels[e[:, 0]] - module.taxels[e[:, 1]], axis=1), len(mods))
    both = (i >= 0) & (j >= 0)
    i, j, flat = i[both], j[both], flat[both]
    p, nrm = np.asarray(layout.positions), np.asarray(layout.normals)
    s = np.abs(arc_lengths(p[i], p[j], nrm[i], nrm[j]) / np.where(flat > 0, flat, np.nan) - 1.0)
    s = np.nan_to_num(s, nan=0.0)
    np.maximum.at(out, i, s)
    np.maximum.at(out, j, s)
    return out, s


def overlapping_taxels(positions: np.ndarray, module_ids: np.ndarray, min_distance: float) -> np.ndarray:
    """(N,) bool: taxels closer than ``min_distance`` metres to a taxel of another module."""
    out = np.zeros(len(positions), bool)
    if len(positions) < 2:
        return out
    pairs = cKDTree(positions).query_pairs(min_distance, output_type="ndarray")
    if len(pairs):
        cross = pairs[module_ids[pairs[:, 0]] != module_ids[pairs[:, 1]]]
        out[cross.ravel()] = True
    return out


def skin_report(layout: Layout, module, previous: dict | None = None, n_before: int | None = None) -> tuple:
    """The report of a whole skin after an edit (modules removed or moved), judged on the skin as it
    is, and the per-taxel values to colour it by.

    layout : every taxel of the skin. module : its ModuleType. previous : the report dict before
    the edit (its coverage is scaled by the module count, ``n_before`` modules before; the region
    is not re-measured) and its notes are dropped. Returns ``(report dict, strain (N,), overlap
    (N,) bool)``: the report has ``strain_max``, ``strain_mean`` (of the module edges' |strain|),
    ``overlaps`` (module pairs) with ``overlap_pairs``, ``coverage``; ``strain`` is the largest
    |strain| of the module edges at each taxel.
    """
    strain, edges = module_edge_strain(layout, module)
    gap = OVERLAP_FRACTION * module.pitch
    pairs = find_overlaps(np.asarray(layout.positions), np.asarray(layout.module_ids), gap)
    overlap = overlapping_taxels(np.asarray(layout.positions), np.asarray(layout.module_ids), gap)
    rep = {"method": (previous or {}).get("method", "edit"), "strain_max": float(edges.max()) if len(edges) else 0.0,
           "strain_mean": float(edges.mean()) if len(edges) else 0.0, "overlaps": len(pairs),
           "overlaps_within": len(pairs), "overlaps_existing": 0, "overlap_pairs": [list(p) for p in pairs],
           "existing_overlap_pairs": [], "notes": []}
    cov = (previous or {}).get("coverage")
    if cov is not None and n_before:
        rep["coverage"] = float(cov) * layout.n_modules / n_before
        rep["notes"].append("coverage scaled by the modules kept, the region not re-measured")
    return rep, strain, overlap
