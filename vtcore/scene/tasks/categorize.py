"""Tasks ``categorize`` and ``categorize_sweep``: category formation through a soft layer (seed 001).

``categorize`` presses every ``[[objects]]`` entry on the skin through the
scene's ``[layer]`` at ``task.force``, builds the tactile images (``readings``
readings averaged, ``trials`` trials averaged, the listed sensor effects on
every reading), forms two categories (PCA + K-Means), scores the 7 tasks of
seed 001 (Fig. 8), draws the projection with the K-Means boundary (Fig. 9) and
runs the spatial-resolution study (Fig. 10).

``categorize_sweep`` is the soft-layer designer: the same at every thickness of
``task.thicknesses``, ``task.repeats`` noise draws each, and reports which
thicknesses solve each task, with a plot of accuracy against thickness. It also
reports the *model variants* (``vtcore.categorize.variants``): the same
category formation at ``task.variant_thicknesses`` for every layer base in
``task.variant_bases`` and sensor transfer in ``task.variant_p_halfs`` (0:
linear), so a reader sees how much the result rests on those assumptions.

The noise-free pressure of each (object, thickness) is computed once per run
and cached; the sensor effects run through ``ctx.pipeline.apply("sensor", ...)``
on every reading.
"""

from __future__ import annotations

import time
import warnings

import numpy as np

from ...categorize import (PAPER_FIG8, PAPER_TASK_NOTES, CategoryFormation, confusion, design_sweep,
                           format_ranges_mm, kmeans_splits, make_tasks, resolution_study, tactile_images,
                           task_accuracies)
from ...categorize import plots as cplots
from ...categorize.variants import variant_grid, variant_sweep, variants_summary, variants_table
from ...contact.materials import LargeDeformationWarning, compression_note
from ...errors import UnreachableTargetError
from ...tolerances import EPS
from ..registry import SENSOR_EFFECTS, TaskSpec, register_task
from ..runner import TaskResult
from ..budget import MAX_FORCE_N
from ..schema import Field, Section

_COMMON = {
    "force": Field("float", default=10.0, gt=0, le=MAX_FORCE_N, unit="N", doc="total normal force of each press (seed 001: 10 N)"),
    "readings": Field("int", default=10, ge=1, doc="readings averaged while the force is held (seed 001: 10)"),
    "trials": Field("int", default=3, ge=1, doc="trials averaged per object (seed 001: 3)"),
    "kmeans_runs": Field("int", default=3, ge=1, doc="K-Means runs that must agree (seed 001: 3)"),
    "kmeans_init": Field("int", default=1, ge=1,
                         doc="random starts per K-Means run, lowest inertia kept (1: one start per run; "
                             "scikit-learn's default for init='random' is 10; seed 001 does not say)"),
    "max_retries": Field("int", default=10, ge=0, doc="discarded attempts allowed before giving up"),
    "rate": Field("float", default=20.0, gt=0, unit="Hz", doc="sensor reading rate (seed 001: 20 Hz)"),
}

_PLACEMENT = {
    "radius_reading": Field("str", default="radius", choices=("radius", "diameter"),
                            doc="seed 001 gives the sphere and half-cylinder as 'radius = 30mm': read as a "
                                "radius (the objects' radius as given) or as a diameter (their radius halved)"),
    "object_yaw": Field("float", default=0.0, unit="rad",
                        doc="turn every object about the press axis (the paper does not give how the long "
                            "objects lay on the patch)"),
}

PARAMS = Section({
    **_COMMON,
    **_PLACEMENT,
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

SWEEP_PARAMS = Section({
    **_COMMON,
    **_PLACEMENT,
    "solve_probability": Field("float", default=0.5, gt=0, le=1,
                               doc="chance of forming exactly a task's split that counts as solving it, "
                                   "averaged over a sweep's seeds (`vtcore sweep` designer table)"),
    "thicknesses": Field("vec", default=[i * 1e-3 for i in range(1, 16)], length=(1, 200), unit="m",
                         doc="layer thicknesses to try"),
    "repeats": Field("int", default=5, ge=1, doc="noise draws per thickness"),
    "variant_thicknesses": Field("vec", default=[0.003, 0.006, 0.010], length=(0, 50), unit="m",
                                 doc="thicknesses of the model-variants table (empty: no table)"),
    "variant_bases": Field("list", default=["bonded", "frictionless"],
                           item=Field("str", choices=("bonded", "frictionless")),
                           doc="layer bases of the model-variants table"),
    "variant_p_halfs": Field("list", default=[0.0, 1000.0, 2000.0, 3000.0, 5000.0, 7000.0, 10000.0, 20000.0],
                             item=Field("float", ge=0),
                             unit="Pa", doc="sensor transfers of the model-variants table: p_half, 0 = linear"),
})


# -- the contact part: layout, objects, pressures (cached per object and thickness) ----------------

class _Pressures:
    """Noise-free taxel stress of every object pressed through a layer of a given thickness.

    Each (object, thickness) is pressed once per run (``vtcore.contact.press`` with the
    scene's ``[layer]`` options, then the listed contact-stage effects, e.g. ``soft_layer``
    spreading to the taxels' depth) and cached.
    """

    def __init__(self, scene, ctx):
        from ..sections.layer import build_layer, layer_options
        from ..sections.objects import build_objects
        from ..sections.layout import build_layout

        self.scene, self.ctx = scene, ctx
        self.layout = build_layout(scene)
        self.objects = _placed_objects(scene, build_objects(scene))  # [(name, mesh, pose)]
        if len(self.objects) < 2:
            raise scene.error("objects", f"category formation needs at least 2 [[objects]], got "
                                         f"{len(self.objects)}")
        self.names = [name for name, _, _ in self.objects]
        if len(set(self.names)) != len(self.names):
            raise scene.error("objects", "every [[objects]] entry needs a distinct name")
        self.layer = build_layer(scene)
        self.options = layer_options(scene)
        self.force = scene["task"]["force"]
        self._cache: dict[tuple[str, float, str], dict] = {}

    def _press(self, i, thickness, base=None):
        from dataclasses import replace

        from ...contact import press

        name, mesh, pose = self.objects[i]
        base = base or self.layer.base
        key = (name, round(float(thickness), 12), base)
        if key not in self._cache:
            layer = (self.layer if thickness == self.layer.thickness and base == self.layer.base
                     else replace(self.layer, thickness=float(thickness), base=base))
            # The object starts the same gap above the layer whatever its thickness.
            pose = pose.copy()
            pose[2, 3] += float(thickness) - self.layer.thickness
            res = press(self.layout, mesh, pose, layer, force=self.force, spread=False, **self.options)
            state = {"layout": self.layout, "layer": layer, "results": [res], "mesh": mesh, "compliance": None,
                     "pressure": res.surface_pressure[None, :].copy(),
                     "samples_per_taxel": self.options["samples_per_taxel"]}
            state = self.ctx.pipeline.apply("contact", state, self.ctx)
            self._cache[key] = {"pressure": np.asarray(state["pressure"], float).reshape(-1),
                                "force": float(res.force), "indentation": float(res.indentation),
                                "contact_area": float(res.contact_area), "converged": bool(res.converged),
                                "bottomed_out": bool(res.bottomed_out),
                                "compression": float(res.max_compression / layer.thickness)}
        return self._cache[key]

    def seated(self, i, pose, thickness):
        """``pose`` (4, 4) of object ``i`` moved along z so its lowest point lies the object's gap above a
        layer of ``thickness`` (m): a tilted object must not start inside the layer."""
        _, mesh, _ = self.objects[i]
        v = np.asarray(mesh.vertices, float) @ pose[:3, :3].T + pose[:3, 3]
        out = pose.copy()
        out[2, 3] += self.top(thickness) + self.scene["objects"][i]["gap"] - v[:, 2].min()
        return out

    def top(self, thickness) -> float:
        """Height (m) of the layer's outer surface at its highest point for ``thickness`` (m)."""
        pos, nrm = self.layout.positions, self.layout.normals
        return float((pos[:, 2] + float(thickness) * nrm[:, 2]).max())

    def press_posed(self, i, pose, thickness, base=None) -> np.ndarray:
        """(N,) Pa: object ``i`` pressed at ``pose`` (re-seated) through ``thickness`` (not cached)."""
        from dataclasses import replace

        from ...contact import press

        name, mesh, _ = self.objects[i]
        base = base or self.layer.base
        layer = replace(self.layer, thickness=float(thickness), base=base)
        try:
            res = press(self.layout, mesh, self.seated(i, pose, thickness), layer, force=self.force, spread=False,
                        **self.options)
        except UnreachableTargetError as exc:
            raise UnreachableTargetError(f"object {name!r} through {thickness * 1e3:g} mm ({base}), "
                                         f"jittered: {exc}") from None
        state = {"layout": self.layout, "layer": layer, "results": [res], "mesh": mesh, "compliance": None,
                 "pressure": res.surface_pressure[None, :].copy(),
                 "samples_per_taxel": self.options["samples_per_taxel"]}
        state = self.ctx.pipeline.apply("contact", state, self.ctx)
        self.max_compression = max(getattr(self, "max_compression", 0.0), res.max_compression / layer.thickness)
        return np.asarray(state["pressure"], float).reshape(-1)

    def at(self, thickness, base=None) -> tuple[np.ndarray, list[dict]]:
        """(M, N) pascals and per-object press info; raises UnreachableTargetError naming the object.

        base : the layer's base ("bonded" / "frictionless"); None: the scene's ``[layer] base``.
        """
        rows = []
        for i, name in enumerate(self.names):
            try:
                rows.append(self._press(i, thickness, base))
            except UnreachableTargetError as exc:
                raise UnreachableTargetError(f"object {name!r} through {thickness * 1e3:g} mm: {exc}") from None
        return np.stack([r["pressure"] for r in rows]), rows


def _placed_objects(scene, objects):
    """The scene's objects with ``task.radius_reading`` and ``task.object_yaw`` applied."""
    from ...contact.objects import make_object
    from ..sections.objects import object_pose

    t = scene["task"]
    out = []
    for i, (name, mesh, pose) in enumerate(objects):
        o = scene["objects"][i]
        if t["radius_reading"] == "diameter" and o["kind"] in ("sphere", "halfcylinder"):
            dims = dict(mesh.metadata.get("dims", {}))
            dims["radius"] = dims["radius"] / 2.0
            mesh = make_object(o["kind"], **dims)
            pose = object_pose(scene, i, mesh)
        if t["object_yaw"]:
            c, s_ = np.cos(t["object_yaw"]), np.sin(t["object_yaw"])
            pose = pose.copy()
            pose[:3, :3] = np.array([[c, -s_, 0], [s_, c, 0], [0, 0, 1.0]]) @ pose[:3, :3]
        out.append((name, mesh, pose))
    return out


def _sensor(ctx, rate):
    """``(T, N) Pa -> (T, N) readings``: the listed sensor effects, through the scene's pipeline."""

    def apply(block):
        out = ctx.pipeline.apply("sensor", {"frames": block, "timestamps": np.arange(len(block)) / rate}, ctx)
        return np.asarray(out["frames"], dtype=np.float64)

    return apply


def _variant_sensor(ctx, rate, p_half):
    """Like :func:`_sensor` but with the listed ``gain`` replaced by one of transfer ``p_half`` (Pa, None:
    linear) and the same slope; every other listed sensor effect (noise, clipping, ...) runs as listed."""
    from ...contact.sensor import gain

    listed = ctx.pipeline.get("gain")
    if listed is None:
        if not p_half:
            return _sensor(ctx, rate)
        # a transfer curve is a gain's: applying one (at 1 count/Pa) the scene does not list broke the
        # effect contract (docs/inputs.md)
        raise ctx.scene.error("effects.gain", f"a sensor variant with p_half {p_half:g} Pa (task.variant_p_halfs / "
                                              "task.jitter_p_halfs) is a gain's transfer curve: list [effects.gain] "
                                              "or keep only p_half 0 (linear, the listed sensor)")
    cpp = listed.counts_per_pa

    def apply(block):
        # gain runs first in a read-out (effect order 10), replaced here by the variant's transfer
        t0 = time.perf_counter()
        frames = gain(block, cpp, p_half)
        ctx.pipeline.add_time("gain", time.perf_counter() - t0)  # the listed gain's slope, the variant's curve
        state = {"frames": frames, "timestamps": np.arange(len(block)) / rate}
        for name in ctx.pipeline.stage("sensor"):
            if name != "gain":
                state = ctx.pipeline.get(name).apply(state, ctx)
        return np.asarray(state["frames"], dtype=np.float64)

    return apply


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


def _fig8_table(rows, tasks, paper=True) -> str:
    """Markdown table: one row per (label, accuracies (K,)), plus seed 001's rows where known."""
    head = "| layer | " + " | ".join(f"Task {t.number}" for t in tasks) + " |"
    lines = [head, "|---" * (len(tasks) + 1) + "|"]
    for label, acc, _ in rows:
        cells = ["n/a" if not np.isfinite(a) else (f"**{a:.2f}**" if a >= 1 else f"{a:.2f}") for a in acc]
        lines.append(f"| {label} (simulated) | " + " | ".join(cells) + " |")
    if paper and len(tasks) == 7:
        for label, _, h in rows:
            ref = PAPER_FIG8.get(round(h, 6)) if h is not None else None
            if ref is not None:
                lines.append(f"| {label} (seed 001, Fig. 8) | " + " | ".join(
                    f"**{a:.2f}**" if a >= 1 else f"{a:.2f}" for a in ref) + " |")
    return "\n".join(lines)


def _num(v) -> str:
    return f"{v:.2f}" if np.isfinite(v) else "n/a (no categories formed)"


def _metric_task_names(tasks):
    return [f"accuracy_task{t.number}" for t in tasks]


# -- categorize --------------------------------------------------------------------------------

def run(scene, ctx) -> TaskResult:
    t = scene["task"]
    src = _Pressures(scene, ctx)
    tasks = make_tasks(src.names)
    show = _task_numbers(scene, "resolution_tasks", tasks)
    n_taxels = len(src.layout)
    sizes = [s for s in t["resolution_sizes"]]
    if any(s > n_taxels for s in sizes):
        raise scene.error("task.resolution_sizes", f"subsets cannot be larger than the {n_taxels} taxels")
    h = src.layer.thickness
    try:
        pressure, info = src.at(h)
    except UnreachableTargetError as exc:
        raise scene.error("task.force", str(exc)) from None
    images, frames = tactile_images(pressure, _sensor(ctx, t["rate"]), readings=t["readings"], trials=t["trials"])
    est = _formation(scene, ctx.child_rng("kmeans")).fit(images)

    metrics = {"thickness_mm": h * 1e3, "objects": len(src.names), "taxels": n_taxels,
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
    # What the seeded run above drew from: every split K-Means reaches from a random start,
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
    groups = ("none" if not est.ok else
              " vs ".join("{" + ", ".join(n for n, l in zip(src.names, est.labels_) if l == c) + "}"
                          for c in (0, 1)))
    lines = [f"## Category formation through {label}", "",
             f"Objects pressed at {t['force']:g} N; tactile images from {t['readings']} readings x "
             f"{t['trials']} trials with the sensor effects {', '.join(ctx.pipeline.stage('sensor')) or '(none)'}.",
             "", f"Formation: **{est.status_}**" + (f" ({est.message_})" if est.message_ else "") +
             f", {est.n_retries_} discarded attempt(s). Categories: {groups}.",
             f"Solved tasks: {', '.join(map(str, solved)) or 'none'}.", "",
             "### Accuracy per task (Fig. 8)", "", _fig8_table([(label, acc, h)], tasks), "",
             f"### Where K-Means can land (exact over all {len(src.names) * (len(src.names) - 1) // 2} random "
             f"starts)", "",
             f"A K-Means start is two objects drawn at random; a run keeps the lowest-inertia result of "
             f"{t['kmeans_init']} start(s) (`task.kmeans_init`); an attempt is kept when its "
             f"{t['kmeans_runs']} runs agree. The reported split is one draw from this distribution:", "",
             "| split | p (one start) | p (one run) | p (kept attempt) | inertia | solves task |",
             "|---|---|---|---|---|---|"]
    for r in splits:
        grp = " vs ".join("{" + ", ".join(n for n, l in zip(src.names, r["labels"]) if l == c) + "}" for c in (0, 1))
        hit = [task.number for task, a in zip(tasks, task_accuracies(r["labels"], tasks)) if a >= 1.0] \
            if r["valid"] else []
        lines.append(f"| {grp} | {r['p_start']:.3f} | {r['p_run']:.3f} | {r['p_accepted']:.3f} | {r['inertia']:.4g} | "
                     f"{', '.join(map(str, hit)) or '-'} |")
    lines += ["", "Expected accuracy of the procedure (weighted by p (kept attempt)):", "",
              _fig8_table([(label + " expected", expected, None)], tasks, paper=False)]
    for k, note in PAPER_TASK_NOTES.items():
        if len(tasks) == 7:
            lines.append(f"\nTask {k} ({note}): accuracy {_num(acc[k - 1])} in this run, "
                         f"{_num(expected[k - 1])} expected, through {label}.")

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
        study = resolution_study(images, tasks, sizes=sizes, runs=t["resolution_runs"],
                                 random_state=ctx.child_rng("resolution"), progress=ctx.progress,
                                 n_runs=t["kmeans_runs"], max_retries=t["max_retries"],
                                 n_init=t["kmeans_init"])
        mean, std = study.mean(), study.std()
        for i, s in enumerate(study.sizes):
            metrics[f"resolution_s{s}_failed_runs"] = int(t["resolution_runs"] - study.n_ok[i])
            for k in show:
                num = tasks[k].number
                metrics[f"resolution_s{s}_task{num}_accuracy_mean"] = mean[i, k]
                metrics[f"resolution_s{s}_task{num}_accuracy_std"] = std[i, k]
        arrays.update({"resolution_sizes": study.sizes, "resolution_accuracy": study.accuracy,
                       "resolution_ok": study.ok, "resolution_subsets": study.subsets})
        figures["resolution"] = cplots.resolution_figure(study, tasks, show,
                                                         title=f"spatial resolution, {label}")
        head = "| s | " + " | ".join(f"Task {tasks[k].number} mean ± std" for k in show) + " | failed runs |"
        tab = [head, "|---" * (len(show) + 2) + "|"]
        for i, s in enumerate(study.sizes):
            tab.append(f"| {s} | " + " | ".join(f"{mean[i, k]:.3f} ± {std[i, k]:.3f}" for k in show)
                       + f" | {t['resolution_runs'] - study.n_ok[i]} |")
        lines += ["", f"### Spatial resolution (Fig. 10), {t['resolution_runs']} random subsets per size", "",
                  *tab]
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
    sensors = {ph: _sensor(ctx, t["rate"]) if ph == 0 else _variant_sensor(ctx, t["rate"], ph) for ph in p_halfs}
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


# -- categorize_sweep ----------------------------------------------------------------------------

def run_sweep(scene, ctx) -> TaskResult:
    t = scene["task"]
    src = _Pressures(scene, ctx)
    tasks = make_tasks(src.names)
    hs = np.asarray(t["thicknesses"], dtype=np.float64)
    if (hs < 0).any():
        raise scene.error("task.thicknesses", f"thicknesses must be >= 0 m, got {hs.min()}")
    if len(np.unique(np.round(hs, 9))) != len(hs):
        raise scene.error("task.thicknesses", "thicknesses must be distinct")
    reachable, unreachable = [], []
    for h in ctx.progress(hs, desc="pressing", total=len(hs)):
        try:
            src.at(h)
            reachable.append(h)
        except UnreachableTargetError as exc:
            unreachable.append((h, str(exc)))
    if not reachable:
        raise scene.error("task.thicknesses", "no thickness lets every object reach the target force: "
                          + unreachable[0][1])
    hs_ok = np.asarray(reachable)
    sensor = _sensor(ctx, t["rate"])

    def images_at(h, r):
        return tactile_images(src.at(h)[0], sensor, readings=t["readings"], trials=t["trials"])[0]

    sweep = design_sweep(hs_ok, images_at, tasks, repeats=t["repeats"], solve_probability=t["solve_probability"],
                         random_state=ctx.child_rng("kmeans"), progress=ctx.progress,
                         n_runs=t["kmeans_runs"], max_retries=t["max_retries"],
                                 n_init=t["kmeans_init"])
    acc = sweep.mean_accuracy()
    solved = sweep.solved()
    rate = sweep.solve_rate()
    metrics = {"thicknesses": len(hs_ok), "unreachable_thicknesses": len(unreachable),
               "failed_formations": int((~sweep.ok).sum()), "formation_retries": int(sweep.retries.sum())}
    for i, h in enumerate(hs_ok):
        mm = f"{h * 1e3:g}".replace(".", "p")
        for k, task in enumerate(tasks):
            metrics[f"h{mm}mm_task{task.number}_accuracy"] = acc[i, k]
            metrics[f"h{mm}mm_task{task.number}_solve_probability"] = rate[i, k]
    for k, task in enumerate(tasks):
        metrics[f"task{task.number}_solving_thicknesses"] = int(solved[:, k].sum())
        if solved[:, k].any():
            best = hs_ok[np.argmax(rate[:, k])]
            metrics[f"task{task.number}_best_thickness_mm"] = best * 1e3

    step = float(np.min(np.diff(np.sort(hs_ok)))) if len(hs_ok) > 1 else None
    lines = ["## Soft-layer designer", "",
             f"{len(hs_ok)} thicknesses, {t['repeats']} noise draws each. *Solve probability*: the chance that "
             f"category formation returns exactly the task's two categories (exact over the random K-Means "
             f"starts, averaged over the noise draws). A thickness solves a task when that chance is at least "
             f"{t['solve_probability']:.2f}.", "",
             "| task | groups | solved by | best solve probability |", "|---|---|---|---|"]
    for k, task in enumerate(tasks):
        note = f" ({PAPER_TASK_NOTES[task.number]})" if len(tasks) == 7 and task.number in PAPER_TASK_NOTES else ""
        i_best = int(np.argmax(rate[:, k]))
        lines.append(f"| {task.number}{note} | {task.label} | {format_ranges_mm(hs_ok[solved[:, k]], step)} | "
                     f"{rate[i_best, k]:.2f} at {hs_ok[i_best] * 1e3:g} mm |")
    if unreachable:
        lines += ["", "Thicknesses where an object cannot reach the force (left out): " +
                  "; ".join(f"{h * 1e3:g} mm ({msg})" for h, msg in unreachable)]

    # Seed 001's three layers, if swept: the Fig. 8 table and the paper's claims, stated from this run.
    paper_rows = [(f"{h * 1e3:g} mm", acc[i], h) for i, h in enumerate(hs_ok) if round(h, 6) in PAPER_FIG8]
    if paper_rows and len(tasks) == 7:
        lines += ["", f"### Seed 001's layers (Fig. 8; expected accuracy, mean of {t['repeats']} noise draws)", "",
                  _fig8_table(paper_rows, tasks)]
        idx = {round(h, 6): i for i, h in enumerate(hs_ok)}
        for k, claim in ((5, 0.003), (6, 0.010)):
            if claim in idx and len(paper_rows) > 1:
                col = acc[[idx[round(h, 6)] for _, _, h in paper_rows], k - 1]
                mine = acc[idx[claim], k - 1]
                best = mine >= col.max() - EPS and solved[idx[claim], k - 1]
                lines.append(f"\nTask {k} ({PAPER_TASK_NOTES[k]}): seed 001 finds {claim * 1e3:g} mm best "
                             f"(accuracy 1). Here the expected accuracy is "
                             + ", ".join(f"{lab} {a:.2f}" for (lab, _, _), a in zip(paper_rows, col))
                             + f", and {claim * 1e3:g} mm forms exactly the task's split with probability "
                             f"{rate[idx[claim], k - 1]:.2f}: **{'reproduced' if best else 'not reproduced'}** "
                             f"(reproduced = highest of the three and solved).")
                metrics[f"paper_task{k}_reproduced"] = bool(best)

    # Model variants: the same procedure under every listed (layer base, sensor transfer).
    vt = np.asarray(t["variant_thicknesses"], dtype=np.float64)
    var_arrays = {}
    if vt.size:
        variants = variant_grid(t["variant_bases"], t["variant_p_halfs"])
        if not variants:
            raise scene.error("task.variant_bases", "the model-variants table needs a base and a p_half "
                              "(or an empty task.variant_thicknesses)")
        try:
            for v in variants:
                for h in vt:
                    src.at(h, v.base)
        except UnreachableTargetError as exc:
            raise scene.error("task.variant_thicknesses", str(exc)) from None
        sensors = {v.p_half: _variant_sensor(ctx, t["rate"], v.p_half) for v in variants}

        def variant_images(v, h, r):
            return tactile_images(src.at(h, v.base)[0], sensors[v.p_half], readings=t["readings"],
                                  trials=t["trials"])[0]

        vs = variant_sweep(variants, vt, variant_images, tasks, repeats=t["repeats"],
                           random_state=ctx.child_rng("variants"), n_runs=t["kmeans_runs"],
                           max_retries=t["max_retries"], n_init=t["kmeans_init"])
        v_exp, v_ps = vs.expected(), vs.p_solve()
        gain_fx = ctx.pipeline.get("gain")
        mine = (src.layer.base, gain_fx.p_half if gain_fx is not None else None)
        metrics["variants"] = len(variants)
        var_arrays = {"variant_thicknesses": vt, "variant_expected_accuracy": v_exp,
                      "variant_solve_probability": v_ps, "variant_seeded_accuracy": vs.seeded(),
                      "variant_frictionless": np.array([v.base == "frictionless" for v in variants]),
                      "variant_p_half": np.array([0.0 if v.p_half is None else v.p_half for v in variants])}
        lines += ["", "### Model variants", "",
                  "Seed 001 states neither how the filters meet the sensor (glued or a sliding pad) nor the "
                  "taxels' transfer curve. The same procedure, at the same seed, under every combination "
                  f"listed in the scene ({t['repeats']} noise draws each; *expected acc.*: exact over the "
                  "random K-Means starts; *P(solve)*: probability of forming exactly the task's split; "
                  "*most likely task split*: the task whose split the procedure returns most often). "
                  f"This scene's own set-up is `base = {mine[0]}`, "
                  f"`p_half = {'none (linear)' if mine[1] is None else f'{mine[1]:g} Pa'}`; K-Means keeps the best "
                  f"of {t['kmeans_init']} start(s) per run (`task.kmeans_init`).", "",
                  "Most likely split per variant and layer (Tn: task n's split; P: probability the procedure "
                  "returns it):", "", variants_summary(vs, tasks), "",
                  "In detail:", "", variants_table(vs, tasks)]

    figures = {"accuracy_vs_thickness": cplots.sweep_figure(sweep, tasks)}
    arrays = {**var_arrays, "thicknesses": hs_ok, "sweep_accuracy": sweep.accuracy, "sweep_ok": sweep.ok,
              "sweep_expected_accuracy": sweep.expected, "sweep_solve_probability": sweep.p_solve,
              "solve_rate": rate, "solved": solved,
              "task_targets": np.stack([task.target for task in tasks]),
              "positions": src.layout.positions, "normals": src.layout.normals,
              "object_pressure": np.stack([src.at(h)[0] for h in hs_ok])}
    return TaskResult(metrics=metrics, arrays=arrays, figures=figures, sections=["\n".join(lines)])


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
                    _fig8_table(paper, tasks)]
    return "\n".join(out)


register_task(TaskSpec("categorize", run, PARAMS, sections=("objects",),
                       effects=("soft_layer",) + SENSOR_EFFECTS,
                       doc="seed 001: tactile images, PCA + K-Means categories, 7 tasks, resolution study",
                       sweep_summary=sweep_summary))
register_task(TaskSpec("categorize_sweep", run_sweep, SWEEP_PARAMS, sections=("objects",),
                       effects=("soft_layer",) + SENSOR_EFFECTS,
                       doc="soft-layer designer: which layer thickness solves which task"))
