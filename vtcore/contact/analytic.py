"""An exactly known stand-in for a press onto a thin contour (tests and benchmarks).

Not a contact solver (use :func:`vtcore.contact.press`): a smooth pressure field
whose edge position is known exactly, so filters and controllers can be checked
against it without the elastic solve.
"""

from __future__ import annotations

import numpy as np


def footprint_pressure(dist, gap, force: float = 15.0, spread: float = 2e-3, depth: float = 3e-3,
                       area: float = 4.9e-5):
    """Taxel pressure (N,) Pa of a thin contour pressed into a soft layer, or None without contact.

    dist : (N,) metres, each taxel's distance (across the skin) to the contour's top face.
    gap : (N,) metres, each taxel's height along the press direction; the skin first touches
        where ``gap`` is smallest among the taxels near the contour.
    Pressure ``exp(-dist^2 / (2 spread^2)) * clip(1 - (gap - gap_min) / depth, 0, 1)``,
    scaled so that it sums to ``force`` newtons over ``area`` m^2 per taxel.
    Returns None when no taxel is within ``3 spread`` of the contour.
    """
    dist = np.asarray(dist, dtype=np.float64)
    gap = np.asarray(gap, dtype=np.float64)
    near = dist < 3 * spread
    if not near.any():
        return None
    p = np.exp(-0.5 * (dist / spread) ** 2) * np.clip(1 - (gap - gap[near].min()) / depth, 0, 1)
    total = p.sum() * area
    return None if total <= 0 else p * (force / total)
