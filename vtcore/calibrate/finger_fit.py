"""The soft finger's parameters fitted to recorded footprints, and judged on held-out recordings.

The shipped profile's layer and transfer curve are kept (fitted by ``vtcore calibrate``); what is
fitted here is the indenter: a soft finger (:mod:`vtcore.contact.soft_finger`), its pulp's Young's
modulus, the depth of pulp over the bone and the pad's radius, on a grid. Every grid point is one
:func:`vtcore.calibrate.validate.validate` of the *fitted* recordings only (the matched press: pose
from the footprint, the force that reproduces each frame's peak). Its score: for the four footprint
statistics (ring 1, ring 2, active taxels, minor radius), the distance of the simulated median from
the recorded one in units of the recorded inter-quartile range, summed over two frame sets, each
recording's peak frame and all its frames (the model must hold at the strongest press and over the
force range).

Intervals: the recordings are resampled with replacement (``n_boot`` times) and the grid point of
least score found again from the stored per-frame statistics (no new press); a parameter's interval
is the 5-95 % range of its chosen values. An interval that reaches a grid bound says so
(``at_bound``): the grid must be widened before the value is read as identified.

The held-out recordings are then validated once with the chosen finger: their peak-frame statistics
are the test of the fit, never an input to it.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass, field

import numpy as np

from .validate import Validation, peak_frames, validate

#: the four statistics the fit and the held-out test are judged on
STATS = ("ring1", "ring2", "active", "minor_mm")
#: the grid of the soft finger: pulp modulus (Pa; factors of 3 from far softer than the 55 kPa layer
#: to ~15 times stiffer, nearly the rigid pad), pulp depth over the bone (m), pad radius (m; a first
#: grid of 6-9 mm chose its top, so it runs to 12 mm)
GRID = {"pad_modulus": (10e3, 30e3, 90e3, 270e3, 810e3),
        "core_depth": (0.002, 0.0035, 0.005),
        "radius": (0.0075, 0.009, 0.0105, 0.012)}


def _score_parts(real: dict, sim: dict, rec, sel, recs_pick=None) -> float:
    """Sum over STATS of |median sim - median real| / IQR real over the frames ``sel`` (K,) bool,
    the recordings resampled as ``recs_pick`` (indices of recordings, with repeats) when given."""
    if recs_pick is not None:
        idx = np.concatenate([np.flatnonzero((rec == r) & sel) for r in recs_pick])
    else:
        idx = np.flatnonzero(sel)
    s = 0.0
    for m in STATS:
        x, y = np.asarray(real[m], float)[idx], np.asarray(sim[m], float)[idx]
        x, y = x[np.isfinite(x)], y[np.isfinite(y)]
        if not len(x) or not len(y):
            return np.inf
        q25, q50, q75 = np.percentile(x, [25, 50, 75])
        s += abs(float(np.median(y)) - q50) / max(q75 - q25, 1e-9 * max(abs(q50), 1.0))
    return s


def score(v: Validation, recs_pick=None) -> float:
    """The fit's score of one validation (see the module docstring): peak frames plus all frames."""
    pk = peak_frames(v)
    allf = np.ones(len(v.real), bool)
    return (_score_parts(v.real_metrics, v.sim_metrics, v.recording, pk, recs_pick)
            + _score_parts(v.real_metrics, v.sim_metrics, v.recording, allf, recs_pick))


@dataclass
class FingerFit:
    """What :func:`fit_soft_finger` found. best : the chosen parameters; scores : (G,) per grid
    point (``points`` (G,) dicts); intervals : {name: (lo, hi)}; at_bound : {name: bool} (the
    interval reaches the grid's end); chosen : {name: (n_boot,) values picked by the bootstrap}."""

    best: dict
    points: list
    scores: np.ndarray
    intervals: dict
    at_bound: dict
    chosen: dict = field(default_factory=dict)


def grid_points(grid: dict) -> list[dict]:
    """Every combination of the grid's values, as dicts."""
    names = list(grid)
    return [dict(zip(names, vals)) for vals in itertools.product(*(grid[n] for n in names))]


def fit_soft_finger(paths, layout, *, layer, sensor, base: dict, params: dict = GRID, k: float = 5.0, seed: int = 0,
                    n_boot: int = 200, progress=None, **kw) -> FingerFit:
    """Fit the soft finger on the recordings ``paths`` (the fitted set only).

    base : the finger's fixed keys (``length``, ``wrap``; m and 0-1). params : {parameter: values}
    over ``pad_modulus`` Pa, ``core_depth`` m, ``radius`` m. layer, sensor, k : as
    :func:`vtcore.calibrate.validate.validate` (its other keywords pass through ``kw``). Each grid
    point's simulated noise uses the same seed, so scores differ by the finger alone.
    """
    grid = params
    pts = grid_points(grid)
    vals = []
    for p in pts:
        ind = {**base, **p, "kind": "softfinger"}
        vals.append(validate(paths, layout, layer=layer, indenter=ind, sensor=sensor,
                             rng=np.random.default_rng(seed), k=k, **kw))
        if progress is not None:
            progress(p, vals[-1])
    scores = np.array([score(v) for v in vals])
    best = pts[int(np.argmin(scores))]
    rng = np.random.default_rng(seed + 1)
    recs = np.unique(vals[0].recording)
    chosen = {n: [] for n in grid}
    for _ in range(n_boot):
        pick = rng.choice(recs, size=len(recs), replace=True)
        b = pts[int(np.argmin([score(v, pick) for v in vals]))]
        for n in grid:
            chosen[n].append(b[n])
    intervals, at_bound = {}, {}
    for n in grid:
        lo, hi = np.percentile(chosen[n], [5, 95])
        intervals[n] = (float(lo), float(hi))
        at_bound[n] = bool(lo <= min(grid[n]) or hi >= max(grid[n]))
    return FingerFit(best=best, points=pts, scores=scores, intervals=intervals, at_bound=at_bound,
                     chosen={n: np.asarray(c) for n, c in chosen.items()})


def peak_table(v: Validation) -> list[dict]:
    """Rows ``{group, stat, real_median, real_q25, real_q75, sim_median, within}`` for each recording's
    peak frame, the fitted and the held-out recordings apart."""
    pk = peak_frames(v)
    rows = []
    for group, sel in (("fitted", pk & ~v.held_out), ("held out", pk & v.held_out)):
        if not sel.any():
            continue
        for m in STATS:
            x = np.asarray(v.real_metrics[m], float)[sel]
            y = np.asarray(v.sim_metrics[m], float)[sel]
            q25, q50, q75 = np.percentile(x[np.isfinite(x)], [25, 50, 75])
            med = float(np.median(y[np.isfinite(y)]))
            rows.append({"group": group, "stat": m, "recordings": int(sel.sum()), "real_median": float(q50),
                         "real_q25": float(q25), "real_q75": float(q75), "sim_median": med,
                         "within": bool(q25 <= med <= q75)})
    return rows
