"""Task ``categorize``: category formation through a soft layer (seed 001).

``categorize`` presses every ``[[objects]]`` entry on the skin through the
scene's ``[layer]`` at ``task.force``, builds the tactile images (``readings``
readings averaged, ``trials`` trials averaged, the listed sensor effects on
every reading), forms two categories (PCA + K-Means), scores the 7 tasks of
seed 001 (Fig. 8), draws the projection with the K-Means boundary (Fig. 9) and
runs the spatial-resolution study (Fig. 10). :func:`sweep_summary` is the
soft-layer designer's table when ``vtcore sweep`` runs this task over
``layer.thickness`` and seeds; :mod:`.categorize_sweep` is the same designer as one task.

The noise-free pressure of each object is computed once per run and cached
(:class:`.categorize_common.Pressures`); the sensor effects run through
``ctx.pipeline.apply("sensor", ...)`` on every reading.
"""

from __future__ import annotations

import warnings

import numpy as np

from ...categorize import (PAPER_FIG8, PAPER_TASK_NOTES, CategoryFormation, confusion, format_ranges_mm, kmeans_splits,
                           make_tasks, resolution_study, tactile_images, task_accuracies)
from ...categorize import plots as cplots
from ...contact.materials import LargeDeformationWarning, compression_note
from ...errors import UnreachableTargetError
from ..registry import SENSOR_EFFECTS, TaskSpec, register_task
from ..runner import TaskResult
from ..schema import Field, Section
from .categorize_common import (COMMON_PARAMS, PLACEMENT_PARAMS, Pressures, fig8_table, sensor_readout,
                                variant_sensor)

PARAMS = Section({
    **COMMON_PARAMS,
    **PLACEMENT_PARAMS,
    "jitter_seeds": Field("int", default=0, ge=0, le=10000,
                          doc="placement jitter draws for the task probabilities (0: no jitter study)"),
    "jitter_xy": Field("float", default=0.002, ge=0, unit="m",
                       doc="per-trial placement offset, standard deviation per axis of the skin plane"),
    "jitter_tilt": Field("float", default=0.0524, ge=0, unit="rad",
                         doc="per-trial tilt about a random horizontal axis, standard deviation (3 deg)"),
    "jitter_yaw": Field("float", default=0.0, ge=0, unit="rad", doc="per-trial turn about the press axis, std"),
    "jitter_bases": Field("list", default=["bonded", "frictionless"],
                          item=Field("str", choices=("bonded", "frictionless")),
                          doc="layer bases compared in the jitter study (the scene's own comes first)"),
    "jitter_p_halfs": Field("list", default=[0.0, 5000.0], item=Field("float", ge=0), unit="Pa",
                            doc="sensor transfers compared in the jitter study: 0 = the listed gain as it is, "
                                "else a saturating transfer of that p_half with the listed slope"),
    "solve_probability": Field("float", default=0.5, gt=0, le=1,
                               doc="chance of forming exactly a task's split that counts as solving it, "
                                   "averaged over a sweep's seeds (`vtcore sweep` designer table)"),
    "resolution_sizes": Field("list", default=[6, 12, 18, 24, 30, 36], item=Field("int", ge=1),
                              doc="taxels per random subset (seed 001: 6, 12, ..., 36)"),
    "resolution_runs": Field("int", default=100, ge=0, doc="random subsets per size (0: no study)"),
    "resolution_tasks": Field("list", default=[5, 6], item=Field("int", ge=1), doc="tasks drawn in Fig. 10"),
})


def _formation(scene, rng):
    t = scene["task"]
    return CategoryFormation(n_runs=t["kmeans_runs"], max_retries=t["max_retries"], n_init=t["kmeans_init"],
                             random_state=rng)


def _task_numbers(scene, key, tasks):
    numbers = [t.number for t in tasks]
    bad = [k for k in scene["task"][key] if k not in numbers]
    if bad:
        raise scene.error(f"task.{key}", f"no task {bad[0]}; tasks are numbered 1..{len(tasks)}")
    return [numbers.index(k) for k in scene["task"][key]]


def _num(v) -> str:
    return f"{v:.2f}" if np.isfinite(v) else "n/a (no categories formed)"


def _metric_task_names(tasks):
    return [f"accuracy_task{t.number}" for t in tasks]


# -- categorize --------------------------------------------------------------------------------

def _formation_metrics(src, info, est, tasks, h):
    """Metrics of one category formation, its accuracy per task (K,) (NaN when no categories formed)
    and confusion matrices (K, 2, 2); returns (metrics, acc, conf, numbers of the solved tasks)."""
    metrics = {"thickness_mm": h * 1e3, "objects": len(src.names), "taxels": len(src.layout),
               "formation_ok": est.ok, "formation_retries": est.n_retries_,
               "explained_variance_pc1": est.explained_variance_ratio_[0],
               "explained_variance_pc2": est.explained_variance_ratio_[1]}
    for name, row in zip(src.names, info):
        metrics[f"force_{name}_n"] = row["force"]
        metrics[f"pressure_max_{name}_pa"] = float(row["pressure"].max())
    if est.ok:
        acc = task_accuracies(est.labels_, tasks)
        conf = np.stack([confusion(est.labels_, task.target) for task in tasks])
    else:
        acc = np.full(len(tasks), np.nan)  # undefined: no categories were formed (status in the report)
        conf = np.zeros((len(tasks), 2, 2), dtype=np.int64)
    metrics.update(dict(zip(_metric_task_names(tasks), acc)))
    solved = [task.number for task, a in zip(tasks, acc) if a >= 1.0]
    metrics["solved_tasks"] = len(solved)
    return metrics, acc, conf, solved


def _split_odds(est, tasks, t, metrics):
    """Every split K-Means reaches from a random start (``kmeans_splits``) and the expected accuracy
    per task (K,) of the procedure; adds the expected accuracies and solve probabilities to ``metrics``."""
    # What the seeded run drew from: every split K-Means reaches from a random start,
    # its probability, and the accuracy expected from the procedure (runs must agree).
    splits = (kmeans_splits(est.projection_, n_runs=t["kmeans_runs"], n_init=t["kmeans_init"])
              if est.n_components_ else [])
    valid = [r for r in splits if r["valid"]]
    expected = (np.sum([r["p_accepted"] * task_accuracies(r["labels"], tasks) for r in valid], axis=0)
                if valid else np.full(len(tasks), np.nan))  # undefined when no split exists
    for task, a in zip(tasks, expected):
        metrics[f"expected_accuracy_task{task.number}"] = a
    # The chance that the procedure returns exactly each task's split (exact over the starts); its
    # mean over seeds (noise draws) is the soft-layer designer's solve probability (sweep_summary).
    targets = np.stack([task.target for task in tasks])
    p_solve = np.zeros(len(tasks))
    for r in valid:
        p_solve += r["p_accepted"] * ((targets == r["labels"]).all(axis=1) | (targets == 1 - r["labels"]).all(axis=1))
    for task, p in zip(tasks, p_solve):
        metrics[f"solve_probability_task{task.number}"] = p
    return splits, expected


def _formation_report(ctx, t, names, est, tasks, acc, expected, solved, splits, label, h) -> list[str]:
    """Report lines: the formation, its accuracy per task (Fig. 8) and where K-Means can land."""
    groups = ("none" if not est.ok else
              " vs ".join("{" + ", ".join(n for n, l in zip(names, est.labels_) if l == c) + "}"
                          for c in (0, 1)))
    lines = [f"## Category formation through {label}", "",
             f"Objects pressed at {t['force']:g} N; tactile images from {t['readings']} readings x "
             f"{t['trials']} trials with the sensor effects {', '.join(ctx.pipeline.stage('sensor')) or '(none)'}.",
             "", f"Formation: **{est.status_}**" + (f" ({est.message_})" if est.message_ else "") +
             f", {est.n_retries_} discarded attempt(s). Categories: {groups}.",
             f"Solved tasks: {', '.join(map(str, solved)) or 'none'}.", "",
             "### Accuracy per task (Fig. 8)", "", fig8_table([(label, acc, h)], tasks), "",
             f"### Where K-Means can land (exact over all {len(names) * (len(names) - 1) // 2} random "
             f"starts)", "",
             f"A K-Means start is two objects drawn at random; a run keeps the lowest-inertia result of "
             f"{t['kmeans_init']} start(s) (`task.kmeans_init`); an attempt is kept when its "
             f"{t['kmeans_runs']} runs agree. The reported split is one draw from this distribution:", "",
             "| split | p (one start) | p (one run) | p (kept attempt) | inertia | solves task |",
             "|---|---|---|---|---|---|"]
    for r in splits:
        grp = " vs ".join("{" + ", ".join(n for n, l in zip(names, r["labels"]) if l == c) + "}" for c in (0, 1))
        hit = [task.number for task, a in zip(tasks, task_accuracies(r["labels"], tasks)) if a >= 1.0] \
            if r["valid"] else []
        lines.append(f"| {grp} | {r['p_start']:.3f} | {r['p_run']:.3f} | {r['p_accepted']:.3f} | {r['inertia']:.4g} | "
                     f"{', '.join(map(str, hit)) or '-'} |")
    lines += ["", "Expected accuracy of the procedure (weighted by p (kept attempt)):", "",
              fig8_table([(label + " expected", expected, None)], tasks, paper=False)]
    for k, note in PAPER_TASK_NOTES.items():
        if len(tasks) == 7:
            lines.append(f"\nTask {k} ({note}): accuracy {_num(acc[k - 1])} in this run, "
                         f"{_num(expected[k - 1])} expected, through {label}.")
    return lines


def _resolution_part(ctx, t, images, tasks, sizes, show, label):
    """The spatial-resolution study (Fig. 10): (metrics, arrays, figure, report lines)."""
    study = resolution_study(images, tasks, sizes=sizes, runs=t["resolution_runs"],
                             random_state=ctx.child_rng("resolution"), progress=ctx.progress,
                             n_runs=t["kmeans_runs"], max_retries=t["max_retries"],
                             n_init=t["kmeans_init"])
    mean, std = study.mean(), study.std()
    metrics = {}
    for i, s in enumerate(study.sizes):
        metrics[f"resolution_s{s}_failed_runs"] = int(t["resolution_runs"] - study.n_ok[i])
        for k in show:
            num = tasks[k].number
            metrics[f"resolution_s{s}_task{num}_accuracy_mean"] = mean[i, k]
            metrics[f"resolution_s{s}_task{num}_accuracy_std"] = std[i, k]
    arrays = {"resolution_sizes": study.sizes, "resolution_accuracy": study.accuracy,
              "resolution_ok": study.ok, "resolution_subsets": study.subsets}
    figure = cplots.resolution_figure(study, tasks, show, title=f"spatial resolution, {label}")
    head = "| s | " + " | ".join(f"Task {tasks[k].number} mean ± std" for k in show) + " | failed runs |"
    tab = [head, "|---" * (len(show) + 2) + "|"]
    for i, s in enumerate(study.sizes):
        tab.append(f"| {s} | " + " | ".join(f"{mean[i, k]:.3f} ± {std[i, k]:.3f}" for k in show)
                   + f" | {t['resolution_runs'] - study.n_ok[i]} |")
    lines = ["", f"### Spatial resolution (Fig. 10), {t['resolution_runs']} random subsets per size", "", *tab]
    return metrics, arrays, figure, lines


def _images(scene, ctx, src, h):
    """Tactile images (M, N) of the objects through the scene's own layer, the readings they average
    and each object's press info; a force no object reaches is the scene's ``task.force`` error."""
    t = scene["task"]
    try:
        pressure, info = src.at(h)
    except UnreachableTargetError as exc:
        raise scene.error("task.force", str(exc)) from None
    images, frames = tactile_images(pressure, sensor_readout(ctx, t["rate"]), readings=t["readings"],
                                    trials=t["trials"])
    return pressure, info, images, frames


def run(scene, ctx) -> TaskResult:
    t = scene["task"]
    src = Pressures(scene, ctx)
    tasks = make_tasks(src.names)
    show = _task_numbers(scene, "resolution_tasks", tasks)
    n_taxels = len(src.layout)
    sizes = [s for s in t["resolution_sizes"]]
    if any(s > n_taxels for s in sizes):
        raise scene.error("task.resolution_sizes", f"subsets cannot be larger than the {n_taxels} taxels")
    h = src.layer.thickness
    pressure, info, images, frames = _images(scene, ctx, src, h)
    est = _formation(scene, ctx.child_rng("kmeans")).fit(images)
    metrics, acc, conf, solved = _formation_metrics(src, info, est, tasks, h)
    splits, expected = _split_odds(est, tasks, t, metrics)

    arrays = {"positions": src.layout.positions, "normals": src.layout.normals,
              "taxel_ids": src.layout.taxel_ids, "object_pressure": pressure, "tactile_images": images,
              "readings": frames, "projection": est.projection_, "labels": est.labels_,
              "centroids": est.centroids_, "task_targets": np.stack([task.target for task in tasks]),
              "task_accuracy": acc, "confusion": conf, "expected_accuracy": np.asarray(expected, float),
              "split_labels": np.array([r["labels"] for r in splits], dtype=np.int64).reshape(-1, len(src.names)),
              "split_p_start": np.array([r["p_start"] for r in splits]),
              "split_p_run": np.array([r["p_run"] for r in splits]),
              "split_p_accepted": np.array([r["p_accepted"] for r in splits])}
    label = f"{h * 1e3:g} mm"
    lines = _formation_report(ctx, t, src.names, est, tasks, acc, expected, solved, splits, label, h)
    figures = {
        "tactile_images": cplots.tactile_images_figure(
            src.layout.flat if src.layout.flat is not None else src.layout.positions[:, :2], images,
            src.names, title=f"tactile images through {label}",
            label="counts" if ctx.pipeline.stage("sensor") else "Pa"),
        "projection": cplots.projection_figure(est, src.names, title=f"PCA projection and K-Means, {label}"),
        "accuracy": cplots.accuracy_figure(acc[None], conf[None], [label], [task.number for task in tasks],
                                           title="confusion matrices and accuracy per task"),
    }
    if t["resolution_runs"] > 0 and sizes:
        rm, ra, figures["resolution"], rl = _resolution_part(ctx, t, images, tasks, sizes, show, label)
        metrics.update(rm)
        arrays.update(ra)
        lines += rl
    big = compression_note(max(r["compression"] for r in info) * h, h, "the firmest press", src.options["model"])
    metrics["compression_max"] = float(max(r["compression"] for r in info))
    if big:
        lines += ["", f"**Warning:** {big}."]
        warnings.warn(big, LargeDeformationWarning, stacklevel=2)
    if t["jitter_seeds"] > 0:
        jl, jm, ja = _jitter_study(scene, ctx, src, tasks, h)
        lines += ["", *jl]
        metrics.update(jm)
        arrays.update(ja)
    nan_meaning = ({"jitter_probability": "a draw whose tilted object presses through the layer (left out, named "
                                          "in the report)"} if t["jitter_seeds"] > 0 else {})
    return TaskResult(metrics=metrics, arrays=arrays, figures=figures, sections=["\n".join(lines)],
                      nan_meaning=nan_meaning)


def _sensor_label(ctx, p_half) -> str:
    gain_fx = ctx.pipeline.get("gain")
    if p_half:
        return f"saturating, p_half {p_half / 1e3:g} kPa"
    if gain_fx is None:
        return "no gain (pascals)"
    prof = getattr(gain_fx, "profile_obj", None)
    own = f"{'measured profile ' + repr(prof.name) if prof is not None else 'listed gain'}"
    curve = "linear" if gain_fx.p_half is None else f"p_half {gain_fx.p_half / 1e3:g} kPa"
    return f"{own} ({curve}, {gain_fx.counts_per_pa:.3g} counts/Pa)"


def _jitter_study(scene, ctx, src, tasks, h):
    """Task probabilities over ``task.jitter_seeds`` per-trial placement draws, for the scene's own layer
    base and sensor and the listed alternatives. Returns (report lines, metrics, arrays)."""
    from ...categorize import tactile_images as images_of
    from ...categorize.jitter import Jitter, jittered_poses, task_probabilities

    t = scene["task"]
    jit = Jitter(t["jitter_xy"], t["jitter_tilt"], t["jitter_yaw"])
    bases = list(dict.fromkeys([src.layer.base] + list(t["jitter_bases"])))      # the scene's own first
    p_halfs = list(dict.fromkeys([0.0] + [float(x) for x in t["jitter_p_halfs"]]))
    sensors = {ph: sensor_readout(ctx, t["rate"]) if ph == 0 else variant_sensor(ctx, t["rate"], ph) for ph in p_halfs}
    poses0 = np.stack([pose for _, _, pose in src.objects])
    n_j, trials, m = t["jitter_seeds"], t["trials"], len(src.objects)
    prob = np.zeros((len(bases), len(p_halfs), n_j, len(tasks)))
    bottomed: list[str] = []
    for j in ctx.progress(range(n_j), desc="jitter draws", total=n_j, unit="draw"):
        # one generator per draw, from the scene's seed: a draw reproduces alone and in any order
        rng = np.random.default_rng([scene.seed, 0x6A17, j])
        poses = jittered_poses(poses0, jit, rng, trials)
        for a, base in enumerate(bases):
            try:
                pres = np.stack([[src.press_posed(i, poses[tr, i], h, base) for i in range(m)] for tr in range(trials)])
            except UnreachableTargetError as exc:
                # the tilted object would press through the layer: this draw has no images (left out, said)
                prob[a, :, j] = np.nan
                bottomed.append(f"draw {j}, {base}: {exc}")
                continue
            for b, ph in enumerate(p_halfs):
                img, _ = images_of(pres, sensors[ph], readings=t["readings"], trials=trials)
                prob[a, b, j] = task_probabilities(img, tasks, n_runs=t["kmeans_runs"], n_init=t["kmeans_init"],
                                                   max_retries=t["max_retries"])
    import warnings as _w

    with _w.catch_warnings():
        _w.simplefilter("ignore", RuntimeWarning)      # a base whose every draw bottomed out: NaN, said below
        mean = np.nanmean(prob, axis=2)
        n_ok = np.isfinite(prob[..., 0]).sum(axis=2)
        se = np.nanstd(prob, axis=2) / np.sqrt(np.maximum(n_ok, 1))[..., None]
    metrics = {"jitter_draws": n_j, "jitter_compression_max": float(getattr(src, "max_compression", 0.0)),
               "jitter_draws_bottomed_out": len(bottomed)}
    for k, task in enumerate(tasks):
        metrics[f"jitter_p_task{task.number}"] = float(mean[0, 0, k])
    for a, base in enumerate(bases):
        for b, ph in enumerate(p_halfs):
            tag = f"{base}_{'profile' if ph == 0 else f'phalf{ph:g}'}"
            for k, task in enumerate(tasks):
                metrics[f"jitter_{tag}_p_task{task.number}"] = float(mean[a, b, k])
    head = "| layer base | sensor | " + " | ".join(f"P(Task {task.number})" for task in tasks) + " | most likely |"
    rows = [head, "|---" * (len(tasks) + 3) + "|"]
    for a, base in enumerate(bases):
        for b, ph in enumerate(p_halfs):
            own = " (this scene)" if a == 0 and b == 0 else ""
            if not np.isfinite(mean[a, b]).any():
                rows.append(f"| {base} | {_sensor_label(ctx, ph)} | " + " | ".join("-" for _ in tasks)
                            + " | every draw bottoms out |")
                continue
            best = int(np.nanargmax(mean[a, b]))
            cells = [f"**{p:.2f}**" if k == best else f"{p:.2f}" for k, p in enumerate(mean[a, b])]
            rows.append(f"| {base}{own} | {_sensor_label(ctx, ph)} | " + " | ".join(cells)
                        + f" | Task {tasks[best].number} ({mean[a, b, best]:.2f} ± {se[a, b, best]:.2f}) |")
    lines = [f"### Task probabilities under placement jitter ({n_j} draws)", "",
             f"Every trial of every object placed anew: offset N(0, {t['jitter_xy'] * 1e3:g} mm) per axis, tilt "
             f"N(0, {np.degrees(t['jitter_tilt']):.3g} deg) about a random horizontal axis, turn "
             f"N(0, {np.degrees(t['jitter_yaw']):.3g} deg) about the press axis; objects turned by "
             f"{np.degrees(t['object_yaw']):.3g} deg, round objects read as '{t['radius_reading']}'. P(Task k): the "
             "probability that category formation returns exactly task k's split (exact over the random K-Means "
             "starts), averaged over the draws (± its standard error in the last column).", "", *rows]
    if bottomed:
        lines += ["", f"{len(bottomed)} (draw, base) pair(s) left out: an object would press through the layer at "
                      f"{scene['task']['force']:g} N (e.g. {bottomed[0]})."]
    arrays = {"jitter_probability": prob, "jitter_bases": np.array(bases), "jitter_p_halfs": np.array(p_halfs)}
    return lines, metrics, arrays


# -- the designer as a sweep: `vtcore sweep` over layer.thickness x seeds ----------------------------

def sweep_summary(scene, rows, keys) -> str:
    """The soft-layer designer's table from ``vtcore sweep`` rows of ``categorize`` points.

    rows : the sweep's finished points (``grid``, ``seed``, ``metrics``); keys : the grid keys.
    For every value of the first key (a thickness, for ``category_sweep``), the solve probability
    and expected accuracy of each task are averaged over the seeds (the noise draws), and a value
    solves a task when that mean is at least ``task.solve_probability``. One table per
    combination of the other grid keys. Nothing for a sweep without grid keys.
    """
    def shown(v):
        return v if isinstance(v, str) else f"{v:g}" if isinstance(v, float) else str(v)

    if not keys:
        return ""
    tasks = make_tasks([o["name"] for o in scene["objects"]])
    threshold = scene["task"]["solve_probability"]
    first, rest = keys[0], keys[1:]
    thick = first == "layer.thickness"
    groups: dict[tuple, dict] = {}
    for r in rows:
        g = groups.setdefault(tuple(r["grid"][k] for k in rest), {})
        g.setdefault(r["grid"][first], []).append(r["metrics"])

    def mean(ms, name):
        v = np.array([np.nan if m.get(name) is None else float(m[name]) for m in ms])
        return float(np.nanmean(v)) if np.isfinite(v).any() else np.nan

    out = ["## Soft-layer designer" if thick else f"## Tasks solved against {first}"]
    for combo, by_value in groups.items():
        values = list(by_value)
        if thick:
            values = sorted(values)
        n_seeds = sorted({len(ms) for ms in by_value.values()})
        rate = np.array([[mean(by_value[v], f"solve_probability_task{t.number}") for t in tasks] for v in values])
        acc = np.array([[mean(by_value[v], f"expected_accuracy_task{t.number}") for t in tasks] for v in values])
        solved = np.nan_to_num(rate, nan=0.0) >= threshold - 1e-12
        label = ", ".join(f"{k}={shown(v)}" for k, v in zip(rest, combo))
        out += ["", *([f"### {label}", ""] if label else []),
                f"{len(values)} values of `{first}`, {'/'.join(map(str, n_seeds))} seed(s) each (noise draws). "
                "*Solve probability*: the chance that category formation returns exactly the task's two "
                "categories (exact over the random K-Means starts, averaged over the seeds). A value solves a "
                f"task when that chance is at least {threshold:.2f}.", "",
                "| task | groups | solved by | best solve probability |", "|---|---|---|---|"]
        for k, task in enumerate(tasks):
            note = f" ({PAPER_TASK_NOTES[task.number]})" if len(tasks) == 7 and task.number in PAPER_TASK_NOTES \
                else ""
            col = np.nan_to_num(rate[:, k], nan=-1.0)
            best = int(np.argmax(col))
            hit = [v for v, ok in zip(values, solved[:, k]) if ok]
            where = (format_ranges_mm(hit, min(np.diff(values)) if len(values) > 1 else None) if thick
                     else ", ".join(shown(v) for v in hit) or "none")
            at = f"{values[best] * 1e3:g} mm" if thick else shown(values[best])
            out.append(f"| {task.number}{note} | {task.label} | {where} | {rate[best, k]:.2f} at {at} |")
        paper = [(f"{h * 1e3:g} mm", acc[i], h) for i, h in enumerate(values)
                 if thick and round(h, 6) in PAPER_FIG8]
        if paper and len(tasks) == 7:
            out += ["", "Seed 001's layers (Fig. 8; expected accuracy, mean over the seeds):", "",
                    fig8_table(paper, tasks)]
    return "\n".join(out)


register_task(TaskSpec("categorize", run, PARAMS, sections=("objects",),
                       effects=("soft_layer",) + SENSOR_EFFECTS,
                       doc="seed 001: tactile images, PCA + K-Means categories, 7 tasks, resolution study",
                       sweep_summary=sweep_summary))
