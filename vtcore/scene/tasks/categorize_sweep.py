"""Task ``categorize_sweep``: the soft-layer designer (seed 001).

The category formation of :mod:`.categorize` at every thickness of
``task.thicknesses``, ``task.repeats`` noise draws each; reports which
thicknesses solve each task, with a plot of accuracy against thickness. It also
reports the *model variants* (``vtcore.categorize.variants``): the same
category formation at ``task.variant_thicknesses`` for every layer base in
``task.variant_bases`` and sensor transfer in ``task.variant_p_halfs`` (0:
linear), so a reader sees how much the result rests on those assumptions.

The noise-free pressure of each (object, thickness) is computed once per run
and cached (:class:`.categorize_common.Pressures`); the sensor effects run through
``ctx.pipeline.apply("sensor", ...)`` on every reading.
"""

from __future__ import annotations

import numpy as np

from ...categorize import PAPER_FIG8, PAPER_TASK_NOTES, design_sweep, format_ranges_mm, make_tasks, tactile_images
from ...categorize import plots as cplots
from ...categorize.variants import variant_grid, variant_sweep, variants_summary, variants_table
from ...errors import UnreachableTargetError
from ...tolerances import EPS
from ..registry import SENSOR_EFFECTS, TaskSpec, register_task
from ..runner import TaskResult
from ..schema import Field, Section
from .categorize_common import COMMON_PARAMS, PLACEMENT_PARAMS, Pressures, fig8_table, sensor_readout, variant_sensor

SWEEP_PARAMS = Section({
    **COMMON_PARAMS,
    **PLACEMENT_PARAMS,
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


# -- categorize_sweep ----------------------------------------------------------------------------

def _reachable(scene, ctx, src):
    """The thicknesses of ``task.thicknesses`` (m) at which every object reaches the force, and
    (thickness, reason) for the others; none reachable is the scene's ``task.thicknesses`` error."""
    hs = np.asarray(scene["task"]["thicknesses"], dtype=np.float64)
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
    return np.asarray(reachable), unreachable


def _sweep_metrics(sweep, hs_ok, unreachable, tasks) -> dict:
    """Metrics of the designer sweep: accuracy and solve probability per (thickness, task), how many
    thicknesses solve each task and the best one."""
    acc, solved, rate = sweep.mean_accuracy(), sweep.solved(), sweep.solve_rate()
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
    return metrics


def _designer_lines(t, sweep, hs_ok, unreachable, tasks) -> list[str]:
    """Report lines: which thicknesses solve each task, and the thicknesses left out."""
    solved, rate = sweep.solved(), sweep.solve_rate()
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
    return lines


def _paper_claims(t, sweep, hs_ok, tasks, metrics) -> list[str]:
    """Seed 001's three layers, if swept: the Fig. 8 table and the paper's claims (tasks 5 and 6),
    stated from this run; adds ``paper_task{k}_reproduced`` to ``metrics``."""
    acc, solved, rate = sweep.mean_accuracy(), sweep.solved(), sweep.solve_rate()
    paper_rows = [(f"{h * 1e3:g} mm", acc[i], h) for i, h in enumerate(hs_ok) if round(h, 6) in PAPER_FIG8]
    if not (paper_rows and len(tasks) == 7):
        return []
    lines = ["", f"### Seed 001's layers (Fig. 8; expected accuracy, mean of {t['repeats']} noise draws)", "",
             fig8_table(paper_rows, tasks)]
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
    return lines


def _variants_part(scene, ctx, src, tasks, vt):
    """The model variants: the same procedure under every listed (layer base, sensor transfer) at the
    thicknesses ``vt`` (m). Returns (metrics, arrays, report lines)."""
    t = scene["task"]
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
    sensors = {v.p_half: variant_sensor(ctx, t["rate"], v.p_half) for v in variants}

    def variant_images(v, h, r):
        return tactile_images(src.at(h, v.base)[0], sensors[v.p_half], readings=t["readings"],
                              trials=t["trials"])[0]

    vs = variant_sweep(variants, vt, variant_images, tasks, repeats=t["repeats"],
                       random_state=ctx.child_rng("variants"), n_runs=t["kmeans_runs"],
                       max_retries=t["max_retries"], n_init=t["kmeans_init"])
    gain_fx = ctx.pipeline.get("gain")
    mine = (src.layer.base, gain_fx.p_half if gain_fx is not None else None)
    arrays = {"variant_thicknesses": vt, "variant_expected_accuracy": vs.expected(),
              "variant_solve_probability": vs.p_solve(), "variant_seeded_accuracy": vs.seeded(),
              "variant_frictionless": np.array([v.base == "frictionless" for v in variants]),
              "variant_p_half": np.array([0.0 if v.p_half is None else v.p_half for v in variants])}
    lines = ["", "### Model variants", "",
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
    return {"variants": len(variants)}, arrays, lines


def run_sweep(scene, ctx) -> TaskResult:
    t = scene["task"]
    src = Pressures(scene, ctx)
    tasks = make_tasks(src.names)
    hs_ok, unreachable = _reachable(scene, ctx, src)
    sensor = sensor_readout(ctx, t["rate"])

    def images_at(h, r):
        return tactile_images(src.at(h)[0], sensor, readings=t["readings"], trials=t["trials"])[0]

    sweep = design_sweep(hs_ok, images_at, tasks, repeats=t["repeats"], solve_probability=t["solve_probability"],
                         random_state=ctx.child_rng("kmeans"), progress=ctx.progress,
                         n_runs=t["kmeans_runs"], max_retries=t["max_retries"], n_init=t["kmeans_init"])
    metrics = _sweep_metrics(sweep, hs_ok, unreachable, tasks)
    lines = _designer_lines(t, sweep, hs_ok, unreachable, tasks)
    lines += _paper_claims(t, sweep, hs_ok, tasks, metrics)
    vt = np.asarray(t["variant_thicknesses"], dtype=np.float64)
    var_arrays = {}
    if vt.size:
        var_metrics, var_arrays, var_lines = _variants_part(scene, ctx, src, tasks, vt)
        metrics.update(var_metrics)
        lines += var_lines
    figures = {"accuracy_vs_thickness": cplots.sweep_figure(sweep, tasks)}
    arrays = {**var_arrays, "thicknesses": hs_ok, "sweep_accuracy": sweep.accuracy, "sweep_ok": sweep.ok,
              "sweep_expected_accuracy": sweep.expected, "sweep_solve_probability": sweep.p_solve,
              "solve_rate": sweep.solve_rate(), "solved": sweep.solved(),
              "task_targets": np.stack([task.target for task in tasks]),
              "positions": src.layout.positions, "normals": src.layout.normals,
              "object_pressure": np.stack([src.at(h)[0] for h in hs_ok])}
    return TaskResult(metrics=metrics, arrays=arrays, figures=figures, sections=["\n".join(lines)])


register_task(TaskSpec("categorize_sweep", run_sweep, SWEEP_PARAMS, sections=("objects",),
                       effects=("soft_layer",) + SENSOR_EFFECTS,
                       doc="soft-layer designer: which layer thickness solves which task"))
