"""Spatial-resolution study (seed 001 §IV-C, Fig. 10).

For each subset size ``s`` the category formation is run ``runs`` times on the
tactile images restricted to ``s`` taxels drawn at random (without
replacement), and its accuracy on every task is recorded. Runs whose formation
fails (``"degenerate"``: the objects look identical on those taxels, or
``"unstable"``) have no accuracy; they are counted, and the statistics are over
the runs that formed categories.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import InputError
from .formation import CategoryFormation, single_threaded
from .tasks import Task, task_accuracies


@dataclass
class ResolutionStudy:
    """Result of :func:`resolution_study`.

    sizes : (S,) int, taxels per subset.
    accuracy : (S, R, K) float, accuracy of run r on task k (0 where the run failed; see ``ok``).
    ok : (S, R) bool, the run formed categories.
    retries : (S, R) int, discarded attempts of each run.
    subsets : (S, R, max(sizes)) int, the taxel indices of each run, padded with -1.
    """

    sizes: np.ndarray
    accuracy: np.ndarray
    ok: np.ndarray
    retries: np.ndarray
    subsets: np.ndarray

    @property
    def n_ok(self) -> np.ndarray:
        """(S,) int, runs that formed categories."""
        return self.ok.sum(axis=1)

    def mean(self) -> np.ndarray:
        """(S, K) mean accuracy over successful runs; NaN (documented: undefined) where none succeeded."""
        w = self.ok[..., None]
        cnt = w.sum(axis=1)
        with np.errstate(invalid="ignore", divide="ignore"):
            return np.where(cnt > 0, (self.accuracy * w).sum(axis=1) / np.maximum(cnt, 1), np.nan)

    def std(self) -> np.ndarray:
        """(S, K) standard deviation over successful runs (ddof 0); NaN where none succeeded."""
        w = self.ok[..., None]
        cnt = w.sum(axis=1)
        mu = np.nan_to_num(self.mean())
        var = (((self.accuracy - mu[:, None, :]) ** 2) * w).sum(axis=1) / np.maximum(cnt, 1)
        return np.where(cnt > 0, np.sqrt(var), np.nan)

    def sem(self) -> np.ndarray:
        """(S, K) standard error of the mean, ``std / sqrt(n_ok)``; NaN where no run succeeded."""
        cnt = self.n_ok[:, None]
        return np.where(cnt > 0, self.std() / np.sqrt(np.maximum(cnt, 1)), np.nan)

    def solved_fraction(self) -> np.ndarray:
        """(S, K) fraction of all runs (failed ones count as unsolved) with accuracy 1."""
        return ((self.accuracy >= 1.0) & self.ok[..., None]).mean(axis=1)


def resolution_study(images, tasks: list[Task], sizes=(6, 12, 18, 24, 30, 36), runs: int = 100,
                     random_state=None, progress=None, **formation) -> ResolutionStudy:
    """Category formation on random taxel subsets.

    images : (M, N) float, tactile images (any units). tasks : from :func:`make_tasks`.
    sizes : subset sizes, each in 1..N. runs : int >= 1, subsets per size.
    random_state : seed or Generator (subsets and K-Means initialisations).
    progress : optional ``progress(iterable, desc=, total=)`` wrapper.
    formation : keyword arguments of :class:`CategoryFormation` (``n_runs``, ``max_retries``).
    """
    x = np.asarray(images, dtype=np.float64)
    if x.ndim != 2:
        raise InputError(f"images must be (objects, taxels), got shape {x.shape}", key="images")
    n = x.shape[1]
    sizes = np.asarray(sizes, dtype=np.int64).reshape(-1)
    if sizes.size == 0 or (sizes < 1).any() or (sizes > n).any():
        raise InputError(f"subset sizes must lie in 1..{n} (the taxels there are), got {sizes.tolist()}",
                         key="sizes")
    if isinstance(runs, bool) or not isinstance(runs, (int, np.integer)) or runs < 1:
        raise InputError(f"must be an integer >= 1, got {runs!r}", key="runs")
    rng = random_state if isinstance(random_state, np.random.Generator) else np.random.default_rng(random_state)
    k = len(tasks)
    acc = np.zeros((len(sizes), runs, k))
    ok = np.zeros((len(sizes), runs), dtype=bool)
    retries = np.zeros((len(sizes), runs), dtype=np.int64)
    subsets = np.full((len(sizes), runs, int(sizes.max())), -1, dtype=np.int64)
    cells = [(i, r) for i in range(len(sizes)) for r in range(runs)]
    it = progress(cells, desc="resolution study", total=len(cells)) if progress else cells
    with single_threaded():
        for i, r in it:
            idx = np.sort(rng.choice(n, size=int(sizes[i]), replace=False))
            subsets[i, r, : len(idx)] = idx
            est = CategoryFormation(random_state=rng, **formation).fit(x[:, idx])
            retries[i, r] = est.n_retries_
            if est.ok:
                ok[i, r] = True
                acc[i, r] = task_accuracies(est.labels_, tasks)
    return ResolutionStudy(sizes, acc, ok, retries, subsets)
