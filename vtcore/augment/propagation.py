"""Propagation of tactile colours from a few contact points to a whole point cloud.

Seed 000, Sect. 2.2-2.4 and its appendix:

- :class:`ClusterPropagation` (Eq. 2): every point takes the colour of its
  nearest contact point (a Voronoi partition of the cloud; the "clusters" of
  the paper have the contact points as centroids).
- :class:`SmoothPropagation` (Eqs. 3-4): a softmax over distances,
  ``c_k = sum_j softmax_j(beta * d_kj) c_j`` with ``beta < 0`` (per metre).
  The paper writes ``exp(-beta d)`` with ``beta = -300``, which would weight
  *far* contacts most; its text ("higher absolute values of beta lead to a
  representation similar to the cluster-based one") fixes the intended sign,
  which is the one used here: weights ``exp(beta * d)``, ``beta <= 0``.
- :class:`GPPropagation`: the Gaussian-process baseline of the appendix
  (scikit-learn's ``GaussianProcessRegressor``), optionally with the
  "artificially increased" tactile cloud (3 cm neighbourhoods, voxel 4 mm).
- :class:`AugmentedPointCloud`: a visual cloud whose colours are updated
  touch by touch at the cost of the new touch only (O(M) per touch for M
  points), not by recomputing all touches.

All estimators follow scikit-learn's shape: parameters in ``__init__``,
``fit(contact_points (n, 3), values (n,) or (n, k))`` returns ``self``,
``predict(points (M, 3)) -> (M,) or (M, k)``. Inputs of any float dtype are
computed in float64. Coordinates are in metres unless ``scale`` (metres per
coordinate unit, 1e-3 for millimetres) says otherwise; ``beta`` is always per
metre, so the same ``beta`` gives the same colours whatever the cloud's unit.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

from ..errors import InputError

#: Rows of the visual cloud processed at once by the dense smooth kernel: (rows x n)
#: temporaries stay in the CPU cache for n ~ 24 contacts.
_CHUNK = 16384

#: Up to this many contacts the nearest one is found by brute force, beyond by a KD-tree
#: (the benchmark sets it to 0 to time the KD-tree path on the same data).
BRUTE_FORCE_MAX = 64

#: Largest |coordinate| accepted (any unit): squared distances stay far from float64's 1.8e308.
COORD_MAX = 1e150


# ---------------------------------------------------------------------------
# validation
# ---------------------------------------------------------------------------

def _points(x, name: str, allow_empty: bool = True) -> np.ndarray:
    a = np.asarray(x)
    if a.dtype == object or not (np.issubdtype(a.dtype, np.floating) or np.issubdtype(a.dtype, np.integer)):
        raise InputError(f"must be numeric (n, 3) coordinates, got dtype {a.dtype}", key=name)
    a = np.asarray(a, dtype=np.float64)
    if a.ndim == 1 and a.size == 3:
        a = a.reshape(1, 3)
    if a.ndim == 1 and a.size == 0:
        a = a.reshape(0, 3)
    if a.ndim != 2 or a.shape[1] != 3:
        raise InputError(f"must have shape (n, 3), got {a.shape}", key=name)
    if not allow_empty and len(a) == 0:
        raise InputError("is empty: at least one point is needed", key=name)
    if not np.all(np.isfinite(a)):
        bad = int(np.flatnonzero(~np.isfinite(a).all(axis=1))[0])
        raise InputError(f"row {bad} is not finite", key=name)
    if a.size and np.abs(a).max() > COORD_MAX:
        # squared distances (the Gram expansion, KD-tree queries) overflow past ~1e154
        raise InputError(f"coordinates must be within +-{COORD_MAX:g} (in the cloud's unit), got "
                         f"{np.abs(a).max():g}", key=name)
    return np.ascontiguousarray(a)


def _values(v, n: int, name: str = "values") -> np.ndarray:
    a = np.asarray(v, dtype=np.float64)
    if a.ndim == 0 or a.ndim > 2 or a.shape[0] != n:
        raise InputError(f"must have shape ({n},) or ({n}, k) to match the contact points, got {a.shape}",
                         key=name)
    if not np.all(np.isfinite(a)):
        raise InputError("contains non-finite values", key=name)
    return np.ascontiguousarray(a)


def _check_fitted(est):
    if getattr(est, "contact_points_", None) is None:
        raise InputError(f"{type(est).__name__} is not fitted: call fit(contact_points, values) first")


def _empty_like_values(m: int, values: np.ndarray) -> np.ndarray:
    return np.empty((m,) + values.shape[1:], dtype=np.float64)


def merge_duplicates(points: np.ndarray, values: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Merge contact points at exactly the same position, averaging their values.

    Repeated probes of one point are repeated measurements of one colour; the
    nearest-contact rule would otherwise pick one of them arbitrarily.
    Returns ``(points (u, 3), values (u,) or (u, k))`` in first-seen order.
    """
    if len(points) == 0:
        return points, values
    _, first, inverse = np.unique(points, axis=0, return_index=True, return_inverse=True)
    inverse = inverse.reshape(-1)
    if len(first) == len(points):
        return points, values
    order = np.argsort(first)                     # keep first-seen order, deterministic
    rank = np.empty_like(order)
    rank[order] = np.arange(len(order))
    group = rank[inverse]
    counts = np.bincount(group)
    flat = values.reshape(len(values), -1)
    sums = np.zeros((len(counts), flat.shape[1]))
    np.add.at(sums, group, flat)
    merged = (sums / counts[:, None]).reshape((len(counts),) + values.shape[1:])
    return points[np.sort(first)], merged


class _TouchEstimator:
    """``fit`` / ``partial_fit`` over touches, shared by the propagation estimators.

    Subclasses learn from all touches so far in ``_learn(points (n, 3), values (n,) or (n, k))``;
    ``partial_fit`` costs the new touches plus that re-learning (small: contacts, not the cloud).
    """

    def _validate_params(self):
        pass

    def fit(self, contact_points, values):
        """Learn the tactile cloud. contact_points : (n, 3); values : (n,) or (n, k)."""
        self._validate_params()
        p = _points(contact_points, "contact_points", allow_empty=False)
        v = _values(values, len(p))
        self._touch_points, self._touch_values = p, v
        self._learn(p, v)
        return self

    def partial_fit(self, contact_points, values):
        """Add touches to a fitted (or empty) estimator."""
        if getattr(self, "_touch_points", None) is None:
            return self.fit(contact_points, values)
        p = _points(contact_points, "contact_points", allow_empty=False)
        v = _values(values, len(p))
        if v.shape[1:] != self._touch_values.shape[1:]:
            raise InputError(f"has {v.shape[1:]} channels per touch but the fitted ones have "
                             f"{self._touch_values.shape[1:]}", key="values")
        self._touch_points = np.concatenate([self._touch_points, p])
        self._touch_values = np.concatenate([self._touch_values, v])
        self._learn(self._touch_points, self._touch_values)
        return self


# ---------------------------------------------------------------------------
# cluster-based (Eq. 2)
# ---------------------------------------------------------------------------

class ClusterPropagation(_TouchEstimator):
    """Nearest-contact colours (seed 000, Eq. 2): a sharp, Voronoi-like augmented cloud.

    Parameters
    ----------
    workers : int
        Threads for the KD-tree query (scipy ``cKDTree.query``); -1 uses all cores.

    Attributes (after ``fit``)
    --------------------------
    contact_points_ : (u, 3) float, the distinct contact points (duplicates merged).
    values_ : (u,) or (u, k) float, their colours (averaged over duplicates).
    tree_ : scipy.spatial.cKDTree over ``contact_points_``.
    """

    def __init__(self, workers: int = 1):
        self.workers = workers

    def _learn(self, p, v):
        self.contact_points_, self.values_ = merge_duplicates(p, v)
        self.tree_ = cKDTree(self.contact_points_)

    def labels(self, points) -> np.ndarray:
        """Index into ``contact_points_`` of the nearest contact of each point, (M,) int."""
        _check_fitted(self)
        x = _points(points, "points")
        if len(x) == 0:
            return np.empty(0, dtype=np.intp)
        c = self.contact_points_
        if len(c) > BRUTE_FORCE_MAX:
            _, idx = self.tree_.query(x, k=1, workers=self.workers)
            return np.asarray(idx, dtype=np.intp)
        # Few contacts (the paper has <= 24): a brute-force argmin over squared distances
        # beats the KD-tree's per-query overhead ~3x. Coordinates are centred on the
        # contacts so that the Gram expansion keeps its precision far from the origin.
        o = c.mean(axis=0)
        cc = c - o
        half = 0.5 * np.einsum("ij,ij->i", cc, cc)
        out = np.empty(len(x), dtype=np.intp)
        for s in range(0, len(x), _CHUNK):
            d = (x[s:s + _CHUNK] - o) @ (-cc.T)       # |x-c|^2/2 - |x|^2/2: same argmin
            d += half
            out[s:s + _CHUNK] = d.argmin(axis=1)
        return out

    def predict(self, points) -> np.ndarray:
        """Colour of each point: (M, 3) -> (M,) or (M, k). An empty cloud gives an empty array."""
        _check_fitted(self)
        idx = self.labels(points)
        return self.values_[idx].copy() if len(idx) else _empty_like_values(0, self.values_)


# ---------------------------------------------------------------------------
# smooth (Eqs. 3-4)
# ---------------------------------------------------------------------------

def softmax_weights(distances: np.ndarray, beta: float) -> np.ndarray:
    """Row-normalised weights ``exp(beta d) / sum exp(beta d)`` through log-sum-exp.

    distances : (m, n) float, metres. beta : float <= 0, per metre; ``-inf`` gives
    the limit (equal weights over the nearest contacts, zero elsewhere), 0 the
    plain mean. Every row sums to 1 and is finite for finite input.
    """
    d = np.asarray(distances, dtype=np.float64)
    if d.shape[-1] == 0:
        return d.copy()
    dmin = d.min(axis=-1, keepdims=True)
    if np.isneginf(beta):
        w = (d <= dmin).astype(np.float64)
    else:
        # beta (d - dmin) <= 0 with its maximum 0 on every row: no overflow, and the
        # nearest contact's weight is exactly 1 before normalising, so no 0/0.
        w = np.exp(beta * (d - dmin))
    w /= w.sum(axis=-1, keepdims=True)
    return w


class SmoothPropagation(_TouchEstimator):
    """Softmax-of-distance colours (seed 000, Eqs. 3-4): a smooth augmented cloud.

    Parameters
    ----------
    beta : float, per metre, <= 0 (default -300, the paper's value). ``0`` gives the
        plain mean of the touches everywhere; ``-inf`` the cluster-based colours.
    k_nearest : int or None. Use only the k nearest contacts of each point (an
        accuracy/time knob; weights of farther contacts are below
        ``exp(beta * gap)``). ``None`` uses all contacts (exact Eq. 3).
    scale : float, metres per coordinate unit (1e-3 for a cloud in millimetres).
    dtype : numpy float type of the kernel arithmetic (float64 default; float32
        is faster on large clouds at ~1e-6 relative error).
    workers : int, KD-tree threads for ``k_nearest``.
    """

    def __init__(self, beta: float = -300.0, k_nearest: int | None = None, scale: float = 1.0,
                 dtype=np.float64, workers: int = 1):
        self.beta = beta
        self.k_nearest = k_nearest
        self.scale = scale
        self.dtype = dtype
        self.workers = workers

    def _check_params(self):
        b = float(self.beta)
        if np.isnan(b) or b > 0:
            raise InputError(f"must be <= 0 (per metre; the paper uses -300): weights exp(beta*d) must "
                             f"fall with distance, got {self.beta}", key="beta")
        if not (np.isfinite(self.scale) and self.scale > 0):
            raise InputError(f"must be a positive number of metres per unit, got {self.scale}", key="scale")
        if self.k_nearest is not None and (int(self.k_nearest) != self.k_nearest or self.k_nearest < 1):
            raise InputError(f"must be a positive integer or None, got {self.k_nearest}", key="k_nearest")
        return b

    def _validate_params(self):
        self._check_params()

    def _learn(self, p, v):
        self.contact_points_, self.values_ = p, v
        self._prepare()

    def _prepare(self):
        self.origin_ = self.contact_points_.mean(axis=0)
        dt = np.dtype(self.dtype)
        if dt not in (np.float32, np.float64):
            raise InputError(f"must be float32 or float64, got {self.dtype!r}", key="dtype")
        self._dt = dt.type
        self._c = ((self.contact_points_ - self.origin_) * self.scale).astype(dt)
        self._v2 = self.values_.reshape(len(self.values_), -1).astype(dt)
        self._tree = None

    def predict(self, points) -> np.ndarray:
        """Colour of each point: (M, 3) -> (M,) or (M, k), float64."""
        _check_fitted(self)
        beta = self._check_params()
        x = _points(points, "points")
        m, n = len(x), len(self._c)
        out = np.empty((m, self._v2.shape[1]), dtype=np.float64)
        if m == 0:
            return out.reshape((0,) + self.values_.shape[1:])
        k = None if self.k_nearest is None else min(int(self.k_nearest), n)
        if beta == 0.0 and k is None:
            out[:] = self._v2.astype(np.float64).mean(axis=0)
        elif np.isneginf(beta) or n == 1:
            out[:] = _limit_nearest(self, x, beta)
        elif k is not None and k < n:
            self._predict_truncated(x, beta, k, out)
        else:
            self._predict_dense(x, beta, out)
        return out.reshape((m,) + self.values_.shape[1:])

    def _predict_dense(self, x, beta, out):
        # Contacts along the first axis: the reductions over contacts (min, sum) then run
        # as n elementwise passes over contiguous rows of points, several times faster in
        # numpy than reducing a short trailing axis.
        dt = self._dt
        b = dt(beta)
        c = self._c
        c2 = np.einsum("ij,ij->i", c, c)[:, None]
        vt = np.ascontiguousarray(self._v2.T)
        for s in range(0, len(x), _CHUNK):
            xs = ((x[s:s + _CHUNK] - self.origin_) * self.scale).astype(dt)
            d = c @ (dt(-2.0) * xs.T)                 # (n, m): squared distances by the Gram expansion
            d += c2
            d += np.einsum("ij,ij->i", xs, xs)[None, :]
            np.maximum(d, 0.0, out=d)
            np.sqrt(d, out=d)
            d -= d.min(axis=0)                        # log-sum-exp shift: the largest logit is 0
            d *= b
            np.exp(d, out=d)
            num = vt @ d                              # (k, m)
            num /= d.sum(axis=0)
            out[s:s + _CHUNK] = num.T

    def _predict_truncated(self, x, beta, k, out):
        if self._tree is None:
            self._tree = cKDTree(self.contact_points_)
        d, idx = self._tree.query(x, k=k, workers=self.workers)
        d, idx = d.reshape(len(x), k), idx.reshape(len(x), k)     # k = 1 returns 1-d arrays
        w = softmax_weights(d * self.scale, beta)
        vals = self.values_.reshape(len(self.values_), -1)
        out[:] = np.einsum("mk,mkc->mc", w, vals[idx])


def _limit_nearest(est, x, beta):
    """beta -> -inf (or a single touch): mean colour of the nearest contacts (ties averaged)."""
    vals = est.values_.reshape(len(est.values_), -1)
    if len(vals) == 1:
        return vals[0][None, :]
    merged = ClusterPropagation(workers=getattr(est, "workers", 1)).fit(est.contact_points_, vals)
    return merged.predict(x)


# ---------------------------------------------------------------------------
# Gaussian process baseline (appendix)
# ---------------------------------------------------------------------------

class GPPropagation:
    """Gaussian-process regression of the tactile colour over space (seed 000, appendix).

    Parameters
    ----------
    length_scale : float, metres, initial RBF length scale (optimised by sklearn).
    noise : float, initial white-noise level, in units of the normalised colour.
    radius : float or None, metres. If set and ``fit`` gets ``visual_points``, every
        visual point within ``radius`` of a contact joins the training set with
        that contact's colour (the paper's "artificially increased tactile PC",
        3 cm), then the set is voxel-downsampled to ``voxel``.
    voxel : float, metres (paper: 0.004).
    max_train : int, cap on training points (GP fitting is O(n^3)); extra points
        are dropped with a seeded choice.
    random_state : int or None, seeds the optimiser restarts and the subsampling.
    """

    def __init__(self, length_scale: float = 0.05, noise: float = 1e-2, radius: float | None = None,
                 voxel: float = 0.004, max_train: int = 2000, n_restarts: int = 0, random_state=0):
        self.length_scale = length_scale
        self.noise = noise
        self.radius = radius
        self.voxel = voxel
        self.max_train = max_train
        self.n_restarts = n_restarts
        self.random_state = random_state

    def fit(self, contact_points, values, visual_points=None):
        from sklearn.gaussian_process import GaussianProcessRegressor
        from sklearn.gaussian_process.kernels import RBF, ConstantKernel, WhiteKernel

        p = _points(contact_points, "contact_points", allow_empty=False)
        v = _values(values, len(p))
        self.contact_points_, self.values_ = p, v
        xt, yt = p, v
        if self.radius is not None and visual_points is not None:
            xt, yt = self._augment(p, v, _points(visual_points, "visual_points"))
        rng = np.random.default_rng(self.random_state)
        if len(xt) > self.max_train:
            keep = np.sort(rng.choice(len(xt), self.max_train, replace=False))
            xt, yt = xt[keep], yt[keep]
        self.train_points_, self.train_values_ = xt, yt
        kernel = (ConstantKernel(1.0, (1e-3, 1e3)) * RBF(self.length_scale, (1e-3, 10.0))
                  + WhiteKernel(self.noise, (1e-8, 1.0)))
        self.gp_ = GaussianProcessRegressor(kernel=kernel, normalize_y=True, n_restarts_optimizer=self.n_restarts,
                                            random_state=int(rng.integers(2**31 - 1)))
        if len(xt) == 1:                      # sklearn cannot normalise a single sample: constant field
            self.gp_ = None
        else:
            import warnings

            from sklearn.exceptions import ConvergenceWarning

            with warnings.catch_warnings():
                warnings.simplefilter("ignore", ConvergenceWarning)
                self.gp_.fit(xt, yt)
        return self

    def _augment(self, p, v, vis):
        tree = cKDTree(vis)
        hoods = tree.query_ball_point(p, r=self.radius)
        idx = np.unique(np.concatenate([np.asarray(h, dtype=np.intp) for h in hoods] + [np.empty(0, np.intp)]))
        if len(idx) == 0:
            return p, v
        x = vis[idx]
        # each neighbourhood point takes the colour of its nearest contact (hoods may overlap)
        lab = ClusterPropagation().fit(p, np.arange(len(p), dtype=float)).predict(x).astype(np.intp)
        y = v[lab]
        if self.voxel and self.voxel > 0:
            keys = np.floor(x / self.voxel).astype(np.int64)
            _, first = np.unique(keys, axis=0, return_index=True)
            first = np.sort(first)
            x, y = x[first], y[first]
        return np.concatenate([p, x]), np.concatenate([v, y])

    def predict(self, points) -> np.ndarray:
        _check_fitted(self)
        x = _points(points, "points")
        if len(x) == 0:
            return _empty_like_values(0, self.values_)
        if self.gp_ is None:
            return np.broadcast_to(self.values_[0], (len(x),) + self.values_.shape[1:]).copy()
        y = self.gp_.predict(x)
        return np.asarray(y, dtype=np.float64).reshape((len(x),) + self.values_.shape[1:])


# ---------------------------------------------------------------------------
# incremental augmented cloud
# ---------------------------------------------------------------------------

class AugmentedPointCloud:
    """A visual cloud whose tactile colours are updated touch by touch.

    Each :meth:`add_touch` costs O(M) for M points (one distance per point),
    whatever the number of earlier touches: the cluster method keeps the
    nearest distance and label of every point; the smooth method keeps, per
    point, the running log-sum-exp state (largest logit ``m``, ``S = sum
    exp(l - m)``, ``N = sum exp(l - m) c``) and rescales it when a nearer
    touch arrives. The colours equal those of a batch ``fit``/``predict`` over
    the same touches (to rounding).

    Parameters
    ----------
    points : (M, 3) float, the visual cloud (coordinates in units of ``scale`` metres).
    method : "cluster" or "smooth".
    beta : float <= 0, per metre (smooth only).
    channels : int or None, k for vector colours (None: scalar colours).
    scale : float, metres per coordinate unit.
    """

    def __init__(self, points, method: str = "smooth", beta: float = -300.0, channels: int | None = None,
                 scale: float = 1.0, normals=None):
        if method not in ("cluster", "smooth"):
            raise InputError(f"must be 'cluster' or 'smooth', got {method!r}", key="method")
        SmoothPropagation(beta=beta, scale=scale)._check_params()
        self.points = _points(points, "points")
        self.normals = None if normals is None else _points(normals, "normals")
        self.method, self.beta, self.scale = method, float(beta), float(scale)
        self.channels = channels
        m, k = len(self.points), (channels or 1)
        self.origin = self.points.mean(axis=0) if m else np.zeros(3)
        self._x = (self.points - self.origin) * self.scale
        self.contact_points = np.empty((0, 3))
        self.contact_values = np.empty((0,) if channels is None else (0, channels))
        self._best = np.full(m, np.inf)          # nearest distance (metres), cluster and smooth
        self._label = np.full(m, -1, dtype=np.intp)
        self._dupes: dict[tuple, list[int]] = {}
        self._S = np.zeros(m)
        self._N = np.zeros((m, k))

    @property
    def n_touches(self) -> int:
        return len(self.contact_points)

    def add_touch(self, point, value) -> "AugmentedPointCloud":
        """Add one touch: point (3,), value scalar or (k,). O(M)."""
        p = _points(point, "point", allow_empty=False)
        if len(p) != 1:
            raise InputError(f"add_touch takes one point, got {len(p)}; use add_touches", key="point")
        v = np.asarray(value, dtype=np.float64).reshape(-1)
        if v.size != (self.channels or 1) or not np.all(np.isfinite(v)):
            raise InputError(f"must be a finite {'scalar' if self.channels is None else f'({self.channels},) vector'}"
                             f", got {value!r}", key="value")
        j = self.n_touches
        self.contact_points = np.concatenate([self.contact_points, p])
        self.contact_values = np.concatenate([self.contact_values, v.reshape((1,) + self.contact_values.shape[1:])])
        if len(self.points) == 0:
            return self
        d = np.linalg.norm(self._x - (p[0] - self.origin) * self.scale, axis=1)
        if self.method == "cluster":
            key = tuple(p[0])
            group = self._dupes.setdefault(key, [])
            group.append(j)
            if len(group) > 1:               # a repeated probe: the point's colour is the mean of its probes
                owned = self._label == group[0]
                self._N[owned] = self.contact_values.reshape(self.n_touches, -1)[group].mean(axis=0)
            closer = d < self._best
            self._best[closer] = d[closer]
            self._label[closer] = group[0]
            self._N[closer] = self.contact_values.reshape(self.n_touches, -1)[group].mean(axis=0)
            return self
        if np.isneginf(self.beta):
            # limit: equal weights over the nearest touches only
            new_best = np.minimum(self._best, d)
            reset = d < self._best
            self._S[reset] = 0.0
            self._N[reset] = 0.0
            tie = d <= new_best
            self._S[tie] += 1.0
            self._N[tie] += v
            self._best = new_best
            return self
        # running log-sum-exp: the shift m = beta * best distance is the largest logit so far
        first = ~np.isfinite(self._best)
        old_m = self.beta * np.where(first, 0.0, self._best)
        new_best = np.minimum(self._best, d)
        new_m = self.beta * new_best
        rescale = np.where(first, 0.0, np.exp(np.where(first, 0.0, old_m - new_m)))  # exponent <= 0
        w = np.exp(self.beta * (d - new_best))
        self._S = self._S * rescale + w
        self._N = self._N * rescale[:, None] + w[:, None] * v[None, :]
        self._best = new_best
        return self

    def add_touches(self, points, values) -> "AugmentedPointCloud":
        p = _points(points, "points", allow_empty=True)
        vals = np.asarray(values, dtype=np.float64)
        if len(vals) != len(p):
            raise InputError(f"has {len(vals)} rows but points has {len(p)}", key="values")
        for i in range(len(p)):        # loop over touches (few), each vectorised over the cloud
            self.add_touch(p[i], vals[i])
        return self

    def write_ply(self, path, c_min: float, c_max: float, cmap: str = "viridis_r", channel_names=None):
        """Write the cloud with its colours: RGB on the shared scale (first channel) and every channel
        as a scalar property (``tactile_color``, then ``channel_names[1:]`` or ``channel_1``...)."""
        from .cloud import colour_map, write_ply

        vals = self.values.reshape(len(self.points), -1)
        names = list(channel_names or ["tactile_color"] + [f"channel_{j}" for j in range(1, vals.shape[1])])
        names[0] = "tactile_color"
        return write_ply(path, self.points, normals=self.normals, rgb=colour_map(vals[:, 0], c_min, c_max, cmap),
                         scalars={names[j]: vals[:, j] for j in range(vals.shape[1])},
                         comment=f"vtcore augmented point cloud, {self.method}, {self.n_touches} touches")

    @property
    def values(self) -> np.ndarray:
        """Current colours, (M,) or (M, k); NaN everywhere before the first touch (no information)."""
        m = len(self.points)
        shape = (m,) if self.channels is None else (m, self.channels)
        if self.n_touches == 0:
            return np.full(shape, np.nan)
        if self.method == "cluster":
            return self._N.reshape(shape).copy()
        return (self._N / self._S[:, None]).reshape(shape)
