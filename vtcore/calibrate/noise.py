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

One offset per taxel and segment: the acquisition re-zeroes each file, and after a press a
taxel's baseline can sit elsewhere (pooling the offsets of the shared touched recordings' idle
stretches inflated the median sigma from ~190 to ~260 counts).
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
    offset : (N,) counts, mean of the unclipped reading (the acquisition's own baseline error),
        averaged over the segments where the taxel rose above the clip at least once.
    drift : (N,) counts/s, linear trend within a segment (time centred per segment).
    sigma_se, offset_se, drift_se : (N,) standard errors from the inverse observed information.
    censored : (N,) fraction of samples at or below the clip level. n : (N,) samples used.
    lag1 : (N,) lag-1 correlation of the unclipped noise from the sign sequence (Sheppard:
        rho = sin(pi/2 r_sign), exact for a zero-median Gaussian process; pairs within a segment).
    iterations : Newton iterations run. converged : bool (every identifiable taxel).
    segment_offset : (S, N) counts, each segment's own offset (NaN where the taxel never rose above
        the clip in that segment, or is not identified).
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
    segment_offset: np.ndarray | None = None


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


def _loglik(off, dt, theta, onehot, tc, yy, cens, w, clip):
    """Per-taxel Tobit log-likelihood (N,) in Olsen's parameters: off (S, N) segment offsets / sigma,
    dt (N,) drift / sigma, theta (N,) = 1 / sigma."""
    xd = onehot @ off + tc[:, None] * dt                  # (T, N)
    lp, _ = _log_mills(theta * clip - xd)
    r = theta * yy - xd
    ll = np.where(cens, lp, np.log(theta) - 0.5 * r * r)
    return (w * ll).sum(axis=0)


@dataclass
class _Tobit:
    """The data of a censored fit, laid out once: T samples, N taxels, S segments.

    y, yy : (T, N) counts (yy: 0 where not valid); tc : (T,) s, time centred per segment (0 without
    drift); ok : (T, N) valid; sid : (T,) segment index; onehot : (T, S); cens0 : (T, N) at or
    below the clip; live : (S, N) pairs with a sample above the clip; w : (T, N) weight of a
    sample (0 for dead pairs); cens : (T, N) censored and weighted; clip : counts.
    """

    y: np.ndarray
    yy: np.ndarray
    tc: np.ndarray
    ok: np.ndarray
    sid: np.ndarray
    onehot: np.ndarray
    cens0: np.ndarray
    live: np.ndarray
    w: np.ndarray
    cens: np.ndarray
    clip: float

    def loglik(self, off, dt, theta):
        return _loglik(off, dt, theta, self.onehot, self.tc, self.yy, self.cens, self.w, self.clip)


def _tobit_data(segments, clip: float, fit_drift: bool) -> _Tobit:
    """Stack the segments and mark which (segment, taxel) pairs carry information."""
    y, tc, ok, sid = _stack(segments)
    if not fit_drift:
        tc = np.zeros_like(tc)
    _, sid = np.unique(sid, return_inverse=True)
    n_seg = int(sid.max()) + 1
    onehot = np.zeros((len(y), n_seg))
    onehot[np.arange(len(y)), sid] = 1.0                 # (T, S)
    cens0 = ok & (y <= clip)
    obs_seg = onehot.T @ (ok & ~cens0).astype(float)     # (S, N) samples above the clip per segment
    live = obs_seg > 0                                   # (S, N) pairs that carry information
    w = ok.astype(float) * (onehot @ live.astype(float))  # drop the samples of dead pairs
    cens = cens0 & (w > 0)
    yy = np.where(ok, y, 0.0)
    return _Tobit(y, yy, tc, ok, sid, onehot, cens0, live, w, cens, clip)


def _newton_direction(d: _Tobit, off, dt, theta, ident, fit_drift: bool):
    """One Newton direction for all taxels: ``step_a (S, N)`` in the offsets, ``step_b (N, 2)`` in
    (drift, theta), and the Hessian's diagonal block ``A (S, N)`` and Schur complement ``S_ (N, 2, 2)``
    (for the standard errors)."""
    onehot, tc, yy, w, clip, live = d.onehot, d.tc, d.yy, d.w, d.clip, d.live
    n_tax = len(theta)
    wu_ = w * (~d.cens)
    xd = onehot @ off + tc[:, None] * dt
    a = theta * clip - xd
    _, lam = _log_mills(a)
    k = lam * (a + lam)                              # in (0, 1): the censored curvature
    r = theta * yy - xd
    wc = w * d.cens
    q = wu_ + wc * k                                 # (T, N) curvature weight of a location shift
    e = wu_ * r - wc * lam                           # (T, N) score of a location shift
    cy = wu_ * yy + wc * k * clip                    # (T, N) cross term with theta
    g_a = onehot.T @ e                               # (S, N)
    g_b = np.stack([(e * tc[:, None]).sum(0), (wu_ * (1.0 / theta - r * yy) + wc * lam * clip).sum(0)], 1)
    A = -(onehot.T @ q)                              # (S, N) diagonal block
    A = np.where(live, A, -1.0)                      # dead pairs: a dummy, zero-gradient coordinate
    g_a = np.where(live, g_a, 0.0)
    B = np.stack([-(onehot.T @ (q * tc[:, None])), onehot.T @ cy], axis=2)   # (S, N, 2)
    B = np.where(live[..., None], B, 0.0)
    C = np.empty((n_tax, 2, 2))
    C[:, 0, 0] = -(q * tc[:, None] ** 2).sum(0) - (0.0 if fit_drift else 1.0)
    C[:, 0, 1] = C[:, 1, 0] = (cy * tc[:, None]).sum(0)
    C[:, 1, 1] = -(wu_ * (1.0 / theta**2 + yy * yy) + wc * k * clip * clip).sum(0)
    # Schur complement of the diagonal block: (C - B' A^-1 B) y = -g_b + B' A^-1 g_a
    ainv = 1.0 / A
    S_ = C - np.einsum("sni,sn,snj->nij", B, ainv, B) - 1e-12 * np.eye(2)
    rhs = -g_b + np.einsum("sni,sn,sn->ni", B, ainv, g_a)
    step_b = np.linalg.solve(S_, rhs[..., None])[..., 0]          # (N, 2)
    step_a = ainv * (-g_a - np.einsum("sni,ni->sn", B, step_b))   # (S, N)
    step_a[:, ~ident] = 0.0
    step_b[~ident] = 0.0
    if not fit_drift:
        step_b[:, 0] = 0.0
    return step_a, step_b, A, S_


def _halve_steps(d: _Tobit, off, dt, theta, step_a, step_b, ll):
    """Step halving, per taxel, until the log-likelihood does not fall and theta stays > 0
    (at most 40 halvings). Returns the new ``(off, dt, theta, loglik)`` and each taxel's step length."""
    t_len = np.ones(len(theta))
    for _ in range(40):
        no = off + t_len * step_a
        nd = dt + t_len * step_b[:, 0]
        nt = theta + t_len * step_b[:, 1]
        bad = nt <= 0
        nt = np.where(bad, theta, nt)
        nll = d.loglik(no, nd, nt)
        worse = bad | ~(nll >= ll - 1e-12 * np.abs(ll))
        if not worse.any():
            break
        t_len = np.where(worse, t_len / 2, t_len)
    return no, nd, nt, nll, t_len


def _sign_lag1(d: _Tobit, n) -> np.ndarray:
    """``(N,)``: lag-1 correlation of the sign ``y > clip`` within segments, mean removed."""
    sgn = np.where(d.y > d.clip, 1.0, -1.0)
    same = (d.sid[1:] == d.sid[:-1])[:, None] & d.ok[1:] & d.ok[:-1]
    r1 = np.where(same, sgn[1:] * sgn[:-1], 0.0).sum(axis=0) / np.maximum(same.sum(axis=0), 1)
    pbar = np.where(d.ok, sgn, 0.0).sum(axis=0) / np.maximum(n, 1)
    return (r1 - pbar**2) / np.maximum(1 - pbar**2, 1e-9)


def censored_normal_fit(segments, *, clip: float = 0.0, min_observed: int = 5, max_iter: int = 100,
                        tol: float = 1e-9, fit_drift: bool = True) -> NoiseFit:
    """Fit ``y = offset_s + drift (t - t_s) + N(0, sigma^2)`` per taxel, observed as ``max(y, clip)``.

    segments : list of ``(values (T, N), timestamps (T,) s, valid (T, N) bool)``: runs of idle
        frames in counts (a file, or a stretch of one away from any contact). Each segment has its
        own offset per taxel (the acquisition re-zeroes each file, and after a press a taxel's
        baseline can sit elsewhere); sigma and the drift rate are shared. ``valid`` False (an
        unrecorded taxel) drops the sample.
    clip : the level the recorder clips at (counts): a sample ``<= clip`` means ``y <= clip``.
    min_observed : taxels with fewer samples above the clip get NaN (not identifiable).
    fit_drift : fit the within-segment slope (else drift is 0).

    A segment in which a taxel never rises above the clip says only that its offset there lies far
    below: its likelihood is maximal as that offset goes to minus infinity, where it carries no
    information about sigma, so such (segment, taxel) pairs are left out (the exact limit). The
    Newton step uses the Hessian's arrow shape (diagonal in the segment offsets, dense in drift and
    sigma) through its Schur complement, vectorised over taxels.
    """
    d = _tobit_data(segments, clip, fit_drift)
    ok, w, onehot, live = d.ok, d.w, d.onehot, d.live
    n = ok.sum(axis=0).astype(float)
    n_obs = ((~d.cens0) & ok).sum(axis=0)
    ident = n_obs >= min_observed
    # start: per-segment means of the observed samples, sigma from the naive spread (floored at 1)
    wsum = onehot.T @ w
    mu0 = (onehot.T @ (w * d.yy)) / np.maximum(wsum, 1)     # (S, N)
    sd0 = np.sqrt(np.maximum((w * (d.yy - onehot @ mu0) ** 2).sum(0) / np.maximum(w.sum(0), 1), 1.0))
    theta = 1.0 / sd0
    off = mu0 * theta
    dt = np.zeros(d.y.shape[1])
    ll = d.loglik(off, dt, theta)
    it, converged = 0, False
    for it in range(1, max_iter + 1):
        step_a, step_b, A, S_ = _newton_direction(d, off, dt, theta, ident, fit_drift)
        off, dt, theta, nll, t_len = _halve_steps(d, off, dt, theta, step_a, step_b, ll)
        gain = nll - ll
        ll = nll
        size = np.maximum(np.abs(step_a).max(axis=0), np.abs(step_b).max(axis=1)) * t_len
        if np.all(np.abs(gain[ident]) <= tol * (1 + np.abs(ll[ident]))) and np.all(size[ident] <= 1e-7):
            converged = True
            break
    sigma = 1.0 / theta
    # standard errors: the inverse observed information of (drift/sigma, theta) after the offsets
    # (the Schur complement), mapped back by the delta method; the offsets' own errors from A
    cov_b = np.linalg.inv(-S_)
    drift = dt * sigma
    se_sigma = np.sqrt(np.maximum(cov_b[:, 1, 1], 0)) * sigma * sigma
    se_drift = np.sqrt(np.maximum(cov_b[:, 0, 0] * sigma**2 + drift**2 * sigma**2 * cov_b[:, 1, 1]
                                  - 2 * drift * sigma**2 * cov_b[:, 0, 1], 0))
    seg_n = onehot.T @ w
    wts = seg_n / np.maximum(seg_n.sum(axis=0), 1)
    offset = (wts * off).sum(axis=0) * sigma             # sample-weighted mean offset over the live segments
    se_off = np.sqrt((wts**2 * np.where(live, -1.0 / A, 0.0)).sum(axis=0)) * sigma
    r_sign = _sign_lag1(d, n)

    def nan_unless(v):
        return np.where(ident, v, np.nan)

    return NoiseFit(sigma=nan_unless(sigma), offset=nan_unless(offset),
                    drift=nan_unless(drift) if fit_drift else np.where(ident, 0.0, np.nan),
                    sigma_se=nan_unless(se_sigma), offset_se=nan_unless(se_off),
                    drift_se=nan_unless(se_drift) if fit_drift else np.where(ident, 0.0, np.nan),
                    censored=np.where(n > 0, (d.cens0 & ok).sum(axis=0) / np.maximum(n, 1), np.nan), n=n,
                    lag1=nan_unless(np.sin(np.pi / 2 * np.clip(r_sign, -1, 1))), iterations=it,
                    converged=converged,
                    segment_offset=np.where(live & ident[None, :], off * sigma[None, :], np.nan))


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
