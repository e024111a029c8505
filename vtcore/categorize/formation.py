"""Autonomous category formation (seed 001 §II): PCA to two dimensions, then K-Means with k = 2.

The estimator follows scikit-learn's shape: parameters in ``__init__``,
``fit(X)`` learns the attributes ending in ``_`` and returns ``self``.
PCA and K-Means are scikit-learn's (``init="random"``: the initial centroids
are objects drawn at random, the paper's "random centroid initialization").

An *attempt* runs K-Means ``n_runs`` (3) times from independent random
initialisations and is accepted only when all runs give the same split (up to
the arbitrary naming of the two clusters); otherwise it is discarded and
retried, at most ``max_retries`` times. ``n_retries_`` reports how many were
discarded.

Outcomes (``status_``), none of which produces NaN:

``"ok"``          a split into two non-empty clusters; ``labels_`` in {0, 1}.
``"degenerate"``  the tactile images do not span two distinct points (all
                  identical, or identical after projection): no split exists.
                  ``labels_`` is all -1, ``projection_`` all 0.
``"unstable"``    every attempt disagreed within itself up to ``max_retries``
                  retries. ``labels_`` is all -1.
"""

from __future__ import annotations

import contextlib
import warnings

import numpy as np

from ..errors import InputError

#: Relative tolerance under which two tactile images (or projections) count as identical.
IDENTICAL_RTOL = 1e-12

_DEPTH = [0]


@contextlib.contextmanager
def single_threaded():
    """Limit BLAS/OpenMP pools to one thread while fitting a handful of points.

    scikit-learn's K-Means starts an OpenMP pool per fit; for 4 points in 2-D that
    overhead is the whole cost (about 3x slower on a busy 2-core machine).
    Re-entrant: only the outermost call touches the pools (entering costs ~2 ms).
    """
    if _DEPTH[0]:
        _DEPTH[0] += 1
        try:
            yield
        finally:
            _DEPTH[0] -= 1
        return
    from threadpoolctl import threadpool_limits

    _DEPTH[0] += 1
    try:
        with threadpool_limits(1):
            yield
    finally:
        _DEPTH[0] -= 1


def _distinct_rows(a: np.ndarray, scale: float) -> int:
    """Number of rows of ``a`` farther than ``IDENTICAL_RTOL * scale`` from every earlier row."""
    if len(a) == 0:
        return 0
    d = np.abs(a[:, None, :] - a[None, :, :]).max(axis=-1)  # (N, N) Chebyshev distances; N is small
    same = d <= IDENTICAL_RTOL * scale
    # A row is new when no earlier row is the same as it.
    earlier = np.tril(same, k=-1).any(axis=1)
    return int((~earlier).sum())


def canonical(labels: np.ndarray) -> np.ndarray:
    """Rename clusters so that object 0 is in cluster 0 (the names of K-Means clusters are arbitrary)."""
    labels = np.asarray(labels, dtype=np.int64)
    return labels if labels[0] == 0 else 1 - labels


class CategoryFormation:
    """PCA to ``n_components`` dimensions, then K-Means with 2 clusters, checked over ``n_runs`` runs.

    Parameters
    ----------
    n_components : int, the PCA dimensions kept (2 in seed 001). Fewer are kept
        when the data cannot give them (``min(n_components, D, N - 1)``).
    n_runs : int, K-Means runs per attempt that must agree (3 in seed 001).
    max_retries : int, discarded attempts allowed before giving up (``"unstable"``).
    max_iter : int, K-Means iterations per run.
    n_init : int, random initialisations per K-Means run, the lowest-inertia result kept
        (1: each run is one random start; scikit-learn's ``KMeans(init="random")`` defaults to
        10). Seed 001 says only "random centroid initialization"; see :func:`kmeans_splits`.
    random_state : None, int or numpy Generator; seeds every random initialisation.

    Attributes (after ``fit``)
    --------------------------
    labels_ : (N,) int, cluster of each object, object 0 in cluster 0; -1 when ``status_ != "ok"``.
    status_ : str, ``"ok"``, ``"degenerate"`` or ``"unstable"`` (see the module docstring).
    message_ : str, why the status is not ``"ok"`` (empty when it is).
    scale_ : float, ``max |X|``; PCA runs on ``X / scale_`` (dimensionless).
    projection_ : (N, 2) float, the 2-D encodings ``W`` (Eq. 5, centred) of ``X / scale_``,
        zero-padded when fewer than 2 components exist.
    components_ : (2, D) float, the principal axes (zero rows where padded).
    explained_variance_ : (2,) float, variance along each axis, of ``X / scale_``.
    explained_variance_ratio_ : (2,) float, fraction of the total variance (0 when degenerate).
    centroids_ : (2, 2) float, cluster centroids in the projection (rows: cluster 0, 1).
    n_attempts_, n_retries_ : int, attempts made and attempts discarded.
    run_labels_ : (n_attempts_ * n_runs, N) int, the (canonical) split of every K-Means run made.
    n_components_ : int, PCA components actually fitted (0 when degenerate).
    """

    def __init__(self, n_components: int = 2, n_runs: int = 3, max_retries: int = 10, max_iter: int = 300,
                 random_state=None, n_init: int = 1):
        self.n_init = n_init
        self.n_components = n_components
        self.n_runs = n_runs
        self.max_retries = max_retries
        self.max_iter = max_iter
        self.random_state = random_state

    # -- helpers ----------------------------------------------------------------------------------
    def _validate(self, X) -> np.ndarray:
        X = np.asarray(X, dtype=np.float64)
        if X.ndim != 2:
            raise InputError(f"tactile images must be an (objects, taxels) matrix, got shape {X.shape}",
                             key="X")
        n, d = X.shape
        if n < 2:
            raise InputError(f"category formation needs at least 2 objects, got {n}", key="X")
        if d < 1:
            raise InputError("tactile images have no taxels (0 columns)", key="X")
        if not np.isfinite(X).all():
            row = int(np.flatnonzero(~np.isfinite(X).all(axis=1))[0])
            raise InputError(f"tactile image of object {row} is not finite", key="X")
        for name, lo in (("n_components", 1), ("n_runs", 1), ("max_retries", 0), ("max_iter", 1), ("n_init", 1)):
            val = getattr(self, name)
            if isinstance(val, bool) or not isinstance(val, (int, np.integer)) or val < lo:
                raise InputError(f"must be an integer >= {lo}, got {val!r}", key=name)
        return X

    def _fail(self, n, d, status, message):
        self.status_ = status
        self.message_ = message
        self.labels_ = np.full(n, -1, dtype=np.int64)
        self.centroids_ = np.zeros((2, 2))
        return self

    # -- fitting ----------------------------------------------------------------------------------
    def fit(self, X, y=None) -> "CategoryFormation":
        """Form two categories from the tactile images ``X`` (N objects, D taxels), any units."""
        with single_threaded():
            return self._fit(X)

    def _fit(self, X):
        from sklearn.cluster import KMeans
        from sklearn.decomposition import PCA

        X = self._validate(X)
        n, d = X.shape
        rng = self.random_state if isinstance(self.random_state, np.random.Generator) \
            else np.random.default_rng(self.random_state)
        self.n_attempts_ = 0
        self.n_retries_ = 0
        self.projection_ = np.zeros((n, 2))
        self.components_ = np.zeros((2, d))
        self.explained_variance_ = np.zeros(2)
        self.explained_variance_ratio_ = np.zeros(2)
        self.n_components_ = 0
        self.run_labels_ = np.zeros((0, n), dtype=np.int64)

        # Work on X / max|X|: K-Means and the split do not depend on the scale, and squares of
        # huge counts (or tiny pressures) neither overflow nor underflow.
        scale = max(float(np.abs(X).max()), np.finfo(float).tiny)
        self.scale_ = scale
        X = X / scale
        if _distinct_rows(X, 1.0) < 2:
            # PCA of zero variance has no axes (sklearn would divide 0 by 0); say so instead.
            return self._fail(n, d, "degenerate", "all tactile images are identical: there is no "
                              "variance to project and no split into two categories")

        k = int(min(self.n_components, 2, d, n - 1))
        pca = PCA(n_components=k, svd_solver="full")
        w = pca.fit_transform(X)
        self.n_components_ = k
        self.projection_[:, :k] = w
        self.components_[:k] = pca.components_
        self.explained_variance_[:k] = pca.explained_variance_
        total = float(np.sum(np.var(X, axis=0, ddof=1)))
        self.explained_variance_ratio_[:k] = pca.explained_variance_ / total if total > 0 else 0.0
        w = self.projection_
        if _distinct_rows(w, 1.0) < 2:
            return self._fail(n, d, "degenerate", "the tactile images differ only below numerical "
                              "precision: their projections coincide")

        while True:
            self.n_attempts_ += 1
            guesses = []
            for _ in range(self.n_runs):
                km = KMeans(n_clusters=2, init="random", n_init=self.n_init, max_iter=self.max_iter,
                            random_state=int(rng.integers(2**31 - 1)))
                with warnings.catch_warnings():
                    # Coincident objects may make K-Means report fewer distinct clusters than
                    # points; that is expected here and the split is checked below.
                    warnings.simplefilter("ignore")
                    labels = km.fit_predict(w)
                guesses.append(canonical(labels))
            g = np.stack(guesses)
            self.run_labels_ = np.concatenate([self.run_labels_, g])
            split = (g == 0).any(axis=1) & (g == 1).any(axis=1)
            if split.all() and (g == g[0]).all():
                break
            if self.n_retries_ >= self.max_retries:
                return self._fail(n, d, "unstable", f"the {self.n_runs} K-Means runs disagreed in "
                                  f"every one of {self.n_attempts_} attempts")
            self.n_retries_ += 1

        self.labels_ = g[0]
        # Centroids of the accepted split (identical for all runs once they agree on it).
        self.centroids_ = np.stack([w[self.labels_ == c].mean(axis=0) for c in (0, 1)])
        self.status_ = "ok"
        self.message_ = ""
        return self

    def fit_predict(self, X, y=None) -> np.ndarray:
        return self.fit(X).labels_

    @property
    def ok(self) -> bool:
        return getattr(self, "status_", None) == "ok"


def decision_boundary(centroids) -> tuple[np.ndarray, np.ndarray]:
    """The K-Means decision line ``l_kmc`` between two centroids (Fig. 9).

    centroids : (2, 2). Returns ``point (2,)`` (their midpoint) and unit
    ``direction (2,)`` along the line (perpendicular to ``c1 - c0``); for
    coincident centroids the direction is (0, 1).
    """
    c = np.asarray(centroids, dtype=np.float64).reshape(2, 2)
    mid = c.mean(axis=0)
    diff = c[1] - c[0]
    norm = float(np.hypot(*diff))
    if norm == 0.0:
        return mid, np.array([0.0, 1.0])
    return mid, np.array([-diff[1], diff[0]]) / norm


def kmeans_splits(projection, n_runs: int = 3, max_iter: int = 300, n_init: int = 1) -> list[dict]:
    """Every split K-Means can return from a random initialisation, with its exact probability.

    scikit-learn's ``init="random"`` starts from two distinct objects drawn
    uniformly; Lloyd's iterations are deterministic from there. Enumerating all
    ``N (N - 1) / 2`` starting pairs therefore gives the exact distribution of
    one random start's outcome, ``q``. A run of ``n_init`` starts keeps the lowest-inertia
    result, so it returns split ``s`` when no start reaches a split of lower inertia and at
    least one reaches ``s``: ``p_s = Q(>= I_s)**n_init - Q(> I_s)**n_init``, with ``Q(> I)``
    the total ``q`` of the splits of inertia above ``I`` (``p = q`` for ``n_init = 1``).
    An attempt of :class:`CategoryFormation` is
    accepted when its ``n_runs`` independent runs agree, so the split finally
    reported is split ``i`` with probability ``p_i**n_runs / sum_j p_j**n_runs``.

    projection : (N, d) float, the encodings (``CategoryFormation.projection_``).
    Returns a list of ``{"labels" (N,) int canonical, "p_start" (one start), "p_run",
    "p_accepted", "inertia"}`` sorted by decreasing ``p_accepted``; empty when fewer than two
    distinct points exist.
    """
    from sklearn.cluster import KMeans

    w = np.asarray(projection, dtype=np.float64)
    n = len(w)
    scale = max(float(np.abs(w).max()) if w.size else 0.0, np.finfo(float).tiny)
    if n < 2 or _distinct_rows(w / scale, 1.0) < 2:
        return []
    counts: dict[tuple, int] = {}
    with single_threaded(), warnings.catch_warnings():
        warnings.simplefilter("ignore")
        for i in range(n):
            for j in range(i + 1, n):
                km = KMeans(n_clusters=2, init=w[[i, j]], n_init=1, max_iter=max_iter)
                key = tuple(canonical(km.fit_predict(w)).tolist())
                counts[key] = counts.get(key, 0) + 1
    total = sum(counts.values())
    rows = []
    for key, c in counts.items():
        lab = np.asarray(key, dtype=np.int64)
        both = (lab == 0).any() and (lab == 1).any()
        inertia = sum(float(((w[lab == k] - w[lab == k].mean(axis=0)) ** 2).sum()) for k in (0, 1) if (lab == k).any())
        rows.append({"labels": lab, "p_start": c / total, "valid": bool(both), "inertia": inertia})
    if isinstance(n_init, bool) or not isinstance(n_init, (int, np.integer)) or n_init < 1:
        raise InputError(f"must be an integer >= 1, got {n_init!r}", key="n_init")
    # Inertias equal to rounding are one level (sklearn keeps the first of equal inertias; which
    # of two such splits that is does not matter to the distribution of their union).
    tol = 1e-9 * max(max(r["inertia"] for r in rows), np.finfo(float).tiny)
    for r in rows:
        above = sum(o["p_start"] for o in rows if o["inertia"] > r["inertia"] + tol)
        level = [o for o in rows if abs(o["inertia"] - r["inertia"]) <= tol]
        at = sum(o["p_start"] for o in level)
        # the level's share goes to its splits in proportion to their single-start probability
        r["p_run"] = ((above + at) ** n_init - above ** n_init) * (r["p_start"] / at) if at > 0 else 0.0
        if n_init == 1:
            r["p_run"] = r["p_start"]  # exact, without the rounding of the sums above
    weights = np.array([r["p_run"] ** n_runs if r["valid"] else 0.0 for r in rows])
    for r, wgt in zip(rows, weights):
        r["p_accepted"] = float(wgt / weights.sum()) if weights.sum() > 0 else 0.0
    rows.sort(key=lambda r: (-r["p_accepted"], r["inertia"]))
    return rows
