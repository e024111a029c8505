"""Baseline, noise and drift of idle taxels whose counts are clipped at 0.

A CySkin recording holds baseline-subtracted counts clipped at 0: an idle taxel whose true
reading ``y = offset + drift (t - t_seg) + e`` (``e`` white, Gaussian, sigma) falls below 0
reads 0. About half the samples of an idle skin are such zeros, so the plain standard
deviation of the recorded values is far too small (the zeros pile up at one value: about half
the true sigma on the shared recordings) and their mean too large. The fit here is the
maximum-likelihood fit of a *censored* (Tobit) normal model per taxel.

In Olsen's parametrisation (``theta = 1 / sigma``, ``delta = (offset, drift) / sigma``) the
Tobit log-likelihood is concave, so Newton's method with step halving converges from any
start; it runs on all taxels at once with (N, 3, 3) Hessians (a per-taxel scipy optimiser
would be a Python loop over 600+ taxels; plain EM crawls where most samples are clipped).

One offset per taxel for all segments: the acquisition re-zeroes each file, but on the shared
idle recordings the offsets of a taxel differ between files by a median 0.2 sigma, which
inflates sigma by about 2 %; a separate offset per file would be unidentifiable for the taxels
that read 0 throughout a file (116 of 3,170 file-taxel pairs there).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import InputError


def _log_mills(a):
    """(log Phi(a), phi(a) / Phi(a)), stable for very negative ``a``."""
    from scipy.special import log_ndtr

    lp = log_ndtr(a)
    return lp, np.exp(-0.5 * a * a - 0.5 * np.log(2 * np.pi) - lp)


@dataclass
class NoiseFit:
    """Per-taxel censored-normal fit of idle samples.

    sigma : (N,) counts, white-noise standard deviation (NaN where a taxel has fewer than
        ``min_observed`` samples above the clip: it reads 0 nearly always, sigma is not identifiable).
    offset : (N,) counts, mean of the unclipped reading (the acquisition's own baseline error).
    drift : (N,) counts/s, linear trend within a segment (time centred per segment).
    sigma_se, offset_se, drift_se : (N,) standard errors from the inverse observed information.
    censored : (N,) fraction of samples at or below the clip level. n : (N,) samples used.
    lag1 : (N,) lag-1 correlation of the unclipped noise from the sign sequence (Sheppard:
        rho = sin(pi/2 r_sign), exact for a zero-median Gaussian process; pairs within a segment).
    iterations : Newton iterations run. converged : bool (every identifiable taxel).
    """

    sigma: np.ndarray
    offset: np.ndarray
    drift: np.ndarray
    sigma_se: np.ndarray
    offset_se: np.ndarray
    drift_se: np.ndarray
    censored: np.ndarray
    n: np.ndarray
    lag1: np.ndarray
    iterations: int
    converged: bool


def _stack(segments):
    """Concatenate ``[(values (T, N), timestamps (T,), valid)]`` -> y (T, N), tc (T,), ok (T, N), sid (T,)."""
    if not segments:
        raise InputError("no idle frames to estimate the noise from", key="recordings")
    ys, ts, vs, seg = [], [], [], []
    n_tax = None
    for s, (v, t, ok) in enumerate(segments):
        v = np.asarray(v, float)
        t = np.asarray(t, float).reshape(-1)
        if v.ndim != 2 or len(t) != len(v):
            raise InputError(f"segment {s}: values (T, N) and timestamps (T,) needed, got {v.shape}, {t.shape}",
                             key="segments")
        ok = np.broadcast_to(np.asarray(ok, bool), v.shape)
        if n_tax is None:
            n_tax = v.shape[1]
        elif v.shape[1] != n_tax:
            raise InputError(f"segment {s} has {v.shape[1]} taxels, the first {n_tax}", key="segments")
        if len(t) == 0:
            continue
        ys.append(v)
        ts.append(t - t.mean())
        vs.append(ok & np.isfinite(v))
        seg.append(np.full(len(t), s))
    if not ys:
        raise InputError("the idle segments hold no frames", key="recordings")
    return np.concatenate(ys), np.concatenate(ts), np.concatenate(vs), np.concatenate(seg)


def _loglik(delta, theta, X, yy, cens, w, clip):
    """Per-taxel Tobit log-likelihood (N,) in Olsen's parameters: delta (N, 2), theta (N,)."""
    xd = X @ delta.T                                   # (T, N)
    lp, _ = _log_mills(theta * clip - xd)
    r = theta * yy - xd
    ll = np.where(cens, lp, np.log(theta) - 0.5 * r * r)
    return (w * ll).sum(axis=0)


def censored_normal_fit(segments, *, clip: float = 0.0, min_observed: int = 5, max_iter: int = 100,
                        tol: float = 1e-9, fit_drift: bool = True) -> NoiseFit:
    """Fit ``y = offset + drift (t - t_seg) + N(0, sigma^2)`` per taxel, observed as ``max(y, clip)``.

    segments : list of ``(values (T, N), timestamps (T,) s, valid (T, N) bool)``: runs of idle
        frames in counts (a file, or a stretch of one away from any contact). ``valid`` False
        (an unrecorded taxel) drops the sample.
    clip : the level the recorder clips at (counts): a sample ``<= clip`` means ``y <= clip``.
    min_observed : taxels with fewer samples above the clip get NaN (not identifiable).
    fit_drift : fit the within-segment slope (else drift is 0).
    """
    y, tc, ok, sid = _stack(segments)
    n_t, n_tax = y.shape
    X = np.column_stack([np.ones(n_t), tc if fit_drift else np.zeros(n_t)])   # (T, 2)
    w = ok.astype(float)
    cens = ok & (y <= clip)
    yy = np.where(ok, y, 0.0)
    n = w.sum(axis=0)
    n_obs = ((~cens) & ok).sum(axis=0)
    ident = n_obs >= min_observed
    # start: the naive moments (sigma floored at 1 count)
    mu0 = (w * yy).sum(0) / np.maximum(n, 1)
    sd0 = np.sqrt(np.maximum((w * (yy - mu0) ** 2).sum(0) / np.maximum(n, 1), 1.0))
    theta = 1.0 / sd0
    delta = np.column_stack([mu0 * theta, np.zeros(n_tax)])
    ll = _loglik(delta, theta, X, yy, cens, w, clip)
    ridge = np.diag([0.0, 0.0 if fit_drift else 1.0, 0.0])   # keeps the unused drift column regular
    it, converged = 0, False
    XX = X[:, :, None] * X[:, None, :]                  # (T, 2, 2)
    for it in range(1, max_iter + 1):
        xd = X @ delta.T
        a = theta * clip - xd
        _, lam = _log_mills(a)
        k = lam * (a + lam)                             # in (0, 1): the censored curvature
        r = theta * yy - xd
        wc, wu = w * cens, w * (~cens)
        g_d = X.T @ (wu * r - wc * lam)                 # (2, N)
        g_t = (wu * (1.0 / theta - r * yy) + wc * lam * clip).sum(0)
        H_dd = -np.einsum("tij,tn->nij", XX, wu + wc * k)
        H_dt = (X.T @ (wu * yy + wc * k * clip)).T      # (N, 2)
        H_tt = -(wu * (1.0 / theta**2 + yy * yy) + wc * k * clip * clip).sum(0)
        H = np.zeros((n_tax, 3, 3))
        H[:, :2, :2], H[:, :2, 2], H[:, 2, :2], H[:, 2, 2] = H_dd, H_dt, H_dt, H_tt
        H -= ridge + 1e-12 * np.eye(3)
        g = np.column_stack([g_d.T, g_t])
        g[~ident] = 0.0
        step = -np.linalg.solve(H, g[..., None])[..., 0]   # Newton: H is negative definite
        t_len = np.ones(n_tax)
        for _ in range(30):                             # step halving, per taxel, keeping theta > 0
            nd = delta + t_len[:, None] * step[:, :2]
            nt = theta + t_len * step[:, 2]
            bad = nt <= 0
            nt = np.where(bad, theta, nt)
            nll = _loglik(nd, nt, X, yy, cens, w, clip)
            worse = bad | ~(nll >= ll - 1e-12 * np.abs(ll))
            if not worse.any():
                break
            t_len = np.where(worse, t_len / 2, t_len)
        delta, theta, gain = nd, nt, nll - ll
        ll = nll
        if np.all(np.abs(gain[ident]) <= tol * (1 + np.abs(ll[ident]))) and \
                np.all(np.abs(step[ident]).max(axis=1) * t_len[ident] <= 1e-7 * (1 + np.abs(theta[ident]))):
            converged = True
            break
    sigma = 1.0 / theta
    off, drift = delta[:, 0] * sigma, delta[:, 1] * sigma
    # standard errors: the inverse observed information mapped back by the delta method
    cov = np.linalg.inv(-H)                             # (N, 3, 3) in (delta, theta)
    J = np.zeros((n_tax, 3, 3))                         # d(offset, drift, sigma) / d(delta, theta)
    J[:, 0, 0] = J[:, 1, 1] = sigma
    J[:, 0, 2], J[:, 1, 2], J[:, 2, 2] = -off * sigma, -drift * sigma, -sigma * sigma
    cv = J @ cov @ np.transpose(J, (0, 2, 1))
    se = np.sqrt(np.maximum(np.diagonal(cv, axis1=1, axis2=2), 0.0))
    # lag-1 correlation of the sign within segments
    sgn = np.where(y > clip, 1.0, -1.0)
    same = (sid[1:] == sid[:-1])[:, None] & ok[1:] & ok[:-1]
    r1 = np.where(same, sgn[1:] * sgn[:-1], 0.0).sum(axis=0) / np.maximum(same.sum(axis=0), 1)
    pbar = np.where(ok, sgn, 0.0).sum(axis=0) / np.maximum(n, 1)
    r_sign = (r1 - pbar**2) / np.maximum(1 - pbar**2, 1e-9)

    def nan_unless(v):
        return np.where(ident, v, np.nan)

    return NoiseFit(sigma=nan_unless(sigma), offset=nan_unless(off),
                    drift=nan_unless(drift) if fit_drift else np.where(ident, 0.0, np.nan),
                    sigma_se=nan_unless(se[:, 2]), offset_se=nan_unless(se[:, 0]),
                    drift_se=nan_unless(se[:, 1]) if fit_drift else np.where(ident, 0.0, np.nan),
                    censored=np.where(n > 0, (cens & ok).sum(axis=0) / np.maximum(n, 1), np.nan), n=n,
                    lag1=nan_unless(np.sin(np.pi / 2 * np.clip(r_sign, -1, 1))), iterations=it,
                    converged=converged)


def summarise(values, rng=None, n_boot: int = 2000) -> dict:
    """Median, interquartile range and a 95 % bootstrap interval of the median of ``values`` (finite only)."""
    v = np.asarray(values, float)
    v = v[np.isfinite(v)]
    if v.size == 0:
        return {"median": float("nan"), "iqr": [float("nan")] * 2, "ci95": [float("nan")] * 2, "n": 0}
    rng = rng if rng is not None else np.random.default_rng(0)
    idx = rng.integers(0, v.size, size=(n_boot, v.size))
    meds = np.median(v[idx], axis=1)
    return {"median": float(np.median(v)), "iqr": [float(x) for x in np.percentile(v, [25, 75])],
            "ci95": [float(x) for x in np.percentile(meds, [2.5, 97.5])], "n": int(v.size)}
