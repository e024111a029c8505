"""Active touch selection: which of the candidate probe points to touch next (beyond seed 000).

Seed 000 closes with "selecting the best points to explore, aiming for a more accurate
object representation with few touches". The policies here choose G touches among an
object's candidate probe points (its tactile cloud T_o, so that every policy is scored
on the same measurements and only the choice differs):

- ``random``: a seeded uniform G-subset (what the paper's data sets do);
- ``farthest``: farthest-point coverage: after a seeded random first touch, each next
  touch is the candidate farthest (Euclidean) from every touch so far, i.e. the point
  the propagated colour knows least about (both propagations colour a point from its
  nearest touches, so the largest nearest-touch distance is the largest extrapolation).

:func:`map_error` scores a choice by how well its propagated colours predict the probes
it did not touch (the compliance-map error on held-out probes).
"""

from __future__ import annotations

import numpy as np

from ..errors import InputError
from .datasets import propagate

POLICIES = ("random", "farthest")


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


def select_touches(policy: str, touch_points: np.ndarray, g: int, rng) -> np.ndarray:
    """(g,) candidate indices chosen by ``policy`` (see :data:`POLICIES`), in the order touched."""
    n = len(touch_points)
    if policy not in POLICIES:
        raise InputError(f"unknown policy {policy!r}; valid: {', '.join(POLICIES)}", key="policy")
    if not 1 <= g <= n:
        raise InputError(f"G = {g} touches asked of {n} candidate probes (valid: 1..{n})", key="touches")
    rng = np.random.default_rng(rng)
    if policy == "random":
        return rng.choice(n, g, replace=False).astype(np.int64)
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
