"""Soft-layer designer: which layer thickness makes the skin group objects the way a task needs.

Seed 001 measured three layers; the designer sweeps the thickness and, for
every task, reports the thicknesses at which category formation solves it,
i.e. returns exactly the task's split.

Category formation is random twice over: the sensor noise in the tactile
images, and the random K-Means starts (with 4 objects, several splits are
stable K-Means outcomes and the paper's "three runs must agree" rule picks
one of them at random). For each thickness and each of ``repeats`` noise draws
the designer therefore computes, with :func:`kmeans_splits`, the exact
probability that the procedure returns each split, and averages over the draws:
``solve_probability (H, K)`` is the chance that a robot with this layer forms
exactly task k's categories, and ``expected_accuracy (H, K)`` the accuracy it
can expect. A thickness *solves* a task when its solve probability is at least
``solve_probability`` (default 0.5: more likely than not). The seeded outcome
of the procedure itself (one draw per repeat) is kept as ``accuracy``.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np

from ..errors import InputError
from ..tolerances import EPS
from .formation import CategoryFormation, kmeans_splits
from .tasks import Task, task_accuracies


@dataclass
class LayerSweep:
    """Result of :func:`design_sweep`.

    thicknesses : (H,) float, metres.
    accuracy : (H, R, K) float, accuracy of the seeded procedure on repeat r (0 where it failed; see ``ok``).
    ok : (H, R) bool, the seeded procedure formed categories.
    retries : (H, R) int, its discarded K-Means attempts.
    expected : (H, R, K) float, accuracy expected over the random K-Means starts, per noise draw
        (0 where the images give no split at all).
    p_solve : (H, R, K) float, probability that the procedure returns exactly task k's split.
    threshold : float, solve probability needed to count a thickness as solving a task.
    """

    thicknesses: np.ndarray
    accuracy: np.ndarray
    ok: np.ndarray
    retries: np.ndarray
    expected: np.ndarray
    p_solve: np.ndarray
    threshold: float

    def solve_rate(self) -> np.ndarray:
        """(H, K) probability of forming exactly the task's split (mean over noise draws)."""
        return self.p_solve.mean(axis=1)

    def solved(self) -> np.ndarray:
        """(H, K) bool, the thickness solves the task (solve rate >= threshold)."""
        return self.solve_rate() >= self.threshold - EPS

    def mean_accuracy(self) -> np.ndarray:
        """(H, K) expected accuracy, mean over the noise draws."""
        return self.expected.mean(axis=1)

    def solving_thicknesses(self, k: int) -> np.ndarray:
        """Thicknesses (m) that solve task index ``k`` (0-based)."""
        return self.thicknesses[self.solved()[:, k]]


def format_ranges_mm(thicknesses, step=None) -> str:
    """``[0.003, 0.004, 0.005, 0.009]`` -> ``"3-5, 9 mm"``; ``"none"`` when empty.

    Consecutive values (spaced by ``step``, default the smallest spacing of the
    sweep) are merged into a range.
    """
    mm = np.round(np.asarray(thicknesses, dtype=np.float64) * 1e3, 6)
    if mm.size == 0:
        return "none"
    if step is None:
        step = float(np.min(np.diff(mm))) if mm.size > 1 else 1.0
    else:
        step = float(step) * 1e3
    parts, start, prev = [], mm[0], mm[0]
    for v in mm[1:]:
        if abs(v - prev - step) > 1e-6:
            parts.append((start, prev))
            start = v
        prev = v
    parts.append((start, prev))
    txt = [f"{a:g}" if a == b else f"{a:g}-{b:g}" for a, b in parts]
    return ", ".join(txt) + " mm"


def design_sweep(thicknesses, images_at: Callable[[float, int], np.ndarray], tasks: list[Task], *,
                 repeats: int = 5, solve_probability: float = 0.5, random_state=None, progress=None,
                 **formation) -> LayerSweep:
    """Category formation at every layer thickness.

    thicknesses : (H,) metres, >= 0 (0: a bare sensor).
    images_at : ``(thickness, repeat) -> (M, N)`` tactile images (one noise realisation per repeat).
    tasks : from :func:`make_tasks`. repeats : int >= 1.
    solve_probability : in (0, 1], the chance of forming exactly a task's split that counts as solving it.
    random_state : seed or Generator for the seeded K-Means runs.
    formation : keyword arguments of :class:`CategoryFormation` (``n_runs``, ``max_retries``, ``n_init``).
    """
    h = np.asarray(thicknesses, dtype=np.float64).reshape(-1)
    if h.size == 0 or not np.isfinite(h).all() or (h < 0).any():
        raise InputError(f"thicknesses must be finite and >= 0 m, got {h.tolist()}", key="thicknesses")
    if isinstance(repeats, bool) or not isinstance(repeats, (int, np.integer)) or repeats < 1:
        raise InputError(f"must be an integer >= 1, got {repeats!r}", key="repeats")
    if not 0.0 < solve_probability <= 1.0:
        raise InputError(f"must be in (0, 1], got {solve_probability}", key="solve_probability")
    rng = random_state if isinstance(random_state, np.random.Generator) else np.random.default_rng(random_state)
    k = len(tasks)
    targets = np.stack([t.target for t in tasks])  # (K, N)
    acc = np.zeros((h.size, repeats, k))
    expected = np.zeros((h.size, repeats, k))
    p_solve = np.zeros((h.size, repeats, k))
    ok = np.zeros((h.size, repeats), dtype=bool)
    retries = np.zeros((h.size, repeats), dtype=np.int64)
    n_runs = formation.get("n_runs", 3)
    n_init = formation.get("n_init", 1)
    cells = [(i, r) for i in range(h.size) for r in range(repeats)]
    it = progress(cells, desc="thickness sweep", total=len(cells)) if progress else cells
    for i, r in it:
        # Each fit limits its own thread pools; pressing (inside images_at) keeps them.
        est = CategoryFormation(random_state=rng, **formation).fit(images_at(float(h[i]), r))
        retries[i, r] = est.n_retries_
        if est.ok:
            ok[i, r] = True
            acc[i, r] = task_accuracies(est.labels_, tasks)
        for split in kmeans_splits(est.projection_, n_runs=n_runs, n_init=n_init) if est.n_components_ else []:
            if not split["valid"]:
                continue
            lab = split["labels"]
            expected[i, r] += split["p_accepted"] * task_accuracies(lab, tasks)
            exact = (targets == lab).all(axis=1) | (targets == 1 - lab).all(axis=1)
            p_solve[i, r] += split["p_accepted"] * exact
    return LayerSweep(h, acc, ok, retries, expected, p_solve, float(solve_probability))
