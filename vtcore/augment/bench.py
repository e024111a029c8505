"""``vtcore bench augment``: propagation time and accuracy side by side (seed 000's bottle).

The empty bottle seen by two virtual D415s, subsampled to the paper's 33,676
points, probed at 24 points with the closed-form series probe (so the dense
ground truth is known at every point). Each method's colours are compared with
that truth (mean absolute error, % of the mean colour) next to its time
(best of several runs, fit + predict). Rows: cluster-based (brute force and
KD-tree), smooth (float64, float32, truncated to k contacts, beta sweep), the
incremental per-touch update, 1,000 noise-free touches (where truncation pays), the GP baseline (plain, and with the paper's
3 cm neighbourhood augmentation), fewer touches, and 1 M points x 24 touches.
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np

from .._bench import best_time, save_png, write_table
from . import propagation as prop
from .compliance import ProbeModel
from .experiment import probe_object
from .objects import make_seed000_object
from .propagation import AugmentedPointCloud, ClusterPropagation, GPPropagation, SmoothPropagation

#: What this benchmark measures its error against (the closing note of ``vtcore bench`` lists it).
REFERENCE = ("the dense ground-truth colour of the series probe at every point of the bottle (closed form), "
             "not a propagation")

PAPER_POINTS = 33676


def _row(method, setting, points, touches, seconds, error_pct):
    return {"method": method, "setting": setting, "points": int(points), "touches": int(touches),
            "time_ms": round(seconds * 1e3, 3), "error_rel_pct": None if error_pct is None else round(error_pct, 3)}


def run(out: Path, quick: bool = False) -> list[dict]:
    out = Path(out)
    rep = 2 if quick else 7
    obj = make_seed000_object("empty_bottle")
    probe = ProbeModel()
    n_points = 5000 if quick else PAPER_POINTS
    pb = probe_object(obj, 24, probe, n_points=n_points, rng=0)
    x, truth = pb.points, pb.truth
    v, c = pb.tactile.points, pb.tactile.values
    scale = float(np.mean(truth))

    def err(y):
        return 100.0 * float(np.mean(np.abs(y - truth))) / scale

    rows = []

    def measure(method, setting, est, points=x, touches=v, values=c, with_error=True, repeat=rep):
        t, y = best_time(lambda: est.fit(touches, values).predict(points), repeat)
        rows.append(_row(method, setting, len(points), len(touches), t, err(y) if with_error else None))
        return y

    measure("cluster", "brute force (default, n <= 64)", ClusterPropagation())
    old = prop.BRUTE_FORCE_MAX
    try:
        prop.BRUTE_FORCE_MAX = 0                       # force the KD-tree path for comparison
        measure("cluster", "KD-tree", ClusterPropagation())
    finally:
        prop.BRUTE_FORCE_MAX = old
    measure("smooth", "beta=-300, float64 (default)", SmoothPropagation())
    measure("smooth", "beta=-300, float32 kernel", SmoothPropagation(dtype=np.float32))
    for k in (1, 2, 4, 8):
        measure("smooth truncated", f"k_nearest={k}", SmoothPropagation(k_nearest=k))
    for beta in (-30.0, -100.0, -1000.0, -3000.0):
        measure("smooth", f"beta={beta:g}", SmoothPropagation(beta=beta))
    for n in (3, 7, 13):
        measure("cluster", f"{n} touches", ClusterPropagation(), touches=v[:n], values=c[:n])
        measure("smooth", f"{n} touches", SmoothPropagation(), touches=v[:n], values=c[:n])

    # many touches (e.g. a densely explored object): where truncation pays
    many = 200 if quick else 1000
    pick = np.random.default_rng(2).choice(len(x), many, replace=False)
    vm, cm = x[pick], probe.true_c(obj.stiffness(x[pick]))
    measure("smooth", f"{many} touches, dense", SmoothPropagation(), touches=vm, values=cm)
    for k in (4, 16):
        measure("smooth truncated", f"{many} touches, k_nearest={k}", SmoothPropagation(k_nearest=k), touches=vm,
                values=cm)
    measure("cluster", f"{many} touches (KD-tree)", ClusterPropagation(), touches=vm, values=cm)

    # incremental: cost of adding the 24th touch to a cloud that has 23
    for method in ("cluster", "smooth"):
        def add_last(method=method):
            aug = AugmentedPointCloud(x, method).add_touches(v[:-1], c[:-1])
            t0 = time.perf_counter()
            aug.add_touch(v[-1], c[-1])
            return time.perf_counter() - t0, aug.values
        ts = [add_last() for _ in range(rep)]
        rows.append(_row(f"{method} incremental", "add the 24th touch", len(x), 24, min(t for t, _ in ts),
                         err(ts[-1][1])))

    # the GP baseline of the appendix
    measure("GP", "24 touches, RBF + white noise", GPPropagation(random_state=0), repeat=1)
    gp_aug = GPPropagation(radius=0.03, voxel=0.004, max_train=300 if quick else 1500, random_state=0)
    t, y = best_time(lambda: gp_aug.fit(v, c, visual_points=x).predict(x), 1)
    rows.append(_row("GP", f"3 cm neighbourhoods, voxel 4 mm, {len(gp_aug.train_points_)} training points",
                     len(x), 24, t, err(y)))

    # 1 M points x 24 touches (accuracy against the truth field evaluated there too)
    m = 100_000 if quick else 1_000_000
    rng = np.random.default_rng(1)
    big = x[rng.integers(0, len(x), m)] + rng.normal(0, 5e-4, (m, 3))
    truth_big = probe.true_c(obj.stiffness(big))  # the closed-form truth at the jittered points
    for name, est in (("cluster", ClusterPropagation()), ("smooth", SmoothPropagation()),
                      ("smooth", SmoothPropagation(dtype=np.float32))):
        t, y = best_time(lambda est=est: est.fit(v, c).predict(big), max(2, rep // 2))
        setting = "float32 kernel" if getattr(est, "dtype", np.float64) is np.float32 else "default"
        e = 100.0 * float(np.mean(np.abs(y - truth_big))) / float(np.mean(truth_big))
        rows.append(_row(name, f"{m:,} points, {setting}", m, 24, t, e))

    _write(out, rows, quick)
    return rows


def _write(out: Path, rows: list[dict], quick: bool) -> None:
    write_table(out, rows, title="Augmented point cloud: propagation time and accuracy", notes=[
        f"Empty bottle, two virtual D415s, {rows[0]['points']:,} points, 24 probes (series probe model: the "
        "dense ground truth is known at every point). Error: mean |c - c_true| in % of the mean c_true. "
        "Time: best of several runs, fit + predict, one core." + (" QUICK RUN (small sizes)." if quick else ""),
        "Goals (issue 6): smooth <= 5 ms and cluster-based <= 3 ms on 33,676 points x 24 touches; "
        "1 M points x 24 touches <= 0.2 s. Paper: smooth 3.1 s, cluster ~0.1 s, GP ~132 s per object."])

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(8, 5))
    colours = {"cluster": "tab:blue", "smooth": "tab:orange", "smooth truncated": "tab:green", "GP": "tab:red",
               "cluster incremental": "tab:cyan", "smooth incremental": "gold"}
    for r in rows:
        if r["error_rel_pct"] is None:
            continue
        ax.scatter(r["time_ms"], r["error_rel_pct"], color=colours.get(r["method"], "k"), s=25)
        ax.annotate(f"{r['method']}: {r['setting']}", (r["time_ms"], r["error_rel_pct"]), fontsize=6,
                    xytext=(3, 2), textcoords="offset points")
    ax.set_xscale("log")
    ax.set_xlabel("time (ms), log scale")
    ax.set_ylabel("error vs dense ground truth (% of mean c)")
    ax.set_title(f"Propagation on {rows[0]['points']:,} points: accuracy vs time", fontsize=10)
    ax.grid(True, which="both", alpha=0.3)
    save_png(fig, out / "accuracy_vs_time.png")
