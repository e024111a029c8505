"""Active touch selection: which of the candidate probe points to touch next (beyond seed 000).

Seed 000 closes with "selecting the best points to explore, aiming for a more accurate
object representation with few touches". The policies here choose G touches among an
object's candidate probe points (its tactile cloud T_o, so that every policy is scored
on the same measurements and only the choice differs):

- ``random``: a seeded uniform G-subset (what the paper's data sets do);
- ``farthest``: farthest-point coverage (greedy k-center): after a seeded random first
  touch, each next touch is the candidate farthest (Euclidean) from every touch so far,
  i.e. the point the propagated colour knows least about (both propagations colour a
  point from its nearest touches, so the largest nearest-touch distance is the largest
  extrapolation). It goes to the extremes of the object first (cap, base, vertices);
- ``coverage``: representative coverage (greedy k-median over the visual cloud): each
  next touch is the candidate that most lowers the *mean* distance from a visual point
  to its nearest touch, so every touch stands for about as much surface as any other
  (the seeded first touch as in ``farthest``).

:func:`map_error` scores a choice by how well its propagated colours predict the probes
it did not touch (the compliance-map error on held-out probes).
"""

from __future__ import annotations

import numpy as np

from ..errors import InputError
from .datasets import propagate

POLICIES = ("random", "farthest", "coverage")


def farthest_first(points: np.ndarray, g: int, start: int) -> np.ndarray:
    """(g,) indices of ``points`` (n, 3): ``start`` then, greedily, the farthest from those chosen.

    O(n g) with one distance vector updated per pick (n <= a few dozen candidates here);
    ties go to the lowest index.
    """
    p = np.asarray(points, dtype=np.float64)
    chosen = [int(start)]
    d = np.linalg.norm(p - p[start], axis=1)
    for _ in range(g - 1):
        d[chosen] = -1.0                          # never pick a touch twice (coincident candidates too)
        nxt = int(np.argmax(d))
        chosen.append(nxt)
        d = np.minimum(d, np.linalg.norm(p - p[nxt], axis=1))
    return np.asarray(chosen, dtype=np.int64)


def greedy_median(points: np.ndarray, surface: np.ndarray, g: int, start: int) -> np.ndarray:
    """(g,) indices of candidate ``points`` (n, 3): ``start``, then greedily the one that most lowers the
    summed distance from the ``surface`` points (K, 3) to their nearest chosen candidate.

    One (K, n) distance matrix; each pick is a vectorised column sum (K <= a few thousand).
    """
    d = np.linalg.norm(np.asarray(surface, float)[:, None, :] - np.asarray(points, float)[None, :, :], axis=2)
    chosen = [int(start)]
    near = d[:, start].copy()
    for _ in range(g - 1):
        cost = np.minimum(near[:, None], d).sum(axis=0)
        cost[chosen] = np.inf
        nxt = int(np.argmin(cost))
        chosen.append(nxt)
        near = np.minimum(near, d[:, nxt])
    return np.asarray(chosen, dtype=np.int64)


def select_touches(policy: str, touch_points: np.ndarray, g: int, rng, surface: np.ndarray | None = None) \
        -> np.ndarray:
    """(g,) candidate indices chosen by ``policy`` (see :data:`POLICIES`), in the order touched.

    surface : (K, 3) visual points, needed by ``coverage`` (a few thousand are plenty).
    """
    n = len(touch_points)
    if policy not in POLICIES:
        raise InputError(f"unknown policy {policy!r}; valid: {', '.join(POLICIES)}", key="policy")
    if not 1 <= g <= n:
        raise InputError(f"G = {g} touches asked of {n} candidate probes (valid: 1..{n})", key="touches")
    rng = np.random.default_rng(rng)
    if policy == "random":
        return rng.choice(n, g, replace=False).astype(np.int64)
    if policy == "coverage":
        if surface is None or len(surface) == 0:
            raise InputError("the coverage policy needs the visual cloud's points", key="surface")
        return greedy_median(touch_points, surface, g, int(rng.integers(n)))
    return farthest_first(touch_points, g, int(rng.integers(n)))


def map_error(touch_points: np.ndarray, touch_values: np.ndarray, chosen: np.ndarray, method: str = "cluster",
              beta: float = -300.0) -> float:
    """Relative mean absolute error (fraction) of the colours propagated from ``chosen`` probes
    at the probes not chosen; NaN when every probe was chosen (nothing held out)."""
    held = np.setdiff1d(np.arange(len(touch_points)), chosen)
    if len(held) == 0:
        return float("nan")
    pred = propagate(method, touch_points[chosen], touch_values[chosen], touch_points[held], beta)
    truth = touch_values[held]
    return float(np.mean(np.abs(pred - truth)) / np.mean(np.abs(truth)))
