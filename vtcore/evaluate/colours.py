"""Colours and legends of the design maps, the same in PLY files, reports and Blender.

The ramp is viridis sampled at 9 stops (matplotlib's values) and interpolated linearly, so colours
need no matplotlib (the Blender add-on calls this without it). Low is good for every map (a light
touch felt, a small error, a short distance): dark blue is good, yellow is poor, and points where
the quantity has no value (undetectable, never located, never told apart, not evaluated) are drawn
in one flat colour the legend names.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

#: viridis at 0, 1/8, ..., 1 (matplotlib's colormap sampled there, 4 decimals)
_VIRIDIS = np.array([[0.267, 0.0049, 0.3294], [0.2788, 0.1755, 0.4834], [0.2297, 0.3224, 0.5457],
                     [0.1727, 0.4488, 0.5579], [0.1276, 0.5669, 0.5506], [0.1579, 0.6838, 0.5017],
                     [0.3692, 0.7889, 0.3829], [0.6785, 0.8637, 0.1895], [0.9932, 0.9062, 0.1439]])
_STOPS = np.linspace(0.0, 1.0, 9)
#: where a map has no value (blind, never located): a red that viridis never reaches
NO_VALUE = np.array([0.80, 0.10, 0.15])
#: surface that was not evaluated (beyond the margin)
NOT_EVALUATED = np.array([0.55, 0.55, 0.55])


@dataclass(frozen=True)
class Quantity:
    """One map: ``key`` (array name), ``title``, ``unit`` as shown, ``scale`` from SI to that unit,
    ``attribute`` (Blender / PLY name), ``no_value`` (what the flat colour means)."""

    key: str
    title: str
    unit: str
    scale: float
    attribute: str
    no_value: str


QUANTITIES = {
    "threshold": Quantity("threshold", "Detection threshold", "N", 1.0, "threshold_n",
                          "not detected up to the largest force"),
    "localisation": Quantity("localisation", "Localisation error", "mm", 1e3, "localisation_mm",
                             "not detected at the reference force"),
    "two_point": Quantity("two_point", "Two-point discrimination", "mm", 1e3, "two_point_mm",
                          "not told apart up to the largest separation"),
}


def ramp(t) -> np.ndarray:
    """(n, 3) RGB in [0, 1] of ``t`` (n,) in [0, 1] (clipped) on the viridis ramp."""
    t = np.clip(np.asarray(t, float), 0.0, 1.0)
    return np.column_stack([np.interp(t, _STOPS, _VIRIDIS[:, c]) for c in range(3)])


@dataclass
class Legend:
    """What a colour bar shows: ``title``, ``unit``, the value range ``lo``..``hi`` (in ``unit``),
    ``ticks`` (values), ``no_value`` (what the flat red means), ``log`` (ticks spaced in log)."""

    title: str
    unit: str
    lo: float
    hi: float
    ticks: list
    no_value: str
    log: bool = False

    def label(self, v: float) -> str:
        return f"{v:.3g} {self.unit}"

    def lines(self) -> list[str]:
        """The legend as text lines (the panel and reports show these)."""
        return [f"{self.title} ({self.unit}{', log scale' if self.log else ''})",
                f"dark: {self.label(self.lo)}  ..  yellow: {self.label(self.hi)} or more",
                f"red: {self.no_value}"]


def colourise(values, valid, quantity: Quantity, *, lo=None, hi=None, log: bool | None = None,
              evaluated=None) -> tuple[np.ndarray, Legend]:
    """RGBA (n, 4) colours of ``values`` (n,) in SI units with ``valid`` (n,) bool, and their legend.

    lo, hi : range in display units (default: the valid values' 2nd and 98th percentile; equal values
    widen to a small range). log : log-spaced colours (default: when hi / lo > 20). evaluated : (n,)
    bool or None; False is drawn grey.
    """
    v = np.asarray(values, float) * quantity.scale
    ok = np.asarray(valid, bool) & np.isfinite(v)
    if evaluated is not None:
        ok &= np.asarray(evaluated, bool)
    good = v[ok]
    if lo is None:
        lo = float(np.percentile(good, 2)) if len(good) else 0.0
    if hi is None:
        hi = float(np.percentile(good, 98)) if len(good) else 1.0
    if not hi > lo:
        hi = lo + max(abs(lo) * 0.1, 1e-3)
    if log is None:
        log = lo > 0 and hi / lo > 20
    if log and lo > 0:
        t = (np.log(np.maximum(v, 1e-300)) - np.log(lo)) / (np.log(hi) - np.log(lo))
        ticks = list(np.geomspace(lo, hi, 4))
    else:
        log = False
        t = (v - lo) / (hi - lo)
        ticks = list(np.linspace(lo, hi, 5))
    rgb = np.where(ok[:, None], ramp(np.nan_to_num(t)), NO_VALUE)
    if evaluated is not None:
        rgb = np.where(np.asarray(evaluated, bool)[:, None], rgb, NOT_EVALUATED)
    rgba = np.column_stack([rgb, np.ones(len(rgb))])
    return rgba, Legend(quantity.title, quantity.unit, float(lo), float(hi), [float(x) for x in ticks],
                        quantity.no_value, bool(log))
