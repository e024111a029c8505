"""Model variants: how much of seed 001's result rests on the contact and sensor assumptions.

Seed 001 gives neither how its Ecoflex filters meet the sensor (glued, or a pad
laid on top and slid into place) nor the capacitive taxel's transfer curve. The
simulated grouping depends on both, so a reader needs to see it for every
plausible combination, not only for the one the scenes pick. A *variant* is
one ``(base, p_half)`` pair:

- ``base``: ``"bonded"`` (the layer is glued or cast onto the end-effector: no
  slip at its base) or ``"frictionless"`` (a loose pad that slides on the
  sensor's lycra), see ``vtcore.contact.SoftLayer``;
- ``p_half``: pascals at which the saturating taxel transfer
  ``c = g p_half p / (p + p_half)`` reaches half its ceiling, or ``None`` for a
  linear sensor (``vtcore.contact.sensor.gain``).

:func:`variant_sweep` runs the soft-layer designer (:func:`design_sweep`:
exact K-Means outcome probabilities, averaged over noise draws) for each
variant at a few thicknesses; :func:`variants_table` renders it. The caller
supplies the tactile images, so the same code serves a scene (through its
effect pipeline) and a script.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable, Sequence

import numpy as np

from ..errors import InputError
from .designer import LayerSweep, design_sweep
from .tasks import Task


@dataclass(frozen=True)
class Variant:
    """One contact/sensor assumption. base : "bonded" | "frictionless"; p_half : Pa or None (linear)."""

    base: str
    p_half: float | None

    def __post_init__(self):
        if self.base not in ("bonded", "frictionless"):
            raise InputError(f"must be 'bonded' or 'frictionless', got {self.base!r}", key="base")
        if self.p_half is not None and not (np.isfinite(self.p_half) and self.p_half > 0):
            raise InputError(f"must be > 0 Pa or None (linear), got {self.p_half!r}", key="p_half")

    @property
    def label(self) -> str:
        sensor = "linear" if self.p_half is None else f"saturating, p_half {self.p_half / 1e3:g} kPa"
        return f"{'sliding' if self.base == 'frictionless' else 'bonded'} / {sensor}"


def variant_grid(bases: Sequence[str], p_halfs: Sequence[float | None]) -> list[Variant]:
    """Every ``(base, p_half)`` combination, bases outer; ``p_half`` None or 0 means linear."""
    return [Variant(b, None if (p is None or p == 0) else float(p)) for b in bases for p in p_halfs]


@dataclass
class VariantSweep:
    """Result of :func:`variant_sweep`: ``variants`` (V,), ``thicknesses`` (H,) m, one LayerSweep per variant."""

    variants: list[Variant]
    thicknesses: np.ndarray
    sweeps: list[LayerSweep]

    def expected(self) -> np.ndarray:
        """(V, H, K) expected accuracy (exact over K-Means starts, mean over noise draws)."""
        return np.stack([s.mean_accuracy() for s in self.sweeps])

    def p_solve(self) -> np.ndarray:
        """(V, H, K) probability that the procedure forms exactly task k's split."""
        return np.stack([s.solve_rate() for s in self.sweeps])

    def seeded(self) -> np.ndarray:
        """(V, H, K) accuracy of the seeded procedure, mean over noise draws (failed draws count 0)."""
        return np.stack([s.accuracy.mean(axis=1) for s in self.sweeps])


def variant_sweep(variants: Sequence[Variant], thicknesses, images_at: Callable[[Variant, float, int], np.ndarray],
                  tasks: list[Task], *, repeats: int = 5, random_state=None, **formation) -> VariantSweep:
    """Category formation for every variant at every thickness.

    variants : from :func:`variant_grid`. thicknesses : (H,) metres.
    images_at : ``(variant, thickness, repeat) -> (M, N)`` tactile images.
    tasks : from :func:`make_tasks`. repeats : noise draws per cell.
    random_state : seed or Generator; one generator serves all variants in order (reproducible).
    formation : keyword arguments of :class:`CategoryFormation` (``n_runs``, ``max_retries``).
    """
    variants = list(variants)
    if not variants:
        raise InputError("at least one variant is needed", key="variants")
    rng = random_state if isinstance(random_state, np.random.Generator) else np.random.default_rng(random_state)
    h = np.asarray(thicknesses, dtype=np.float64).reshape(-1)
    sweeps = [design_sweep(h, lambda t, r, v=v: images_at(v, t, r), tasks, repeats=repeats, random_state=rng,
                           **formation) for v in variants]
    return VariantSweep(variants, h, sweeps)


def variants_table(result: VariantSweep, tasks: list[Task], show: Sequence[int] = (5, 6)) -> str:
    """Markdown: one row per (variant, thickness) with the expected accuracy and the solve
    probability of the tasks numbered in ``show``, and the most likely split."""
    numbers = [t.number for t in tasks]
    idx = [numbers.index(k) for k in show if k in numbers]
    exp, ps = result.expected(), result.p_solve()
    cols = " | ".join(f"Task {tasks[k].number} expected acc. / P(solve)" for k in idx)
    head = f"| variant (base / sensor) | layer | {cols} | most likely task split (P) |"
    lines = [head, "|---|---|" + "---|" * len(idx) + "---|"]
    for v, var in enumerate(result.variants):
        for i, h in enumerate(result.thicknesses):
            # every task within rounding of the most likely one: ties are common (a near-rectangle
            # of four images is split either way equally often) and must not be hidden
            best = np.flatnonzero(ps[v, i] >= ps[v, i].max() - 1e-9)
            top = (" = ".join(f"Task {tasks[b].number}" for b in best) + f" ({ps[v, i].max():.2f} each)"
                   if len(best) > 1 else f"Task {tasks[best[0]].number} ({ps[v, i].max():.2f})")
            top = top if ps[v, i].max() > 0 else "none"
            lines.append(f"| {var.label} | {h * 1e3:g} mm | "
                         + " | ".join(f"{exp[v, i, k]:.2f} / {ps[v, i, k]:.2f}" for k in idx) + f" | {top} |")
    return "\n".join(lines)


def variants_summary(result: VariantSweep, tasks: list[Task]) -> str:
    """Markdown, one row per variant and one column per thickness: the task(s) whose split the
    procedure forms most often, with that probability (ties joined by "=")."""
    ps = result.p_solve()
    head = "| variant (base / sensor) | " + " | ".join(f"{h * 1e3:g} mm" for h in result.thicknesses) + " |"
    lines = [head, "|---|" + "---|" * len(result.thicknesses)]
    for v, var in enumerate(result.variants):
        cells = []
        for i in range(len(result.thicknesses)):
            best = np.flatnonzero(ps[v, i] >= ps[v, i].max() - 1e-9)
            cells.append("=".join(f"T{tasks[b].number}" for b in best) + f" {ps[v, i].max():.2f}"
                         if ps[v, i].max() > 0 else "none")
        lines.append(f"| {var.label} | " + " | ".join(cells) + " |")
    return "\n".join(lines)
