"""Task ``contour``: seed 002's tapping contour following (ruler / mug, planar / curved skin).

For every method (``mesh``: Eq. 6 on the skin mesh; ``image``: the tactile-image
baseline; ``subtaxel``: Eq. 6 on a Loop-subdivided mesh) the robot follows the
contour ``runs`` times from seeded random starts (the same starts for every
method). Each tap presses the object at ``force`` through the soft layer
(``vtcore.contact.press``), passes the taxel pressure through the listed
sensor effects, finds the edges and moves by Eq. 9. The soft layer is the
scene's standard ``[layer]`` table (thickness, material, contact model, grid),
as for every other task; the seed 002 scenes set 6 mm of Ecoflex 00-50
because the paper does not describe CySkin's cover and 3 mm of Ecoflex 00-20
(the ``[layer]`` default) bottoms out at 15 N on a 1 mm edge. Metrics are seed 002 §6's:
``<method>_d_mean_mm`` (mean of the per-run mean distances), ``_d_std_mm``
(mean of the per-run standard deviations), ``_d_max_mm`` (maximum).
"""

from __future__ import annotations

import time

import numpy as np

from ...plots import png_writer, pyplot
from ..registry import SENSOR_EFFECTS, TaskSpec, register_task
from ..runner import TaskResult
from ..budget import MAX_FORCE_N
from ..schema import Field, Section

METHODS = ("mesh", "image", "subtaxel")

#: Seed 002 Tables 1-2: (d_mean, sigma, d_max) mm for (end-effector, object, method).
PAPER = {
    ("seed002_planar", "ruler", "mesh"): (0.97, 0.67, 2.99),
    ("seed002_planar", "ruler", "image"): (0.89, 0.49, 2.93),
    ("seed002_planar", "mug", "mesh"): (1.53, 0.87, 4.16),
    ("seed002_planar", "mug", "image"): (1.34, 0.85, 3.53),
    ("seed002_curved", "ruler", "mesh"): (1.12, 0.70, 4.11),
    ("seed002_curved", "ruler", "image"): (1.12, 0.53, 2.38),
    ("seed002_curved", "mug", "mesh"): (1.86, 0.96, 5.21),
    ("seed002_curved", "mug", "image"): (1.81, 0.82, 6.12),
}

PARAMS = Section({
    "object": Field("str", default="ruler", choices=("ruler", "mug"), doc="contour to follow"),
    "end_effector": Field("str", default="seed002_planar", choices=("seed002_planar", "seed002_curved"),
                          doc="skin (vtcore.layout end-effector)"),
    "contact": Field("str", default="press", choices=("press", "analytic"),
                     doc="press: vtcore.contact.press; analytic: AnalyticContact (testing)"),
    "position_error": Field("float", default=0.0, ge=0, unit="m",
                            doc="RMS length of the error of the taxel positions the robot believes (its "
                                "control frame and filters use them, the physics the true ones); seed 002: "
                                "~1 mm on its curved patch"),
    "position_error_model": Field("str", default="module", choices=("module", "taxel"),
                                  doc="module: each CySkin module misplaced rigidly (taxels on one PCB keep "
                                      "their CAD distances); taxel: independent per taxel (worst case)"),
    "active_depth": Field("float", default=0.012, gt=0, unit="m",
                          doc="press only taxels within this depth of the tangent plane at x_R "
                              "(the rest cannot touch a flat-topped object; <1% change, 3-5x faster)"),
    "force": Field("float", default=15.0, gt=0, le=MAX_FORCE_N, unit="N", doc="force held at each tap (seed 002: 15 N)"),
    "step": Field("float", default=5e-3, gt=0, unit="m", doc="s of Eq. 9 (seed 002: 5 mm)"),
    "lift": Field("float", default=0.01, ge=0, unit="m", doc="lift between taps (seed 002: 1 cm)"),
    "runs": Field("int", default=3, ge=1, doc="experiments per method (seed 002: 3)"),
    "methods": Field("list", default=list(METHODS), item=Field("str", choices=METHODS)),
    "max_taps": Field("int", default=120, ge=2, doc="safety limit per run"),
    "start_offset": Field("float", default=2e-3, ge=0, unit="m",
                          doc="initial x_R offset from the contour: uniform in +-start_offset"),
    "start_heading": Field("float", default=0.17, ge=0, unit="rad",
                           doc="initial heading error: uniform in +-start_heading"),
    "ruler_length": Field("float", default=0.25, gt=0, unit="m"),
    "ruler_thickness": Field("float", default=1e-3, gt=0, unit="m", doc="seed 002: 1 mm"),
    "ruler_height": Field("float", default=0.02, gt=0, unit="m", doc="how far the ruler stands up"),
    "ruler_margin": Field("float", default=0.03, ge=0, unit="m",
                          doc="start this far inside one end, stop this far before the other"),
    "mug_outer_diameter": Field("float", default=0.081, gt=0, unit="m", doc="seed 002: 81 mm"),
    "mug_inner_diameter": Field("float", default=0.075, gt=0, unit="m", doc="seed 002: 75 mm"),
    "mug_height": Field("float", default=0.10, gt=0, unit="m"),
    "reference_radius": Field("float", default=0.0395, gt=0, unit="m", doc="seed 002's r-bar"),
    "explore_angle": Field("float", default=2 * np.pi, gt=0, unit="rad", doc="mug: stop after this arc"),
    "mesh_fraction": Field("float", default=0.15, ge=0, le=1, doc="Eq. 7 threshold / strongest response"),
    "subtaxel_levels": Field("int", default=2, ge=0, le=4, doc="Loop subdivision steps"),
    "subtaxel_interpolate": Field("str", default="log", choices=("log", "linear"),
                                  doc="subdivide log-pressure (Gaussian-like profiles) or pressure"),
    "subtaxel_fraction": Field("float", default=0.1, ge=0, le=1),
    "subtaxel_centroid": Field("str", default="curve", choices=("curve", "components", "points"),
                               doc="edge at x_R from a local quadratic fit, mean of the major "
                                   "components' centroids, or centroid of all edge points"),
    "image_resolution": Field("float", default=1e-3, gt=0, unit="m", doc="seed 002: 1 mm"),
    "image_sigma": Field("float", default=1.5, gt=0, doc="Canny smoothing, pixels"),
    "image_low": Field("float", default=0.1, gt=0, le=1, doc="Canny low threshold / max gradient"),
    "image_high": Field("float", default=0.2, gt=0, le=1, doc="Canny high threshold / max gradient"),
})


def control_skin(name):
    """``(end-effector mesh, layout in the control frame, control frame pose in the layout frame)``."""
    from ...control.contour import control_skin as make

    return make(name)


def _detectors(p, mesh, layout):
    from ...filters import ImageEdgeDetector, MeshEdgeDetector, SubtaxelEdgeDetector

    out = {}
    for m in p["methods"]:
        if m == "mesh":
            out[m] = MeshEdgeDetector(mesh, fraction=p["mesh_fraction"])
        elif m == "image":
            out[m] = ImageEdgeDetector(mesh.positions, mesh.triangles, layout.flat,
                                       resolution=p["image_resolution"], sigma=p["image_sigma"],
                                       low=p["image_low"], high=p["image_high"])
        else:
            out[m] = SubtaxelEdgeDetector(mesh, levels=p["subtaxel_levels"], fraction=p["subtaxel_fraction"],
                                          centroid=p["subtaxel_centroid"],
                                          interpolate=p["subtaxel_interpolate"])
    return out


def _skin(ctx, p):
    """The skin as it is (``layout``), as the robot believes it (``belief``: with ``task.position_error``,
    seed 002's ~1 mm taxel estimate) and the control frame (4, 4) taken from the belief."""
    from ...control.contour import believed_skin, taxel_position_error

    _, layout, frame = control_skin(p["end_effector"])
    belief = layout
    if p["position_error"] > 0:
        # the robot's model of its skin: seed 002 estimated its curved patch's taxels to ~1 mm.
        # The robot's control frame comes from that model too (x_R is the believed reference taxel)
        err = taxel_position_error(layout, p["position_error"], ctx.child_rng("taxel-position-error"),
                                   p["position_error_model"])
        layout, belief, believed_frame = believed_skin(layout, err)
        frame = frame @ believed_frame
    return layout, belief, frame


def _contact_model(scene, ctx, p, layout, contour, spec, obj_world):
    """The scene's layer, the tap (``PressContact`` through the layer, or the analytic contact) and how
    many taxels can feel a tap."""
    from ...control import AnalyticContact
    from ...control.contour import PressContact
    from ..effects.contact import spread_options
    from ..sections.layer import build_layer, layer_options

    layer = build_layer(scene)  # the scene's [layer] table, the same for every task
    if p["contact"] == "press":
        from ...contact import make_object

        if layer.thickness <= 0:
            raise scene.error("layer.thickness", "the contour task presses through a soft layer: must be > 0 m")
        sense = PressContact(layout, make_object(spec[0], **spec[1]), obj_world, layer, force=p["force"],
                             lift=p["lift"], active_depth=p["active_depth"],
                             **{**layer_options(scene), **spread_options(ctx.pipeline)})
        return layer, sense, len(sense.active)
    return layer, AnalyticContact(layout.positions, contour, force=p["force"], depth=layer.thickness), len(layout)


def _sensing(ctx, p, sense):
    """``sensed(world_pose) -> (N,) or None``: the taxel pressure of one tap after the listed sensor
    effects (what the detectors see); it keeps each tap's force (N) and raw pressure (N,) Pa in its
    ``force`` and ``raw`` lists, which the caller empties before each run."""
    def sensed(world_pose):
        q = sense(world_pose)
        if q is None:
            return None
        sensed.force.append(float(sense.forces[-1]) if p["contact"] == "press" else float(p["force"]))
        sensed.raw.append(np.asarray(q, dtype=np.float64))
        return np.asarray(ctx.pipeline.apply("sensor", np.asarray(q, float)[None, :].copy(), ctx))[0]

    return sensed


def _follow(ctx, p, m, det, sense, sensed, contour, starts, stop, n_taxels):
    """Every run of method ``m`` from ``starts``: (runs, distances per run (m), metrics, arrays)."""
    from ...control import ContourFollower, summarize

    follower = ContourFollower(det, step=p["step"], lift=p["lift"], max_taps=p["max_taps"])
    runs, dists = [], []
    t0 = time.perf_counter()
    saturated0 = getattr(sense, "saturated", 0)
    for start in ctx.progress(starts, desc=f"contour {m}", total=len(starts)):
        sensed.raw, sensed.force = [], []
        r = follower.run(sensed, start, stop)
        r.extra["raw"] = np.array(sensed.raw).reshape(-1, n_taxels)[: len(r)]
        r.extra["force"] = np.array(sensed.force, dtype=np.float64)[: len(r)]
        runs.append(r)
        dists.append(contour.distances(r.x_ref))
    s = summarize(dists)
    n_frames = sum(len(r) for r in runs)
    metrics = {
        f"{m}_d_mean_mm": s["d_mean"] * 1e3, f"{m}_d_std_mm": s["d_std"] * 1e3,
        f"{m}_d_max_mm": s["d_max"] * 1e3, f"{m}_taps": n_frames,
        f"{m}_runs_explored": sum(r.stop_reason == "explored" for r in runs),
        f"{m}_detect_ms": 1e3 * sum(r.seconds_detect for r in runs) / max(n_frames, 1),
        f"{m}_seconds": time.perf_counter() - t0,
        f"{m}_taps_below_force": getattr(sense, "saturated", 0) - saturated0,
    }
    arrays = {f"{m}_x_ref": np.concatenate([r.x_ref for r in runs]),
              f"{m}_run": np.concatenate([np.full(len(r), i) for i, r in enumerate(runs)]),
              f"{m}_theta": np.concatenate([r.theta for r in runs]),
              f"{m}_distance_mm": np.concatenate([np.r_[np.nan, d] * 1e3 for d in dists])}
    return runs, dists, metrics, arrays


def _tap_arrays(runs_by_method) -> dict:
    """The standard arrays: the taps of the mesh filter's runs (the method whose edges are taxels)."""
    first = "mesh" if "mesh" in runs_by_method else next(iter(runs_by_method))
    fr = runs_by_method[first][0]
    return {"pressure": np.concatenate([r.extra["raw"] for r in fr]),
            "frames": np.concatenate([r.pressure for r in fr]),
            "edge": np.concatenate([r.edge for r in fr]),
            "force": np.concatenate([r.extra["force"] for r in fr]),
            "tap_run": np.concatenate([np.full(len(r), i) for i, r in enumerate(fr)])}


def run(scene, ctx) -> TaskResult:
    from ...control.contour import random_starts, seed002_object
    from ...layout import skin_mesh

    p = scene["task"]
    if p["object"] == "mug" and not p["mug_inner_diameter"] < p["mug_outer_diameter"]:
        raise scene.error("task.mug_inner_diameter", "must be smaller than mug_outer_diameter")
    if not p["methods"]:
        raise scene.error("task.methods", "list at least one of mesh, image, subtaxel")
    layout, belief, frame = _skin(ctx, p)
    mesh = skin_mesh(belief)
    detectors = _detectors(p, mesh, belief)
    keys = ("ruler_length", "ruler_thickness", "ruler_height", "mug_outer_diameter", "mug_inner_diameter",
            "mug_height", "reference_radius")
    contour, spec, obj_world = seed002_object(p["object"], **{k: p[k] for k in keys})
    starts = random_starts(contour, p["runs"], ctx.child_rng("contour-starts"), offset=p["start_offset"],
                           heading=p["start_heading"], step=p["step"], margin=p["ruler_margin"])
    layer, sense, n_active = _contact_model(scene, ctx, p, layout, contour, spec, obj_world)
    sensed = _sensing(ctx, p, sense)
    stop = contour.explored(p["ruler_margin"] if p["object"] == "ruler" else p["explore_angle"])

    metrics = {"taxels": len(layout), "force_n": p["force"], "step_mm": p["step"] * 1e3,
               "active_taxels": n_active}
    arrays = {"positions": layout.positions, "normals": layout.normals, "control_frame": frame}
    runs_by_method = {}
    for m, det in detectors.items():
        runs, dists, mm, ma = _follow(ctx, p, m, det, sense, sensed, contour, starts, stop, len(layout))
        metrics.update(mm)
        runs_by_method[m] = (runs, dists)
        arrays.update(ma)
    arrays.update(_tap_arrays(runs_by_method))

    # drawn only when the runner writes plots (output.plots), never built and discarded
    figures = {"path": png_writer(_path_figure, scene.name, p, contour, runs_by_method),
               "edges": png_writer(_edges_figure, belief, detectors, runs_by_method)}
    sections = [_table(p, layer, metrics, runs_by_method)]
    extra = {"contour_table": [{
        "object": p["object"], "end_effector": p["end_effector"], "method": m,
        "d_mean_mm": metrics[f"{m}_d_mean_mm"], "d_std_mm": metrics[f"{m}_d_std_mm"],
        "d_max_mm": metrics[f"{m}_d_max_mm"],
        "paper": list(PAPER[(p["end_effector"], p["object"], m)]) if (p["end_effector"], p["object"], m) in PAPER else None,
    } for m in runs_by_method]}
    # a run's first tap has no distance (seed 002 counts taps 2..L); NaN keeps the array aligned with the taps
    nan_meaning = {f"{m}_distance_mm": "each run's first tap (not counted by seed 002)" for m in runs_by_method}
    return TaskResult(metrics=metrics, arrays=arrays, figures=figures, sections=sections, extra=extra,
                      nan_meaning=nan_meaning)


def _table(p, layer, metrics, runs_by_method) -> str:
    label = {"mesh": "Mesh filter (seed 002, Eq. 6)", "image": "Tactile image (Canny)",
             "subtaxel": "Sub-taxel (Loop-subdivided mesh)"}
    lines = [f"## Contour following: {p['object']}, {p['end_effector']} (like seed 002 Tables 1-2)", "",
             "| Method | d̄ (mm) | σ̄ (mm) | d_M (mm) | taps | seed 002 d̄ / σ̄ / d_M (mm) |",
             "|---|---|---|---|---|---|"]
    for m in runs_by_method:
        ref = PAPER.get((p["end_effector"], p["object"], m))
        refs = " / ".join(f"{v:.2f}" for v in ref) if ref else "n/a (not in the paper)"
        lines.append(f"| {label[m]} | {metrics[f'{m}_d_mean_mm']:.2f} | {metrics[f'{m}_d_std_mm']:.2f} | "
                     f"{metrics[f'{m}_d_max_mm']:.2f} | {metrics[f'{m}_taps']} | {refs} |")
    lines.append("")
    if "mesh" in runs_by_method:
        d = metrics["mesh_d_mean_mm"]
        if d < 0.89:
            cmp = "below"
        elif d <= 1.86:
            cmp = "inside"
        else:
            cmp = "above"
        pitch = 7.5
        ref = PAPER.get((p["end_effector"], p["object"], "mesh"))
        own = f"; {ref[0]:.2f} mm on this object and end-effector" if ref else ""
        lines.append(f"From this run: the mesh filter's mean distance d̄ = {d:.2f} mm is {cmp} the range "
                     f"seed 002 reports for its experiments (0.89-1.86 mm, Tables 1-2{own}), "
                     f"{'below' if d < pitch else 'NOT below'} the 7.5 mm taxel pitch; its maximum "
                     f"d_M = {metrics['mesh_d_max_mm']:.2f} mm.")
        for m in [m for m in runs_by_method if m != "mesh"]:
            diff = metrics[f"{m}_d_mean_mm"] - d
            lines.append(f"{m}: d̄ = {metrics[f'{m}_d_mean_mm']:.2f} mm, {abs(diff):.2f} mm "
                         f"{'better' if diff < 0 else 'worse'} than the mesh filter; "
                         f"{metrics[f'{m}_detect_ms']:.3f} ms per tap to find the edges vs "
                         f"{metrics['mesh_detect_ms']:.3f} ms.")
    reasons = {m: [r.stop_reason for r in rs] for m, (rs, _) in runs_by_method.items()}
    err = (f"the robot's control frame and filters use taxel positions with a {p['position_error'] * 1e3:.1f} mm "
           f"RMS error ({p['position_error_model']} model; seed 002: ~1 mm on its curved patch)"
           if p["position_error"] > 0 else "the filters know the taxel positions exactly")
    lines += ["", "Run endings: " + "; ".join(f"{m}: {', '.join(v)}" for m, v in reasons.items()) + ".",
              f"Setup: {p['force']:.0f} N per tap through {layer.thickness * 1e3:g} mm of {layer.material} "
              f"(E = {layer.young_modulus / 1e3:.0f} kPa, the scene's [layer]), "
              f"step {p['step'] * 1e3:.0f} mm, {p['runs']} seeded starts shared by all methods; {err}.",
              "", f"Deviation from seed 002: the cover ({layer.thickness * 1e3:g} mm of {layer.material}) is "
              "this simulation's assumption, not the paper's, which does not describe the cover of its CySkin "
              "patches. The shipped contour scenes use 6 mm of Ecoflex 00-50 because a thinner, softer cover "
              "(3 mm of Ecoflex 00-20, the [layer] default) bottoms out before 15 N on a 1 mm edge. The cover "
              "matters: on the curved patch a thinner one makes the mesh filter settle outside the mug rim "
              "(docs/filters.md, sensitivity table)."]
    return "\n".join(lines)


def _path_figure(name, p, contour, runs_by_method):
    """Seed 002 Fig. 8: x_R at every tap over the contour, one panel per method."""
    plt = pyplot()
    k = len(runs_by_method)
    fig, axes = plt.subplots(1, k, figsize=(4.2 * k, 4.2), squeeze=False)
    for ax, (m, (runs, dists)) in zip(axes[0], runs_by_method.items()):
        if p["object"] == "mug":
            t = np.linspace(0, 2 * np.pi, 361)
            c = np.asarray(contour.centre) * 1e3
            for r in (contour.inner, contour.outer):
                ax.plot(c[0] + 1e3 * r * np.cos(t), c[1] + 1e3 * r * np.sin(t), "b-", lw=1)
            ax.plot(c[0] + 1e3 * contour.reference * np.cos(t), c[1] + 1e3 * contour.reference * np.sin(t),
                    "k--", lw=0.8)
            ax.set_aspect("equal")
        else:
            for s in (-1, 1):
                ax.axhline(1e3 * (contour.offset + s * contour.width / 2), color="b", lw=1)
            ax.axhline(1e3 * contour.offset, color="k", ls="--", lw=0.8)
        for i, r in enumerate(runs):
            x = r.x_ref * 1e3
            ax.plot(x[:, 0], x[:, 1], "-", color="0.7" if i else "0.4", lw=0.6, zorder=1)
            ax.plot(x[1:, 0], x[1:, 1], "o", color="r", ms=2.5 if i else 3.5, alpha=0.35 if i else 1.0, zorder=2)
            ax.plot(x[0, 0], x[0, 1], "o", color="b", ms=6, zorder=3)
        ax.set_title(f"{m}: d̄ {np.mean([d.mean() for d in dists if len(d)]) * 1e3 if any(len(d) for d in dists) else 0:.2f} mm")
        ax.set_xlabel("x (mm)")
        ax.set_ylabel("y (mm)")
        if p["object"] == "ruler":
            ax.set_ylim(-8, 8)
    fig.suptitle(f"{name}: x_R at each tap (red; blue = start; run 1 dark, runs 2-3 faint)")
    fig.tight_layout()
    return fig


def _edges_figure(layout, detectors, runs_by_method):
    """One tap of run 1: the pressure on the skin and the edges each method found."""
    plt = pyplot()
    k = len(runs_by_method)
    fig, axes = plt.subplots(1, k + 1, figsize=(4 * (k + 1), 3.8), squeeze=False)
    axes = axes[0]
    first_runs = runs_by_method[next(iter(runs_by_method))][0]
    frame = first_runs[0].pressure[min(2, len(first_runs[0]) - 1)] if len(first_runs[0]) else np.zeros(len(layout))
    xy = layout.positions[:, :2] * 1e3
    sc = axes[0].scatter(xy[:, 0], xy[:, 1], c=frame, s=30, cmap="Greys")
    fig.colorbar(sc, ax=axes[0], shrink=0.8)
    axes[0].set_title("sensor frame (control frame)")
    for ax, (m, det) in zip(axes[1:], detectors.items()):
        f = det.detect(frame)
        ax.scatter(xy[:, 0], xy[:, 1], c=frame, s=30, cmap="Greys")
        if f.found:
            ax.scatter(f.plane[:, 0] * 1e3, f.plane[:, 1] * 1e3, c=f.labels, s=6, cmap="tab10")
            c = f.centroid * 1e3
            d = 10 * np.array([np.cos(f.theta), np.sin(f.theta)])
            ax.plot([c[0] - d[0], c[0] + d[0]], [c[1] - d[1], c[1] + d[1]], "r-", lw=2)
            ax.plot(*c, "r+", ms=10)
        ax.plot(0, 0, "bx", ms=8)
        ax.set_title(f"{m}: {f.n_components} component(s)")
    for ax in axes:
        ax.set_aspect("equal")
        ax.set_xlabel("x (mm)")
    fig.tight_layout()
    return fig


register_task(TaskSpec("contour", run, PARAMS, sections=("layer",), effects=("soft_layer",) + SENSOR_EFFECTS,
                       doc="seed 002 tapping contour following with the mesh, image and sub-taxel edge filters"))
