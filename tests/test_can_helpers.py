"""Shared builders for the CAN tests (imported by test_can_*.py; holds no tests itself)."""

from __future__ import annotations

import numpy as np

from vtcore.contact import median_taxel_area, press_sphere
from vtcore.layout import Layout, hexagon_flat, wrap_on_sphere


def hexagon_layout(icub: bool = False) -> Layout:
    """The 60-taxel hexagon; CySkin UIDs ``(module + 1) << 4 | 1..10`` or iCub ids of board 1."""
    flat, modules = hexagon_flat()
    pos, nrm = wrap_on_sphere(flat, np.inf)
    if icub:
        ids = 192 * 1 + np.arange(len(pos))        # board 1, triangles 0..4, 12 slots each
        mods = ids // 12
    else:
        ids = ((modules + 1) << 4) | np.tile(np.arange(1, 11), 6)[: len(modules)]
        mods = modules + 1
    return Layout(pos, nrm, ids, mods, flat=flat)


def press_counts(layout: Layout, t: int = 12, peak_counts: float = 800.0, seed: int = 0):
    """A sphere pressing with a force ramp: ``timestamps (T,)`` at 20 Hz and counts ``(T, N)``."""
    area = median_taxel_area(layout.positions)
    surface, _ = press_sphere(layout.positions, layout.normals, [0.004, -0.002], 0.02, 5.0, 0.003,
                              55e3, 0.49, taxel_area=area)
    ramp = np.sin(np.linspace(0.0, np.pi, t)) ** 2
    rng = np.random.default_rng(seed)
    counts = ramp[:, None] * surface[None, :] / surface.max() * peak_counts
    counts = counts + rng.normal(0, 3.0, counts.shape)
    ts = 1700000000.0 + np.arange(t) * 0.05
    return ts, counts
