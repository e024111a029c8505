"""Soft-layer designer: which layer thickness makes the skin group objects the way a task needs.

Seed 001 measured three layers; the designer sweeps the thickness and, for
every task, reports the thicknesses at which category formation solves it
(accuracy 1, i.e. the two categories formed are exactly the task's split). A
thickness is counted as solving a task when at least ``solve_fraction`` of
``repeats`` independent sensor-noise realisations solve it, so a designer sees
how robust the choice is and not one lucky draw.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np

from ..errors import InputError
from .formation import CategoryFormation
from .tasks import Task, task_accuracies


@dataclass
class LayerSweep:
    """Result of :func:`design_sweep`.

    thicknesses : (H,) float, metres.
    accuracy : (H, R, K) float, accuracy of repeat r on task k (0 where the formation failed).
    ok : (H, R) bool, the repeat formed categories.
    retries : (H, R) int, discarded K-Means attempts.
    solve_fraction : float, fraction of repeats that must solve a task.
    """

    thicknesses: np.ndarray
    accuracy: np.ndarray
    ok: np.ndarray
    retries: np.ndarray
    solve_fraction: float

    def solve_rate(self) -> np.ndarray:
        """(H, K) fraction of repeats (failed ones count as unsolved) with accuracy 1."""
        return ((self.accuracy >= 1.0) & self.ok[..., None]).mean(axis=1)

    def solved(self) -> np.ndarray:
        """(H, K) bool, the thickness solves the task."""
        return self.solve_rate() >= self.solve_fraction - 1e-12

    def mean_accuracy(self) -> np.ndarray:
        """(H, K) mean accuracy over the repeats that formed categories; 0 where none did."""
        w = self.ok[..., None]
        return (self.accuracy * w).sum(axis=1) / np.maximum(w.sum(axis=1), 1)

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
                 repeats: int = 5, solve_fraction: float = 1.0, random_state=None, progress=None,
                 **formation) -> LayerSweep:
    """Category formation at every layer thickness.

    thicknesses : (H,) metres, > 0 or 0 for a bare sensor.
    images_at : ``(thickness, repeat) -> (M, N)`` tactile images (one noise realisation per repeat).
    tasks : from :func:`make_tasks`. repeats : int >= 1. solve_fraction : in (0, 1].
    random_state : seed or Generator for the K-Means initialisations.
    formation : keyword arguments of :class:`CategoryFormation`.
    """
    h = np.asarray(thicknesses, dtype=np.float64).reshape(-1)
    if h.size == 0 or not np.isfinite(h).all() or (h < 0).any():
        raise InputError(f"thicknesses must be finite and >= 0 m, got {h.tolist()}", key="thicknesses")
    if isinstance(repeats, bool) or not isinstance(repeats, (int, np.integer)) or repeats < 1:
        raise InputError(f"must be an integer >= 1, got {repeats!r}", key="repeats")
    if not 0.0 < solve_fraction <= 1.0:
        raise InputError(f"must be in (0, 1], got {solve_fraction}", key="solve_fraction")
    rng = random_state if isinstance(random_state, np.random.Generator) else np.random.default_rng(random_state)
    k = len(tasks)
    acc = np.zeros((h.size, repeats, k))
    ok = np.zeros((h.size, repeats), dtype=bool)
    retries = np.zeros((h.size, repeats), dtype=np.int64)
    cells = [(i, r) for i in range(h.size) for r in range(repeats)]
    it = progress(cells, desc="thickness sweep", total=len(cells)) if progress else cells
    for i, r in it:
        est = CategoryFormation(random_state=rng, **formation).fit(images_at(float(h[i]), r))
        retries[i, r] = est.n_retries_
        if est.ok:
            ok[i, r] = True
            acc[i, r] = task_accuracies(est.labels_, tasks)
    return LayerSweep(h, acc, ok, retries, float(solve_fraction))
