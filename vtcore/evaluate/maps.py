"""Detection threshold and localisation error at surface points, from a :class:`ResponseTable`.

For a probe at point ``s`` (normal ``n``, tangents ``e1, e2`` turned by the probe's yaw), a live
taxel ``j`` within the table's reach whose normal agrees with ``n`` (within 60 degrees) sits at the
offset ``d_j = P(x_j - s)`` in the tangent plane, rescaled to the 3-D distance ``|x_j - s|`` (closer
to the geodesic offset than the projection on a curved link). Its mean reading at force F is
``gain * r(F, d_j)`` counts (see probe.py for why a table look-up is the press).

* **Detection threshold** (N): the smallest force at which the strongest mean reading reaches
  ``k sigma`` (so at the threshold that taxel detects in half of the noise draws). Between tabulated
  forces log-log interpolation; below the first, proportional to the force. A point where even the
  largest tabulated force (or the force the layer bottoms out at) stays below is **undetectable**:
  its threshold is reported as that force with ``detectable = False`` (never NaN, never 0).
* **Localisation error** (m) at the reference force, expected over noise draws: each draw adds
  Gaussian noise of ``sigma`` counts to every reading and clips at 0 (the recordings are
  baseline-subtracted and clipped), keeps the taxels above ``k sigma``, and estimates the contact as
  the **reading-weighted centroid of those taxels' offsets in the tangent plane** (on the surface);
  the error is its distance from the probe. Draws in which no taxel detects are misses: the map
  gives the mean error over the detecting draws and the share of detecting draws; a point no draw
  detects has ``located = False`` and its error reported as ``error_cap``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import InputError
from ..geometry import tangent_frames
from .noise import SensorNoise
from .probe import ResponseTable

#: a taxel counts for a probe whose normal differs from its own by less than this (cos 60 degrees)
NORMAL_AGREEMENT = 0.5
#: taxels whose mean reading lies this many noise deviations below the gate are left out of the draws
#: (one passes the gate with odds 3.4e-6 per draw)
PRUNE_SIGMAS = 4.5
#: taxels among which the strongest reading at every force is sought (the strongest at the largest)
CANDIDATES = 8
#: (points x taxels x draws) values one chunk of the noise draws may hold
CHUNK_VALUES = 4_000_000


@dataclass
class Neighbours:
    """Taxels around each point: ``index (M, K)`` into the live taxels (``-1`` padding), tangent-plane
    offsets ``dx, dy (M, K)`` m of each taxel from the point (``inf`` for padding)."""

    index: np.ndarray
    dx: np.ndarray
    dy: np.ndarray

    def valid(self) -> np.ndarray:
        return self.index >= 0


def frames(normals: np.ndarray, yaw: float = 0.0, axis=None) -> tuple[np.ndarray, np.ndarray]:
    """Tangent frames ``(e1, e2)`` (M, 3) of unit ``normals`` (M, 3), turned by ``yaw`` radians.

    axis : (3,), (M, 3) (one per point; NaN rows: none) or None: ``e1`` (before the yaw) is ``axis``
    projected on the tangent plane (a link's long axis: the probe's orientation then means the same all
    round the link), else, and where the normal is within 5 degrees of ``axis``, vtcore's default
    tangent (world x, or y near x).
    """
    t1, t2 = tangent_frames(normals)
    if axis is not None:
        a = np.broadcast_to(np.asarray(axis, float).reshape(-1, 3), normals.shape)
        good = np.all(np.isfinite(a), axis=1)
        a = np.where(good[:, None], a, 0.0)
        t = a - normals * np.einsum("mc,mc->m", normals, a)[:, None]
        tn = np.linalg.norm(t, axis=1, keepdims=True)
        ok = good & (tn[:, 0] > np.sin(np.deg2rad(5.0)) * np.linalg.norm(a, axis=1))
        t1 = np.where(ok[:, None], t / np.maximum(tn, 1e-300), t1)
        t2 = np.where(ok[:, None], np.cross(normals, t1), t2)
    c, s = np.cos(yaw), np.sin(yaw)
    return c * t1 + s * t2, -s * t1 + c * t2


def neighbours(taxels: np.ndarray, taxel_normals: np.ndarray, points: np.ndarray, normals: np.ndarray,
               reach: float, yaw: float = 0.0, max_pairs: int = 50_000_000, axis=None) -> Neighbours:
    """The live taxels within ``reach`` (m) of each point, as tangent-plane offsets (see the module doc).

    taxels, taxel_normals : (N, 3); points, normals : (M, 3); axis : see :func:`frames`. Raises InputError when points x the most
    taxels around one point would exceed ``max_pairs``.
    """
    from scipy.spatial import cKDTree

    points = np.asarray(points, float).reshape(-1, 3)
    normals = np.asarray(normals, float).reshape(-1, 3)
    m = len(points)
    if not len(taxels) or not m:
        z = np.zeros((m, 0))
        return Neighbours(np.zeros((m, 0), np.int64), z, z.copy())
    tree = cKDTree(taxels)
    counts = tree.query_ball_point(points, reach, return_length=True)
    kmax = int(np.max(counts, initial=0))
    if kmax == 0:
        z = np.zeros((m, 0))
        return Neighbours(np.zeros((m, 0), np.int64), z, z.copy())
    if m * kmax > max_pairs:
        raise InputError(f"{m:,} points x {kmax} taxels within {reach * 1e3:.3g} mm exceed {max_pairs:,} pairs: "
                         "use a larger spacing", key="spacing")
    _, idx = tree.query(points, k=kmax, distance_upper_bound=reach)
    idx = np.asarray(idx, np.int64).reshape(m, kmax)
    idx[idx >= len(taxels)] = -1
    ok = idx >= 0
    safe = np.where(ok, idx, 0)
    d = taxels[safe] - points[:, None, :]
    e1, e2 = frames(normals, yaw, axis)
    dx = np.einsum("mkc,mc->mk", d, e1)
    dy = np.einsum("mkc,mc->mk", d, e2)
    planar = np.hypot(dx, dy)
    full = np.linalg.norm(d, axis=2)
    scale = np.where(planar > 1e-12, full / np.maximum(planar, 1e-300), 1.0)
    ok &= np.einsum("mkc,mc->mk", taxel_normals[safe], normals) > NORMAL_AGREEMENT
    idx[~ok] = -1
    return Neighbours(idx, np.where(ok, dx * scale, np.inf), np.where(ok, dy * scale, np.inf))


def readings(table: ResponseTable, k: int, nb: Neighbours, shift=(0.0, 0.0)) -> np.ndarray:
    """Mean readings (Pa) (M, K) of the neighbour taxels for a probe at tabulated force row ``k``,
    moved by ``shift`` (2,) m (or (M, 2)) in the tangent plane; 0 for padding."""
    sh = np.asarray(shift, float)
    sx = sh[..., 0][..., None] if sh.ndim == 2 else sh[0]
    sy = sh[..., 1][..., None] if sh.ndim == 2 else sh[1]
    valid = nb.valid()
    dx = np.where(valid, nb.dx - sx, 1e9)
    dy = np.where(valid, nb.dy - sy, 1e9)
    return np.where(valid, table.lookup(k, dx, dy), 0.0)


@dataclass
class Detection:
    """threshold : (M,) N; detectable : (M,) bool; force_cap : N (the threshold of undetectable points)."""

    threshold: np.ndarray
    detectable: np.ndarray
    force_cap: float


def detection_threshold(table: ResponseTable, nb: Neighbours, noise: SensorNoise) -> Detection:
    """Smallest force at which the strongest mean reading reaches ``k sigma`` at each point."""
    m = nb.index.shape[0]
    need = noise.threshold_pa
    # the strongest taxel at any force is among the strongest few at the largest force (the reading
    # falls with the offset at every force; only near-ties reorder): the other forces read those alone
    last = len(table.forces) - 1
    top_all = readings(table, last, nb)
    c = min(CANDIDATES, top_all.shape[1])
    cols = np.argsort(-top_all, axis=1, kind="stable")[:, :c]
    take = lambda a: np.take_along_axis(a, cols, axis=1)  # noqa: E731
    sub = Neighbours(take(nb.index), take(nb.dx), take(nb.dy))
    peaks = np.stack([readings(table, k, sub).max(axis=1, initial=0.0) if k < last else
                      top_all.max(axis=1, initial=0.0) for k in range(len(table.forces))], axis=1)
    f = table.forces
    cap = float(table.bottomed_at if table.bottomed_at is not None else f[-1])
    above = peaks >= need
    detectable = above.any(axis=1)
    first = np.argmax(above, axis=1)
    thr = np.full(m, cap)
    lin = detectable & (first == 0)
    thr[lin] = f[0] * need / peaks[lin, 0]
    mid = detectable & (first > 0)
    if mid.any():
        r = np.flatnonzero(mid)
        k1 = first[r]
        p0, p1 = peaks[r, k1 - 1], peaks[r, k1]
        lf0, lf1 = np.log(f[k1 - 1]), np.log(f[k1])
        # log-log between the forces; a zero reading below gives a linear step instead
        with np.errstate(divide="ignore", invalid="ignore"):
            t = np.where(p0 > 0, (np.log(need) - np.log(np.maximum(p0, 1e-300)))
                         / (np.log(p1) - np.log(np.maximum(p0, 1e-300))), (need - p0) / (p1 - p0))
        t = np.clip(np.nan_to_num(t, nan=1.0), 0.0, 1.0)
        thr[r] = np.where(p0 > 0, np.exp(lf0 + t * (lf1 - lf0)), f[k1 - 1] + t * (f[k1] - f[k1 - 1]))
    return Detection(thr, detectable, cap)


@dataclass
class Localisation:
    """error : (M,) m, expected over the detecting draws (``error_cap`` where none detects);
    detect_rate : (M,) share of draws with at least one taxel above k sigma; located : (M,) bool;
    error_noise_free : (M,) m, the estimator on the mean readings (``error_cap`` when none reaches k sigma);
    saturated : (M,) bool, some taxel's mean reading is at the read-out's ceiling (the press is too firm for
    the sensor there: its readings are flat-topped)."""

    error: np.ndarray
    detect_rate: np.ndarray
    located: np.ndarray
    error_noise_free: np.ndarray
    error_cap: float
    draws: int
    saturated: np.ndarray | None = None


def centroid_error(counts: np.ndarray, nb_dx: np.ndarray, nb_dy: np.ndarray, gate: float,
                   truth=(0.0, 0.0)) -> tuple[np.ndarray, np.ndarray]:
    """The estimator on readings ``counts (..., K)``: reading-weighted centroid of the taxels above
    ``gate`` counts; returns ``(error (...,) m from truth, detected (...,) bool)``."""
    w = np.where(counts > gate, counts, 0.0)
    tot = w.sum(axis=-1)
    det = tot > 0
    safe = np.where(det, tot, 1.0)
    cx = np.einsum("...k,...k->...", w, np.where(np.isfinite(nb_dx), nb_dx, 0.0)) / safe
    cy = np.einsum("...k,...k->...", w, np.where(np.isfinite(nb_dy), nb_dy, 0.0)) / safe
    return np.hypot(cx - truth[0], cy - truth[1]), det


def localisation_error(table: ResponseTable, nb: Neighbours, noise: SensorNoise, reference_force: float, *,
                       draws: int = 32, seed: int = 0, error_cap: float = 0.02) -> Localisation:
    """Expected localisation error of the centroid estimator at ``reference_force`` (N) over ``draws``
    noise draws (seeded: the same seed gives the same map)."""
    k = table.index(reference_force)
    return localise(noise.counts(readings(table, k, nb)), nb, noise, draws=draws, seed=seed, error_cap=error_cap)


def localise(mean: np.ndarray, nb: Neighbours, noise: SensorNoise, *, draws: int = 32, seed: int = 0,
             error_cap: float = 0.02) -> Localisation:
    """The estimator's expected error over noise draws, for mean readings ``mean (M, K)`` counts of the
    neighbour taxels ``nb`` (from the table, or from press-by-press solves: the same draws for the same
    shapes and seed)."""
    if int(draws) < 1:
        raise InputError(f"must be >= 1, got {draws}", key="draws")
    gate = noise.threshold_counts
    saturated = (mean >= noise.max_counts).any(axis=1) if mean.shape[1] else np.zeros(mean.shape[0], bool)
    nf_err, nf_det = centroid_error(mean, nb.dx, nb.dy, gate)
    # a taxel whose mean is more than PRUNE_SIGMAS deviations below the gate passes it in a draw with
    # odds below 3.4e-6: the draws keep only the others (the same columns for the same readings)
    keep = (nb.index >= 0) & (mean >= gate - PRUNE_SIGMAS * noise.sigma)
    kk = max(int(keep.sum(axis=1).max(initial=0)), 1) if mean.shape[1] else 0
    cols = np.argsort(~keep, axis=1, kind="stable")[:, :kk]
    mean = np.take_along_axis(mean, cols, axis=1)
    ok = np.take_along_axis(keep, cols, axis=1)
    nb = Neighbours(np.where(ok, np.take_along_axis(nb.index, cols, axis=1), -1),
                    np.where(ok, np.take_along_axis(nb.dx, cols, axis=1), np.inf),
                    np.where(ok, np.take_along_axis(nb.dy, cols, axis=1), np.inf))
    m = mean.shape[0]
    err = np.zeros(m)
    rate = np.zeros(m)
    if kk and noise.sigma > 0:
        rng = np.random.default_rng(seed)
        step = max(1, CHUNK_VALUES // max(1, kk * int(draws)))
        for s in range(0, m, step):
            sl = slice(s, s + step)
            z = rng.standard_normal((int(draws), min(step, m - s), kk), dtype=np.float32)
            # the read-out clips at 0 (baseline-subtracted recordings) and at its 16-bit ceiling
            c = np.clip(mean[sl][None] + noise.sigma * z, 0.0, noise.max_counts)
            c[:, nb.index[sl] < 0] = 0.0
            e, det = centroid_error(c, nb.dx[sl][None], nb.dy[sl][None], gate)
            n_det = det.sum(axis=0)
            rate[sl] = n_det / draws
            err[sl] = np.where(n_det > 0, (e * det).sum(axis=0) / np.maximum(n_det, 1), 0.0)
    elif kk:
        rate = nf_det.astype(float)
        err = nf_err
    located = rate > 0
    return Localisation(np.where(located, np.minimum(err, error_cap), error_cap), rate, located,
                        np.where(nf_det, np.minimum(nf_err, error_cap), error_cap), float(error_cap), int(draws),
                        saturated)
