"""Seed 000's classification data sets (Sect. 4.1), from the augmented clouds of vtcore.augment.

For each object o: one visual cloud V_o and its tactile cloud T_o (the probes). The
geometry-only set (G = 0) is 15 subsamples of V_o of 512 points each, no two sharing a
point. For G touches, an augmented cloud is one of those subsamples coloured by the
propagation (cluster, Eq. 2, or smooth, Eqs. 3-4) of a G-subset of T_o: there are
``15 * C(|T_o|, G)`` unique ones, of which ``per_object`` (paper: 500) are drawn without
repetition. Each object's clouds are split 70 / 10 / 20 into train / validation / test.

Everything is drawn from one seed (``numpy.random.default_rng``): the same scans and
seed give the same indices, colours and splits, bit for bit. A data set is kept as
indices (which subsample, which touches) plus the scans they index, so it is small to
store and rebuilt exactly by :func:`build_clouds`.

Network inputs: (x, y, z) of each cloud centred on its centroid and scaled into the unit
ball (the usual PointNet normalisation: the network sees shape, not size, so the two
balls, the two bottles and the two cubes look alike without touch), and c divided by
``c_scale``, the stiffest colour probed on any object (a scale shared by all objects, as
the paper's colour map).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ..augment import ClusterPropagation, GPPropagation, SmoothPropagation
from ..errors import InputError

#: the paper's sizes: points per PointNet input, disjoint subsamples of V_o, touch counts, clouds per object
POINTS = 512
SUBSAMPLES = 15
TOUCHES = (3, 7, 10, 13)
PER_OBJECT = 500
SPLIT = (0.7, 0.1, 0.2)
PROPAGATIONS = ("cluster", "smooth")
#: also accepted: the appendix's GP baseline (plain GP regression on the G touches; not in Table 1)
COLOURINGS = PROPAGATIONS + ("gp",)
#: split codes in :attr:`DataSet.split`
TRAIN, VAL, TEST = 0, 1, 2


@dataclass
class ObjectScan:
    """What was measured on one object: its visual cloud and its probes.

    points : (K, 3) float, metres, the visual cloud V_o. touch_points : (n, 3) float,
    metres, the probed points of T_o. touch_values : (n,) float, counts per metre (Eq. 1).
    """

    name: str
    points: np.ndarray
    touch_points: np.ndarray
    touch_values: np.ndarray
    meta: dict = field(default_factory=dict)

    def __post_init__(self):
        self.points = np.asarray(self.points, dtype=np.float64).reshape(-1, 3)
        self.touch_points = np.asarray(self.touch_points, dtype=np.float64).reshape(-1, 3)
        self.touch_values = np.asarray(self.touch_values, dtype=np.float64).reshape(-1)
        if len(self.touch_values) != len(self.touch_points):
            raise InputError(f"{len(self.touch_points)} probe points but {len(self.touch_values)} values",
                             key=f"{self.name}.touch_values")
        if not (np.all(np.isfinite(self.points)) and np.all(np.isfinite(self.touch_points))
                and np.all(np.isfinite(self.touch_values))):
            raise InputError("the visual cloud or the probes hold NaN or inf", key=self.name)


@dataclass
class DataSet:
    """One data set version (a G and a propagation) over all objects, as indices.

    labels : (M,) int, object index into ``objects``. subsample : (M,) int, which of the
    disjoint subsamples. touches : (M, G) int, indices into the object's probes (sorted).
    split : (M,) int8, :data:`TRAIN`, :data:`VAL` or :data:`TEST`. unique_possible : per
    object, how many unique clouds exist (``SUBSAMPLES * C(|T_o|, G)``).
    """

    touches_g: int
    propagation: str
    objects: tuple[str, ...]
    labels: np.ndarray
    subsample: np.ndarray
    touches: np.ndarray
    split: np.ndarray
    unique_possible: dict
    seed: int

    @property
    def name(self) -> str:
        return "g0" if self.touches_g == 0 else f"{self.propagation}_g{self.touches_g}"

    def counts(self) -> dict:
        """Clouds per split: ``{"train": n, "val": n, "test": n}``."""
        return {k: int(np.sum(self.split == c)) for k, c in (("train", TRAIN), ("val", VAL), ("test", TEST))}


def disjoint_subsamples(n_points: int, rng, *, subsets: int = SUBSAMPLES, size: int = POINTS,
                        name: str = "cloud") -> np.ndarray:
    """``(subsets, size)`` indices into a cloud of ``n_points``, no index used twice, seeded.

    A cloud smaller than ``size`` cannot feed PointNet's ``size``-point input, and one
    smaller than ``subsets * size`` cannot give that many disjoint subsamples: both raise
    an InputError saying what was needed (no silent up-sampling or overlap).
    """
    n_points, subsets, size = int(n_points), int(subsets), int(size)
    if subsets < 1 or size < 1:
        raise InputError(f"subsets and size must be >= 1, got {subsets} and {size}", key="subsamples")
    if n_points < size:
        raise InputError(f"the visual cloud has {n_points} points, fewer than the {size} points of one "
                         f"PointNet input; scan it denser (task.points) or lower task.cloud_points", key=name)
    if n_points < subsets * size:
        raise InputError(f"the visual cloud has {n_points} points: {subsets} disjoint subsamples of {size} "
                         f"need {subsets * size} (it gives only {n_points // size})", key=name)
    perm = np.random.default_rng(rng).permutation(n_points)[: subsets * size]
    return np.sort(perm.reshape(subsets, size), axis=1)


def n_unique(n_touches: int, g: int, subsets: int = SUBSAMPLES) -> int:
    """How many unique clouds ``subsets`` subsamples and G-subsets of ``n_touches`` probes make."""
    return subsets * (math.comb(n_touches, g) if g > 0 else 1)


def draw_pairs(n_touches: int, g: int, count: int, rng, *, subsets: int = SUBSAMPLES,
               name: str = "object") -> tuple[np.ndarray, np.ndarray, int]:
    """``count`` unique (subsample, G-subset) pairs: ``(subsample (m,), touches (m, g), unique)``.

    ``m = min(count, unique)`` with ``unique = subsets * C(n_touches, g)``: when fewer unique
    clouds exist than asked for (G = |T_o| gives one subset per subsample) all of them are
    returned, in a seeded order, and the caller reports ``unique``. G > |T_o| is an InputError.
    """
    rng = np.random.default_rng(rng)
    if g < 0:
        raise InputError(f"the number of touches must be >= 0, got {g}", key="touches")
    if g > n_touches:
        raise InputError(f"{name} has {n_touches} probes, fewer than G = {g} touches per cloud", key="touches")
    if count < 1:
        raise InputError(f"must be >= 1, got {count}", key="per_object")
    unique = n_unique(n_touches, g, subsets)
    if unique <= max(4 * count, 20000):
        # few enough to list: every pair once, then a seeded choice (exact, no rejection loop)
        import itertools

        combos = np.array(list(itertools.combinations(range(n_touches), g)), dtype=np.int64).reshape(-1, g)
        pick = rng.permutation(unique)[: min(count, unique)]
        return (pick // len(combos)).astype(np.int64), combos[pick % len(combos)], unique
    # far more pairs than asked for (C(24, 12) = 2.7 M): rejection keeps them unique and rarely rejects
    seen, subs, tch = set(), [], []
    while len(subs) < count:
        s = int(rng.integers(subsets))
        t = tuple(sorted(rng.choice(n_touches, g, replace=False).tolist()))
        if (s, t) not in seen:
            seen.add((s, t))
            subs.append(s)
            tch.append(t)
    return np.asarray(subs, dtype=np.int64), np.asarray(tch, dtype=np.int64).reshape(-1, g), unique


def split_codes(m: int, rng, fractions=SPLIT) -> np.ndarray:
    """(m,) int8 split codes, 70 / 10 / 20 by default, rounded half up for val and test, seeded."""
    n_test = int(m * fractions[2] + 0.5)
    n_val = int(m * fractions[1] + 0.5)
    codes = np.full(m, TRAIN, dtype=np.int8)
    order = np.random.default_rng(rng).permutation(m)
    codes[order[:n_test]] = TEST
    codes[order[n_test:n_test + n_val]] = VAL
    return codes


def make_dataset(scans: list[ObjectScan], g: int, propagation: str = "cluster", *, per_object: int = PER_OBJECT,
                 seed: int = 0, subsamples: list[np.ndarray] | None = None) -> DataSet:
    """One data set version (Sect. 4.1) as indices; see the module docstring.

    scans : the objects (their order gives the labels). g : touches per cloud, 0 for
    the geometry-only set (then every subsample once, ``per_object`` ignored, as in the
    paper's 15 clouds per object). subsamples : per object ``(S, 512)`` indices from
    :func:`disjoint_subsamples` (drawn from ``seed`` when None).
    """
    if propagation not in COLOURINGS:
        raise InputError(f"unknown propagation {propagation!r}; valid: {', '.join(COLOURINGS)}",
                         key="propagation")
    if subsamples is None:
        subsamples = object_subsamples(scans, seed)
    labels, subs, touches, split, unique = [], [], [], [], {}
    for o, scan in enumerate(scans):
        rng = np.random.default_rng([seed, g, o])     # one stream per (G, object): versions do not interact
        n_sub = len(subsamples[o])
        if g == 0:
            s, t, u = rng.permutation(n_sub), np.zeros((n_sub, 0), dtype=np.int64), n_sub
        else:
            s, t, u = draw_pairs(len(scan.touch_values), g, per_object, rng, subsets=n_sub, name=scan.name)
        unique[scan.name] = u
        labels.append(np.full(len(s), o, dtype=np.int64))
        subs.append(s)
        touches.append(t)
        split.append(split_codes(len(s), rng))
    labels = np.concatenate(labels)
    return DataSet(g, propagation if g else "none", tuple(s.name for s in scans), labels,
                   np.concatenate(subs), np.concatenate(touches).reshape(len(labels), g), np.concatenate(split),
                   unique, int(seed))


def object_subsamples(scans: list[ObjectScan], seed: int, subsets: int = SUBSAMPLES,
                      size: int = POINTS) -> list[np.ndarray]:
    """The disjoint subsamples of every object's visual cloud, one seeded stream per object."""
    return [disjoint_subsamples(len(s.points), np.random.default_rng([seed, 10_000 + o]), subsets=subsets,
                                size=size, name=f"{s.name}.points") for o, s in enumerate(scans)]


#: the quantile of all probed colours that sets the top of the shared colour scale
SCALE_QUANTILE = 0.95


def c_scale(scans: list[ObjectScan], quantile: float = SCALE_QUANTILE) -> float:
    """The shared colour scale (counts/m, > 0): the ``quantile`` of every probed colour over all
    objects (robust to a few heavy-tailed touches; see the module docstring)."""
    vals = np.concatenate([s.touch_values for s in scans]) if scans else np.zeros(0)
    top = float(np.quantile(vals, quantile)) if len(vals) else 0.0
    return top if top > 0 else 1.0


def colour_input(c, scale: float) -> np.ndarray:
    """Colours (counts/m) on the shared scale: ``c / scale`` clipped to [0, 1]."""
    return np.clip(np.asarray(c, dtype=np.float64) / float(scale), 0.0, 1.0)


def normalise_xyz(points: np.ndarray) -> np.ndarray:
    """(..., P, 3) clouds centred on their centroids and scaled into the unit ball."""
    p = points - points.mean(axis=-2, keepdims=True)
    r = np.linalg.norm(p, axis=-1).max(axis=-1)[..., None, None]
    return p / np.where(r > 0, r, 1.0)


def propagate(method: str, touch_points, touch_values, points, beta: float = -300.0) -> np.ndarray:
    """Colours (P,) at ``points`` (P, 3) from probes (G, 3), (G,) with the named propagation
    (one of :data:`COLOURINGS`; ``gp`` is the plain GP of the appendix, seeded, no neighbourhoods)."""
    if method == "gp":
        est = GPPropagation(random_state=0)
    else:
        est = ClusterPropagation() if method == "cluster" else SmoothPropagation(beta=beta)
    return est.fit(touch_points, touch_values).predict(points)


def build_clouds(ds: DataSet, scans: list[ObjectScan], subsamples: list[np.ndarray], *, scale: float | None = None,
                 beta: float = -300.0, rows=None) -> np.ndarray:
    """Network inputs ``(M, P, C)`` float32 (C = 3 for G = 0, else 4: x, y, z, c / scale).

    rows : optional subset of the data set's rows (indices). Colours are propagated on
    the 512 subsample points only: both propagations are pointwise in the query points,
    so this equals colouring all of V_o and subsampling after.
    """
    rows = np.arange(len(ds.labels)) if rows is None else np.asarray(rows)
    scale = c_scale(scans) if scale is None else float(scale)
    size = subsamples[0].shape[1]
    out = np.empty((len(rows), size, 3 if ds.touches_g == 0 else 4), dtype=np.float32)
    for j, r in enumerate(rows):                       # one fit per cloud: G probes, 512 points
        o, s = ds.labels[r], ds.subsample[r]
        pts = scans[o].points[subsamples[o][s]]
        out[j, :, :3] = normalise_xyz(pts)
        if ds.touches_g:
            t = ds.touches[r]
            out[j, :, 3] = colour_input(propagate(ds.propagation, scans[o].touch_points[t],
                                                  scans[o].touch_values[t], pts, beta), scale)
    return out


def manifest(datasets: list[DataSet], scans: list[ObjectScan], *, scale: float, points: int = POINTS) -> dict:
    """A JSON-able description of the data sets: sizes, splits, unique clouds possible, the scans.
    points : the points per cloud the data sets were drawn with (``task.cloud_points``)."""
    return {
        "objects": [{"name": s.name, "visual_points": len(s.points), "probes": len(s.touch_values),
                     "c_min": float(np.min(s.touch_values)), "c_max": float(np.max(s.touch_values)),
                     **{k: v for k, v in s.meta.items() if isinstance(v, (int, float, str))}} for s in scans],
        "points_per_cloud": int(points),
        "c_scale": scale,
        "normalisation": f"xyz centred and scaled into the unit ball per cloud; c divided by c_scale (the "
                         f"{SCALE_QUANTILE:g} quantile of all probed colours) and clipped to [0, 1]",
        "datasets": [{"name": d.name, "touches": d.touches_g, "propagation": d.propagation,
                      "clouds": len(d.labels), **d.counts(), "unique_possible": d.unique_possible,
                      "seed": d.seed} for d in datasets],
    }
