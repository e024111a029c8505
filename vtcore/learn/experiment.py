"""Seed 000's classification experiment (Sect. 4.1, Table 1) and the active-touch comparison.

:func:`train_and_test` trains and tests PointNet on one data set version;
:func:`train_mixed` trains one network on random touches at several G;
:func:`active_vs_random` scores test clouds whose touches a policy chose with such a
network, and the held-out compliance-map error of each policy, over several seeds.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np

from .active import map_error, select_touches
from .datasets import TEST, TRAIN, VAL, DataSet, ObjectScan, build_clouds, colour_input, normalise_xyz, propagate

#: Table 1 of seed 000 (accuracy in %), for the report
PAPER_TABLE1 = {"g0": 44.44, "cluster_g3": 79.34, "cluster_g7": 94.84, "cluster_g10": 97.35, "cluster_g13": 98.55,
                "smooth_g3": 70.62, "smooth_g7": 86.37, "smooth_g10": 91.28, "smooth_g13": 97.78}


@dataclass
class VersionResult:
    """One trained and tested data set version.

    accuracy : fraction of the test clouds classified right. confusion : (k, k) counts.
    seconds_data / seconds_train : wall time to build the clouds / to train.
    infer_ms : wall milliseconds per test cloud.
    """

    name: str
    accuracy: float
    confusion: np.ndarray
    curves: dict
    best_epoch: int
    seconds_data: float
    seconds_train: float
    cpu_seconds_train: float
    infer_ms: float
    counts: dict
    model: object = field(repr=False, default=None)


def train_and_test(ds: DataSet, scans: list[ObjectScan], subsamples, cfg, *, scale: float, beta: float = -300.0,
                   progress=None) -> VersionResult:
    """Build the clouds of ``ds``, train PointNet on its train split (validation chooses the epoch),
    test on its test split. ``cfg`` : :class:`vtcore.learn.train.TrainConfig`."""
    from .train import confusion, predict, train

    t0 = time.perf_counter()
    x = build_clouds(ds, scans, subsamples, scale=scale, beta=beta)
    seconds_data = time.perf_counter() - t0
    y = ds.labels
    tr, va, te = (ds.split == c for c in (TRAIN, VAL, TEST))
    res = train(x[tr], y[tr], x[va], y[va], len(scans), cfg, progress=progress)
    t0 = time.perf_counter()
    pred = predict(res.model, x[te]).argmax(axis=1)
    infer_ms = 1e3 * (time.perf_counter() - t0) / max(int(te.sum()), 1)
    conf = confusion(y[te], pred, len(scans))
    return VersionResult(ds.name, float(np.mean(pred == y[te])) if te.any() else float("nan"), conf, res.curves,
                         res.best_epoch, seconds_data, res.seconds, res.cpu_seconds, infer_ms, ds.counts(),
                         res.model)


def train_mixed(scans: list[ObjectScan], subsamples, touches, propagation: str, cfg, *, per_object: int, seed: int,
                scale: float, beta: float = -300.0, progress=None):
    """One PointNet trained on random touches at every G of ``touches`` (``per_object`` clouds per
    object in all, shared evenly among the G values): the network the active-touch comparison
    tests at each G. Returns ``(model, test accuracy on its own random-touch test split, seconds)``."""
    from .datasets import make_dataset
    from .train import predict, train

    each = max(1, per_object // len(touches))
    parts = [make_dataset(scans, g, propagation, per_object=each, seed=seed + 1000, subsamples=subsamples)
             for g in touches]
    x = np.concatenate([build_clouds(ds, scans, subsamples, scale=scale, beta=beta) for ds in parts])
    y = np.concatenate([ds.labels for ds in parts])
    split = np.concatenate([ds.split for ds in parts])
    tr, va, te = (split == c for c in (TRAIN, VAL, TEST))
    res = train(x[tr], y[tr], x[va], y[va], len(scans), cfg, progress=progress)
    acc = float(np.mean(predict(res.model, x[te]).argmax(axis=1) == y[te])) if te.any() else float("nan")
    return res.model, acc, res.seconds


def policy_clouds(policy: str, scans: list[ObjectScan], subsamples, g: int, per_object: int, rng, *,
                  propagation: str, scale: float, beta: float = -300.0):
    """Clouds ``(M, P, 4)`` and labels ``(M,)`` whose G touches ``policy`` chose (seeded).

    Each cloud takes a random disjoint subsample of V_o and a fresh choice of touches
    (for ``farthest``: a random first touch, then farthest-point coverage).
    """
    rng = np.random.default_rng(rng)
    size = subsamples[0].shape[1]
    surfaces = [surface_sample(s) for s in scans]
    x = np.empty((len(scans) * per_object, size, 4), dtype=np.float32)
    y = np.repeat(np.arange(len(scans)), per_object)
    for o, scan in enumerate(scans):
        for k in range(per_object):
            s = int(rng.integers(len(subsamples[o])))
            t = select_touches(policy, scan.touch_points, g, rng, surface=surfaces[o])
            pts = scan.points[subsamples[o][s]]
            j = o * per_object + k
            x[j, :, :3] = normalise_xyz(pts)
            x[j, :, 3] = colour_input(propagate(propagation, scan.touch_points[t], scan.touch_values[t], pts, beta),
                                      scale)
    return x, y


def surface_sample(scan: ObjectScan, n: int = 2000) -> np.ndarray:
    """At most ``n`` points of the visual cloud (a fixed, evenly strided choice) for the coverage policy."""
    step = max(1, len(scan.points) // n)
    return scan.points[::step][:n]


def active_vs_random(models: dict, scans: list[ObjectScan], subsamples, *,
                     policies=("random", "farthest", "coverage"),
                     seeds: int = 5, per_object: int = 20, seed: int = 0, scale: float, beta: float = -300.0,
                     error_touches=None) -> dict:
    """Accuracy and compliance-map error against G for each policy, per seed.

    models : ``(propagation, G) -> trained network`` (trained on random touches, e.g. by
    :func:`train_mixed`: one network for every G).
    Returns ``{"accuracy": {(propagation, policy): (G list, (seeds, len(G)) array)},
    "map_error": {(propagation, policy): (G list, (seeds, len(G)) array)}}``; the map error is
    averaged over objects, at every G from 1 to the fewest probes minus one (``error_touches``).
    """
    from .train import predict

    acc, err = {}, {}
    for prop in sorted({p for p, _ in models}):
        gs = sorted(g for p, g in models if p == prop)
        for policy in policies:
            a = np.full((seeds, len(gs)), np.nan)
            for si in range(seeds):
                for gi, g in enumerate(gs):
                    x, y = policy_clouds(policy, scans, subsamples, g, per_object, [seed, si, g, 7],
                                         propagation=prop, scale=scale, beta=beta)
                    a[si, gi] = float(np.mean(predict(models[(prop, g)], x).argmax(axis=1) == y))
            acc[(prop, policy)] = (gs, a)
    n_min = min(len(s.touch_values) for s in scans)
    eg = list(error_touches or range(1, n_min))
    for prop in sorted({p for p, _ in models}) or ["cluster"]:
        for policy in policies:
            e = np.full((seeds, len(eg)), np.nan)
            for si in range(seeds):
                for gi, g in enumerate(eg):
                    vals = [map_error(s.touch_points, s.touch_values,
                                      select_touches(policy, s.touch_points, g, [seed, si, g, o, 11],
                                                     surface=surface_sample(s)), prop, beta)
                            for o, s in enumerate(scans)]
                    e[si, gi] = float(np.nanmean(vals))
            err[(prop, policy)] = (eg, e)
    return {"accuracy": acc, "map_error": err}


def touches_to_reach(gs, acc: np.ndarray, level: float = 0.95) -> float:
    """The smallest G whose mean accuracy over seeds reaches ``level``; NaN if none does."""
    m = np.nanmean(np.asarray(acc, float), axis=0)
    hit = [g for g, v in zip(gs, m) if v >= level]
    return float(min(hit)) if hit else float("nan")
