"""``vtcore bench categorize``: what the contact model's resolution costs and buys for category formation.

A designer sweeping layer thicknesses presses every object at every thickness;
the contact grid and the contact model set the cost. This benchmark measures, for
seed 001's four objects through 3, 6 and 10 mm of Ecoflex 00-20 (noise-free,
linear sensor):

- time: seconds to press the four objects at the three thicknesses (all presses of
  a designer step), and the time of category formation itself;
- accuracy: the largest difference, over thicknesses and the 7 tasks, between the
  expected accuracy (exact over K-Means starts, :func:`kmeans_splits`) and that
  of the reference, whether the most likely split at each thickness is the
  reference's, and the tactile images' largest difference from the reference's
  (over the largest reference stress).

The reference is none of the rows: a converged finite-layer run on finer objects
(the sphere with 16x the faces, the half-cylinder with 4x the sections: closer to
the smooth analytic surfaces) on a 0.25 mm grid (:data:`REFERENCE_GRID`). It is
the finite-layer model converged, not another physics: the project has no other
solution of a finite layer pressed by these objects (no closed form; a
finite-element one is the large-compression issue's, not in vtcore), as in
``vtcore bench contact``.

Rows: model (finite_layer, halfspace, local) x grid spacing (2, 1, 0.5 mm);
``quick`` keeps the three spacings (at least three points per curve) and the 3 and 10 mm layers.
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np

from .._bench import save_png, write_table
from .formation import CategoryFormation, kmeans_splits, single_threaded
from .tasks import PAPER_OBJECTS, make_tasks, task_accuracies

#: What this benchmark measures its error against (the closing note of ``vtcore bench`` lists it).
REFERENCE = ("a converged finite-layer run (none of the rows): the sphere with 16x the faces, the half-cylinder "
             "with 4x the sections, a 0.25 mm grid")

#: the reference's grid spacing (m) and its finer objects' make_object dimensions
REFERENCE_GRID = 0.25e-3
REFERENCE_DIMS = {"sphere": {"subdivisions": 6}, "halfcylinder": {"sections": 384}}


def _images(layout, objects, thicknesses, model, spacing):
    """(H, 4, N) Pa; rows of NaN where an object cannot reach 10 N (it bottoms out)."""
    from ..contact import ContactGrid, SoftLayer, placement_pose, press
    from ..errors import UnreachableTargetError

    out = []
    for h in thicknesses:
        layer = SoftLayer(thickness=h, extent=0.04)
        rows = []
        try:
            for mesh in objects:
                pose = placement_pose(mesh, top=h, gap=1e-3)
                rows.append(press(layout, mesh, pose, layer, force=10.0, model=model,
                                  grid=ContactGrid(spacing=spacing)).pressure)
            out.append(np.stack(rows))
        except UnreachableTargetError:
            out.append(np.full((len(objects), len(layout)), np.nan))
    return np.stack(out)


def _expected(images, tasks):
    """(H, K) expected accuracy and (H, 4) most likely split, per thickness (NaN / -1 where unreachable)."""
    acc, top = [], []
    for x in images:
        if not np.isfinite(x).all():
            acc.append(np.full(len(tasks), np.nan))
            top.append(np.full(len(x), -1))
            continue
        est = CategoryFormation(random_state=0).fit(x)
        splits = [s for s in kmeans_splits(est.projection_) if s["valid"]]
        acc.append(sum(s["p_accepted"] * task_accuracies(s["labels"], tasks) for s in splits))
        top.append(splits[0]["labels"])
    return np.array(acc), np.array(top)


def run(out: Path, quick: bool = False) -> list[dict]:
    """Write ``table.md``, ``table.csv`` and ``accuracy_vs_time.png`` into ``out``; return the rows."""
    from ..contact import make_object
    from ..layout import seed001_disc

    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    _, layout = seed001_disc()
    objects = [make_object(k) for k in PAPER_OBJECTS]
    tasks = make_tasks(PAPER_OBJECTS)
    thicknesses = (0.003, 0.010) if quick else (0.003, 0.006, 0.010)
    spacings = (2e-3, 1e-3, 0.5e-3)  # >= 3 points per curve, quick or not
    models = ("finite_layer", "halfspace", "local")
    # warm up imports and caches so that the first row is not charged for them
    _images(layout, objects[:1], thicknesses[:1], "local", max(spacings))
    with single_threaded():
        _expected(np.random.default_rng(0).normal(size=(1, len(objects), len(layout))), tasks)

    results = {}
    for model in models:
        for dx in spacings:
            t0 = time.perf_counter()
            imgs = _images(layout, objects, thicknesses, model, dx)
            t_press = time.perf_counter() - t0
            t0 = time.perf_counter()
            with single_threaded():
                acc, top = _expected(imgs, tasks)
            t_form = time.perf_counter() - t0
            results[(model, dx)] = (t_press, t_form, acc, top, imgs)
    fine = [make_object(k, **REFERENCE_DIMS.get(k, {})) for k in PAPER_OBJECTS]
    t0 = time.perf_counter()
    ref_img = _images(layout, fine, thicknesses, "finite_layer", REFERENCE_GRID)
    t_ref = time.perf_counter() - t0
    with single_threaded():
        ref_acc, ref_top = _expected(ref_img, tasks)
    scale = np.nanmax(np.abs(ref_img))
    rows = []
    for (model, dx), (t_press, t_form, acc, top, imgs) in results.items():
        ok = np.isfinite(acc).all(axis=1) & np.isfinite(ref_acc).all(axis=1)
        same = [(a == b).all() or (a == 1 - b).all() for a, b, k in zip(top, ref_top, ok) if k]
        err = float(np.abs(acc[ok] - ref_acc[ok]).max()) if ok.any() else float("nan")
        img_err = float(np.abs(imgs[ok] - ref_img[ok]).max() / scale) if ok.any() else float("nan")
        rows.append({"model": model, "grid_mm": dx * 1e3,
                     "layers_reached": f"{int(np.isfinite(acc).all(axis=1).sum())}/{len(thicknesses)}",
                     "press_seconds": round(t_press, 4), "formation_seconds": round(t_form, 4),
                     "max_expected_accuracy_error": round(err, 4), "max_image_error": round(img_err, 4),
                     "same_top_split": f"{sum(same)}/{len(same)}"})

    write_table(out, rows, title="Category formation: contact model and grid against time", notes=[
        f"Seed 001's four objects at 10 N through {', '.join(f'{h * 1e3:g}' for h in thicknesses)} mm; "
        f"reference ({t_ref:.1f} s): {REFERENCE}. Error: largest |expected accuracy - "
        f"reference| over the layers both reached and the 7 tasks (a model may not reach 10 N through a thin "
        f"layer: the half-space ignores the rigid base); image error: largest |stress - reference| over "
        f"the largest reference stress. Same top split: layers whose most likely K-Means split is the "
        f"reference's."])

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6.0, 4.0))
    for model, marker in zip(models, "osD"):
        rs = [r for r in rows if r["model"] == model]
        ax.plot([r["press_seconds"] for r in rs], [r["max_expected_accuracy_error"] for r in rs], marker=marker,
                label=model)
        for r in rs:
            ax.annotate(f"{r['grid_mm']:g} mm", (r["press_seconds"], r["max_expected_accuracy_error"]),
                        textcoords="offset points", xytext=(4, 4), fontsize=7)
    ax.set_xscale("log")
    ax.set_xlabel(f"seconds to press 4 objects x {len(thicknesses)} layers")
    ax.set_ylabel("max error of expected accuracy")
    ax.set_title("category formation: contact model and grid")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    save_png(fig, out / "accuracy_vs_time.png")
    return rows
