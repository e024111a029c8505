"""Seed 000's experiment end to end: see an object, probe it, propagate, compare with the truth.

:func:`probe_object` builds the visual cloud of a :class:`CompliantObject`
(virtual depth cameras), samples contact points from it with a seed, probes
each (force control to p̄*, the end-effector along the normal at v) and applies
Eq. 1. :func:`true_field` is the dense ground-truth colour the probes sample.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..errors import InputError, UnreachableTargetError
from .cloud import two_cameras, visual_cloud
from .compliance import MIN_DISPLACEMENT, ProbeModel, TactilePointCloud
from .objects import CompliantObject


@dataclass
class ProbedObject:
    """A visual cloud and the tactile cloud probed on it.

    points, normals : (K, 3) visual cloud (metres, unit). tactile : the probes.
    touch_index : (n,) indices of the probed points in the cloud.
    truth : (K,) noise-free colour at every visual point (counts per metre).
    """

    obj: CompliantObject
    points: np.ndarray
    normals: np.ndarray
    tactile: TactilePointCloud
    touch_index: np.ndarray
    truth: np.ndarray
    meta: dict = field(default_factory=dict)


def true_field(obj: CompliantObject, points, probe: ProbeModel) -> np.ndarray:
    """Noise-free Eq. 1 colour at ``points`` (K, 3): what an ideal probe would measure, counts/m."""
    return probe.true_c(obj.stiffness(points))


def sample_touches(n_points: int, touches: int, rng) -> np.ndarray:
    """``touches`` distinct indices of the visual cloud, seeded, in the order they are probed.

    Not sorted: the order is the probing order (the first k touches of a run are a
    random subset, which Fig. 2 and the touches sweep of the benchmark rely on).
    """
    if touches < 1:
        raise InputError(f"must be >= 1, got {touches}", key="touches")
    if touches > n_points:
        raise InputError(f"asks for {touches} touches but the visual cloud has only {n_points} points",
                         key="touches")
    return np.random.default_rng(rng).choice(n_points, touches, replace=False)


def probe_object(obj: CompliantObject, touches: int, probe: ProbeModel | None = None, *, cameras=None,
                 n_points: int | None = 33676, rng=0, channels=("compliance",), probe_fn=None,
                 cloud=None, noise=None) -> ProbedObject:
    """Visual cloud + ``touches`` probes of ``obj`` (seed 000, Sects. 2.1 and 3).

    probe_fn : optional ``(points (n,3), normals (n,3)) -> (p_mean (n,), v_ss (n,3))``
    replacing the self-contained :class:`ProbeModel` (e.g. the contact simulator).
    cloud : optional ``(points (K, 3), normals (K, 3))`` visual cloud (e.g. read from a
    PLY) used instead of the cameras; it must be in the object's frame, metres.
    channels : ``("compliance",)`` or ``("compliance", "friction")``: friction is
    read from the object's field with 5 % noise (a stand-in for a sliding probe).
    noise : optional :class:`~vtcore.augment.probe_noise.ProbeNoise`, the position and
    contact-detection error of each touch; a touch whose measured displacement is
    non-physical is repeated, then rejected and replaced by another seeded point
    (``meta["probes_repeated"]``, ``meta["probes_rejected"]`` count them). Never fatal
    unless no valid touch can be found after five rounds of resampling.
    """
    rng = np.random.default_rng(rng)
    probe = probe or ProbeModel()
    cams = cameras if cameras is not None else two_cameras(target=_centre(obj))
    if cloud is None:
        pts, nrm = visual_cloud(obj.mesh, cams, n_points=n_points, rng=rng)
    else:
        pts, nrm = (np.asarray(a, dtype=np.float64) for a in cloud)
    idx = sample_touches(len(pts), touches, rng)
    if probe_fn is None:
        def probe_fn(vv, nn):
            return probe.probe(vv, nn, obj.stiffness(vv), rng=rng)
    p_mean, disp, stats = _touch(probe_fn, pts[idx], nrm[idx], noise, rng)
    # touches that gave no valid Eq. 1 sample (the target was unreachable, or the measured
    # displacement stayed non-physical after its repeats) are replaced by other seeded points
    for _ in range(5):
        bad = ~np.isfinite(disp)
        if not bad.any():
            break
        free = np.setdiff1d(np.arange(len(pts)), idx)
        if len(free) < bad.sum():
            break
        idx[bad] = rng.choice(free, int(bad.sum()), replace=False)
        p_mean[bad], disp[bad], more = _touch(probe_fn, pts[idx[bad]], nrm[idx[bad]], noise, rng)
        stats = {k: stats[k] + more[k] for k in stats}
    if not np.all(np.isfinite(disp)):
        raise UnreachableTargetError(f"{int((~np.isfinite(disp)).sum())} probes gave no valid sample (target "
                                     "unreachable or displacement non-physical) even after resampling their "
                                     "contact points")
    v, n = pts[idx], nrm[idx]
    unit = n / np.linalg.norm(n, axis=1, keepdims=True)
    v_ss = v - disp[:, None] * unit
    tactile = TactilePointCloud.from_probes(v, v_ss, p_mean, direction=-n)
    for ch in channels[1:]:
        if ch != "friction":
            raise InputError(f"unknown channel {ch!r}; valid: compliance, friction", key="channels")
        mu = obj.friction(v) * (1.0 + 0.05 * rng.standard_normal(len(v)))
        tactile = tactile.with_channel("friction", mu)
    return ProbedObject(obj, pts, nrm, tactile, idx, true_field(obj, pts, probe),
                        meta={"cameras": len(cams), **stats})


def _touch(probe_fn, v, n, noise, rng):
    """Probe at ``v``, ``n`` (m, 3) and measure each displacement: ``(p_mean (m,), disp (m,), counts)``.

    disp is NaN where the target was unreachable, or where the measured displacement is
    non-physical (at or below the smallest Eq. 1 accepts): with ``noise``
    (:class:`~vtcore.augment.probe_noise.ProbeNoise`) such a touch is first repeated with
    fresh detection and position errors. counts : ``probes_repeated`` and
    ``probes_rejected``, in touches (the prober counts unreachable targets itself).
    """
    p_mean, v_ss = probe_fn(v, n)
    p_mean = np.asarray(p_mean, dtype=np.float64).copy()
    unit = n / np.linalg.norm(n, axis=1, keepdims=True)
    disp = np.einsum("ij,ij->i", v - np.asarray(v_ss, float), unit)
    reached = np.isfinite(p_mean) & np.isfinite(disp)
    repeated = 0
    if noise is not None and reached.any():
        disp[reached], repeats, _ = noise.measure(disp[reached], p_mean[reached], rng)
        repeated = int(np.sum(repeats > 0))
    floor = noise.min_displacement if noise is not None else MIN_DISPLACEMENT
    physical = np.isfinite(disp) & (disp > floor) & (p_mean > 0)
    rejected = int(np.sum(reached & ~physical))
    disp[~physical] = np.nan
    return p_mean, disp, {"probes_repeated": repeated, "probes_rejected": rejected}


def _centre(obj) -> tuple:
    lo, hi = np.asarray(obj.mesh.bounds)
    return tuple((lo + hi) / 2)


def voxel_filter(points, voxel: float) -> np.ndarray:
    """Indices of one point per occupied voxel (the first), as the paper filters for display."""
    p = np.asarray(points, float)
    if len(p) == 0 or voxel <= 0:
        return np.arange(len(p))
    keys = np.floor((p - p.min(axis=0)) / voxel).astype(np.int64)
    _, first = np.unique(keys, axis=0, return_index=True)
    return np.sort(first)
