"""What a press looks like on the skin, in numbers: the footprint metrics of one frame.

For a frame of counts on a layout (the same definitions for a real and a simulated frame):

* ``peak``: the largest reading (counts) and its taxel;
* ``active``: taxels within ``radius`` (30 mm) of the peak taxel reading more than ``k`` of their
  own noise deviations;
* ``ring1`` / ``ring2``: the mean reading of the taxels 0-9.8 mm / 9.8-16.5 mm from the peak taxel,
  over the peak (the first and second ring of neighbours on a ~7 mm pitch skin; the peak taxel
  itself excluded);
* ``major_mm`` / ``minor_mm``: the principal radii of the footprint, the square roots of the two
  largest eigenvalues of the reading-weighted covariance of the active taxels' positions.

Distances are 3-D (on the shared curved patch, R ~ 76 mm, the chord is within 0.4 % of the arc
at 16.5 mm). Unrecorded taxels (NaN) are left out of every mean and count.
"""

from __future__ import annotations

import numpy as np

RING1_M = 0.0098
RING2_M = 0.0165
RADIUS_M = 0.030
METRICS = ("active", "ring1", "ring2", "major_mm", "minor_mm", "peak")


def footprint_metrics(counts, positions, sigma, *, k: float = 5.0, radius: float = RADIUS_M,
                      ring1: float = RING1_M, ring2: float = RING2_M) -> dict:
    """Metrics of frames ``counts`` (K, N) (NaN: not recorded) -> dict of (K,) arrays (METRICS), plus
    ``peak_taxel`` (K,) int. positions (N, 3) m; sigma (N,) counts."""
    c = np.atleast_2d(np.asarray(counts, float))
    pos = np.asarray(positions, float)
    sig = np.asarray(sigma, float)
    kk = len(c)
    rec = np.isfinite(c)
    cz = np.where(rec, c, -np.inf)
    pk = np.argmax(cz, axis=1)
    peak = c[np.arange(kk), pk]
    d = np.linalg.norm(pos[None, :, :] - pos[pk][:, None, :], axis=2)      # (K, N)
    cv = np.where(rec, c, 0.0)
    with np.errstate(invalid="ignore", divide="ignore"):
        def ring(lo, hi):
            sel = rec & (d > lo) & (d <= hi)
            sel[np.arange(kk), pk] = False
            n = sel.sum(axis=1)
            return np.where(n > 0, (cv * sel).sum(axis=1) / np.maximum(n, 1) / np.where(peak > 0, peak, np.nan),
                            np.nan)

        act = rec & (cv > k * sig[None, :]) & (d <= radius)
        w = np.where(act, cv, 0.0)
        ws = w.sum(axis=1)
        mu = np.einsum("kn,ni->ki", w, pos) / np.where(ws > 0, ws, 1.0)[:, None]
        rel = pos[None, :, :] - mu[:, None, :]
        cov = np.einsum("kn,kni,knj->kij", w, rel, rel) / np.where(ws > 0, ws, 1.0)[:, None, None]
        ev = np.linalg.eigvalsh(cov)                                         # ascending
        major = np.sqrt(np.maximum(ev[:, 2], 0.0)) * 1e3
        minor = np.sqrt(np.maximum(ev[:, 1], 0.0)) * 1e3
        return {"active": act.sum(axis=1).astype(float), "ring1": ring(0.0, ring1), "ring2": ring(ring1, ring2),
                "major_mm": np.where(ws > 0, major, np.nan), "minor_mm": np.where(ws > 0, minor, np.nan),
                "peak": peak, "peak_taxel": pk}


def contact_geometry(counts, positions, normals, sigma, *, k: float = 5.0, radius: float = RADIUS_M):
    """Where and how a finger lies in each frame, from its footprint.

    Returns ``centre (K, 3)`` m (the reading-weighted centroid of the active taxels near the peak),
    ``normal (K, 3)`` (their weighted mean normal, unit), ``axis (K, 3)`` (the footprint's major
    principal direction projected on the tangent plane, unit) and ``elongation (K,)`` (major / minor
    principal radius; ~1: the axis is not defined by the footprint).
    """
    c = np.atleast_2d(np.asarray(counts, float))
    pos, nrm = np.asarray(positions, float), np.asarray(normals, float)
    sig = np.asarray(sigma, float)
    rec = np.isfinite(c)
    cv = np.where(rec, c, 0.0)
    pk = np.argmax(np.where(rec, c, -np.inf), axis=1)
    d = np.linalg.norm(pos[None] - pos[pk][:, None], axis=2)
    act = rec & (cv > k * sig[None, :]) & (d <= radius)
    act[np.arange(len(c)), pk] = True
    w = np.where(act, cv, 0.0)
    ws = np.maximum(w.sum(axis=1), 1e-300)[:, None]
    centre = (w @ pos) / ws
    n = (w @ nrm) / ws
    n /= np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-12)
    rel = pos[None] - centre[:, None]
    cov = np.einsum("kn,kni,knj->kij", w, rel, rel) / ws[:, :, None]
    proj = np.eye(3)[None] - n[:, :, None] * n[:, None, :]                 # tangent-plane projector
    cov_t = proj @ cov @ proj
    ev, vec = np.linalg.eigh(cov_t)
    axis = vec[:, :, 2]
    axis /= np.maximum(np.linalg.norm(axis, axis=1, keepdims=True), 1e-12)
    elong = np.sqrt(np.maximum(ev[:, 2], 0) / np.maximum(ev[:, 1], 1e-30))
    return centre, n, axis, elong
