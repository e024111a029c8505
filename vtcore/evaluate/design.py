"""Design maps of a skin: :func:`evaluate` (on a mesh) and :func:`evaluate_points` (at given points).

Composes the pieces: the probe's response table (probe.py), surface samples (samples.py), detection
and localisation (maps.py), two-point discrimination (two_point.py), and the blind spots: samples
whose detection threshold exceeds ``blind_limit`` (undetectable ones included), with their area.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np

from ..errors import InputError
from .maps import PRUNE_SIGMAS, Detection, Localisation, detection_threshold, localisation_error, neighbours
from .noise import SensorNoise, sensor_noise
from .probe import Probe, ResponseTable, default_forces, response_table
from .samples import SurfaceSamples, cover_radius, flattest_directions, sample_surface
from .two_point import TwoPoint, two_point_discrimination

_TABLES: dict = {}


@dataclass
class Settings:
    """Everything a map depends on besides the layout and the surface (metres, newtons).

    reference_force : N, the force of the localisation and two-point maps. force_max : N, the largest
    force tabulated (the threshold of undetectable points). blind_limit : N (None: reference_force).
    draws, seed : noise draws of the localisation map. two_point : compute it; two_point_spacing : m
    between its points (None: 2 x the sample spacing), step and max_separation of the separations,
    directions over half a turn. model, spreading, table_spacing, table_forces : the contact solve of
    the table (its cell, m, and how many forces from 0.02 N to force_max, log-spaced; spreading None:
    the taxels read the surface pressure).
    dead : taxel ids that read nothing. probe_axis : (3,) the direction the probe's long axis (and the
    first two-point orientation) follows on the surface; None: on a mesh (:func:`evaluate`) the
    surface's flattest direction where it has one (a finger lies along a link, not across it), else
    vtcore's default tangent. error_cap : m, the localisation error shown where nothing is
    detected.
    """

    probe: Probe = field(default_factory=Probe)
    reference_force: float = 5.0
    force_max: float = 20.0
    blind_limit: float | None = None
    draws: int = 32
    seed: int = 0
    two_point: bool = True
    two_point_spacing: float | None = None
    two_point_step: float = 1e-3
    max_separation: float = 0.05
    two_point_directions: int = 4
    model: str = "finite_layer"
    spreading: str | None = "layer"  # None: the taxels read the surface pressure (no soft_layer effect)
    table_spacing: float | None = None
    table_forces: int = 9
    dead: tuple = ()
    error_cap: float = 0.02
    probe_axis: tuple | None = None

    @property
    def limit(self) -> float:
        return float(self.reference_force if self.blind_limit is None else self.blind_limit)


@dataclass
class PointMaps:
    """The maps at M points: detection (threshold N, detectable), localisation (error m ...), two_point
    (or None), blind (M,) bool, and what they were computed with."""

    detection: Detection
    localisation: Localisation
    two_point: TwoPoint | None
    blind: np.ndarray
    table: ResponseTable
    noise: SensorNoise
    settings: Settings
    taxels_live: int
    seconds: dict


@dataclass
class DesignMap(PointMaps):
    """PointMaps on the :class:`SurfaceSamples` of a mesh, with the area-weighted summary."""

    samples: SurfaceSamples | None = None

    def summary(self) -> dict:
        """Flat metrics (snake_case, unit suffixes) over the covered surface and the margin."""
        s = self.samples
        out = {"samples": len(s), "taxels_live": self.taxels_live, "spacing_mm": s.spacing * 1e3,
               "covered_area_cm2": float(s.areas[s.covered].sum() * 1e4),
               "evaluated_area_cm2": float(s.areas.sum() * 1e4),
               "blind_area_covered_cm2": float(s.areas[s.covered & self.blind].sum() * 1e4),
               "blind_area_margin_cm2": float(s.areas[~s.covered & self.blind].sum() * 1e4),
               "blind_area_cm2": float(s.areas[self.blind].sum() * 1e4),
               "blind_limit_n": self.settings.limit, "reference_force_n": self.settings.reference_force,
               "noise_sigma_counts": self.noise.sigma, "noise_k": self.noise.k,
               "counts_per_pa": self.noise.counts_per_pa}
        cov = s.covered
        thr = self.detection.threshold
        out["undetectable_covered_fraction"] = _share(~self.detection.detectable[cov], s.areas[cov])
        if self.localisation.saturated is not None:
            out["saturated_covered_fraction"] = _share(self.localisation.saturated[cov], s.areas[cov])
        for name, values, ok, scale in (
                ("threshold_n", thr, self.detection.detectable, 1.0),
                ("localisation_mm", self.localisation.error, self.localisation.located, 1e3),
                ("two_point_mm", None if self.two_point is None else self.two_point.distance,
                 None if self.two_point is None else self.two_point.found, 1e3)):
            if values is None:
                continue
            for region, mask in (("covered", cov), ("all", np.ones_like(cov))):
                q = weighted_quantiles(values[mask], s.areas[mask], (0.5, 0.95))
                out[f"{name.rsplit('_', 1)[0]}_{region}_median_{name.rsplit('_', 1)[1]}"] = q[0] * scale
                out[f"{name.rsplit('_', 1)[0]}_{region}_p95_{name.rsplit('_', 1)[1]}"] = q[1] * scale
                out[f"{name.rsplit('_', 1)[0]}_{region}_valid_fraction"] = _share(ok[mask], s.areas[mask])
        out.update({f"seconds_{k}": v for k, v in self.seconds.items()})
        return out


def _share(flags, weights) -> float:
    w = np.asarray(weights, float)
    return float((w * flags).sum() / w.sum()) if w.sum() > 0 else 0.0


def weighted_quantiles(values, weights, qs) -> list[float]:
    """Quantiles ``qs`` of ``values`` weighted by ``weights`` (area): the smallest value whose
    cumulative weight reaches q of the total (0.0 for no values)."""
    v = np.asarray(values, float)
    w = np.asarray(weights, float)
    if not len(v) or w.sum() <= 0:
        return [0.0 for _ in qs]
    order = np.argsort(v, kind="stable")
    cw = np.cumsum(w[order]) / w.sum()
    return [float(v[order][min(int(np.searchsorted(cw, q - 1e-12)), len(v) - 1)]) for q in qs]


def live_taxels(layout, dead=()) -> np.ndarray:
    """(N,) bool: pressure taxels not listed in ``dead`` (taxel ids). Unknown ids are an error."""
    ids = np.asarray(layout.taxel_ids)
    dead = np.asarray(list(dead), dtype=np.int64).reshape(-1)
    missing = np.setdiff1d(dead, ids)
    if len(missing):
        raise InputError(f"taxel id(s) {missing[:5].tolist()} are not in the layout", key="dead")
    roles = np.asarray(layout.roles).astype(str)
    return (roles == "pressure") & ~np.isin(ids, dead)


def clear_tables() -> None:
    """Forget the response tables kept in memory (a benchmark's cold start)."""
    _TABLES.clear()


def table_for(settings: Settings, layer) -> ResponseTable:
    """The probe's response table for ``layer`` and ``settings`` (kept in memory: layouts compared on
    the same layer share it)."""
    forces = default_forces(settings.reference_force, settings.force_max, settings.table_forces)
    key = (settings.probe.kind, tuple(sorted(settings.probe.dims.items())), settings.probe.yaw,
           layer.thickness, layer.young_modulus, layer.poisson, layer.base, settings.model, settings.spreading,
           settings.table_spacing, tuple(forces))
    hit = _TABLES.get(key)
    if hit is None:
        hit = response_table(settings.probe, layer, forces=forces, spacing=settings.table_spacing,
                             model=settings.model, spreading=settings.spreading)
        if len(_TABLES) > 8:
            _TABLES.clear()
        _TABLES[key] = hit
    if hit.bottomed_at is not None and hit.bottomed_at <= settings.reference_force:
        raise InputError(f"the {settings.probe.describe()} bottoms out through the {layer.thickness * 1e3:g} mm layer "
                         f"at {hit.bottomed_at:.3g} N, below the reference force {settings.reference_force:g} N: use a "
                         "lower reference force, a thicker or stiffer layer or a larger probe", key="reference_force")
    return hit


def evaluate_points(layout, points, normals, layer, settings: Settings | None = None,
                    noise: SensorNoise | None = None, *, two_point_points=None, axes=None) -> PointMaps:
    """The maps at ``points (M, 3)`` with outward unit ``normals (M, 3)`` (the layout's frame, metres).

    layout : vtcore.layout.Layout; layer : vtcore.contact.SoftLayer. two_point_points : indices of the
    points where the two-point map is computed (None: all; the others take the nearest one's value).
    axes : (M, 3) per point, the direction the probe's long axis follows (NaN rows: the default), in
    place of ``settings.probe_axis``.
    """
    from ..layout import skin_mesh

    settings = settings or Settings()
    noise = noise or sensor_noise()
    points = np.asarray(points, float).reshape(-1, 3)
    normals = np.asarray(normals, float).reshape(-1, 3)
    if len(points) != len(normals):
        raise InputError(f"{len(points)} points but {len(normals)} normals", key="normals")
    nn = np.linalg.norm(normals, axis=1, keepdims=True)
    if not np.all(np.isfinite(points)) or not np.all(nn > 0):
        raise InputError("points must be finite and normals non-zero", key="points")
    normals = normals / nn
    seconds = {}
    t0 = time.perf_counter()
    table = table_for(settings, layer)
    seconds["table"] = time.perf_counter() - t0
    alive = live_taxels(layout, settings.dead)
    pos, nrm = layout.positions[alive], layout.normals[alive]
    t0 = time.perf_counter()
    # the taxels that can decide a point: those reaching k sigma at the largest force (no other taxel
    # ever detects, and the strongest reading at the force below the crossing is the crossing taxel's:
    # readings keep their order as the force grows, see maps.CANDIDATES) and, for the noise draws, those
    # within PRUNE_SIGMAS of the gate at the reference force (maps.localise keeps only these)
    reach = max(table.radius(len(table.forces) - 1, noise.threshold_pa),
                table.radius(table.index(settings.reference_force),
                             noise.pa_at(noise.threshold_counts - PRUNE_SIGMAS * noise.sigma)))
    axis = settings.probe_axis if axes is None else np.asarray(axes, float).reshape(-1, 3)
    nb = neighbours(pos, nrm, points, normals, reach, settings.probe.yaw, axis=axis)
    det = detection_threshold(table, nb, noise)
    seconds["detection"] = time.perf_counter() - t0
    t0 = time.perf_counter()
    loc = localisation_error(table, nb, noise, settings.reference_force, draws=settings.draws, seed=settings.seed,
                             error_cap=settings.error_cap)
    seconds["localisation"] = time.perf_counter() - t0
    tp = None
    if settings.two_point:
        t0 = time.perf_counter()
        sel = np.arange(len(points)) if two_point_points is None else np.asarray(two_point_points, np.int64)
        adj = skin_mesh(layout.subset(alive)).adjacency if alive.sum() >= 2 else None
        if adj is None:
            n = len(points)
            tp = TwoPoint(np.full(n, settings.max_separation), np.zeros(n, bool),
                          np.full((n, 1), settings.max_separation), np.zeros(1), np.zeros(0), settings.max_separation)
        else:
            sub = two_point_discrimination(table, pos, nrm, adj, points[sel], normals[sel], noise,
                                           settings.reference_force, directions=settings.two_point_directions,
                                           step=settings.two_point_step, max_separation=settings.max_separation,
                                           yaw=settings.probe.yaw,
                                           axis=axis if axes is None else axis[sel],
                                           min_separation=settings.probe.width())
            tp = _spread(sub, sel, points)
        seconds["two_point"] = time.perf_counter() - t0
    blind = ~det.detectable | (det.threshold > settings.limit)
    return PointMaps(det, loc, tp, blind, table, noise, settings, int(alive.sum()), seconds)


def _spread(sub: TwoPoint, sel, points) -> TwoPoint:
    """The two-point map at every point: its own value where computed, else the nearest computed one's."""
    if len(sel) == len(points):
        return sub
    from scipy.spatial import cKDTree

    _, near = cKDTree(points[sel]).query(points)
    return TwoPoint(sub.distance[near], sub.found[near], sub.per_direction[near], sub.directions, sub.separations,
                    sub.max_separation)


def thin_out(samples: SurfaceSamples, spacing: float) -> np.ndarray:
    """Indices of one sample per ``spacing``-sized voxel and side (the two-point map's points)."""
    vox = np.floor(samples.positions / spacing).astype(np.int64)
    ax = np.argmax(np.abs(samples.normals), axis=1)
    side = ax * 2 + (samples.normals[np.arange(len(ax)), ax] > 0)
    _, first = np.unique(np.column_stack([vox, side]), axis=0, return_index=True)
    return np.sort(first)


def evaluate(layout, mesh, layer, settings: Settings | None = None, noise: SensorNoise | None = None, *,
             spacing: float = 2e-3, margin: float = 10e-3, cover: float | None = None) -> DesignMap:
    """Design maps of ``layout`` on ``mesh`` (trimesh, metres, the layout's frame) through ``layer``.

    spacing : m between samples; margin : m of surface evaluated beyond the covered part (points
    within ``cover`` of a pressure taxel of the layout, dead ones included: their surface stays
    covered, and blind; default :func:`samples.cover_radius`). The layer is taken to cover
    the whole evaluated surface (a designer covers the link, not only the taxels).
    """
    settings = settings or Settings()
    alive = live_taxels(layout, settings.dead)
    if not alive.any():
        raise InputError("every taxel of the layout is dead or not a pressure taxel", key="dead")
    # the surface the design covers is the layout's, dead taxels included: a dead taxel leaves a hole
    # in the covered surface, not a gap that the margin then calls uncovered
    placed = live_taxels(layout, ())
    t0 = time.perf_counter()
    samples = sample_surface(mesh, layout.positions[placed], layout.normals[placed], spacing=spacing, margin=margin,
                             cover=cover_radius() if cover is None else cover)
    t_samples = time.perf_counter() - t0
    sel = None
    if settings.two_point:
        sel = thin_out(samples, settings.two_point_spacing or 2 * spacing)
    axes = None
    if settings.probe_axis is None:  # a finger lies along a link: the surface's flattest direction
        axes = flattest_directions(samples.positions, samples.normals)
    pm = evaluate_points(layout, samples.positions, samples.normals, layer, settings, noise, two_point_points=sel,
                         axes=axes)
    pm.seconds = {"samples": t_samples, **pm.seconds}
    return DesignMap(**{k: getattr(pm, k) for k in pm.__dataclass_fields__}, samples=samples)
