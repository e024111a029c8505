"""Task ``augment``: seed 000's augmented point cloud of one object.

See the object with one or two virtual depth cameras (or read a PLY/PCD),
probe it at ``touches`` points sampled from the cloud (force control to p̄*,
Eq. 1), propagate the tactile colours with the cluster-based (Eq. 2) and the
smooth (Eqs. 3-4) methods (and optionally the GP baseline), compare each with
the dense ground truth, write the augmented PLYs and a Fig.-7-style picture.
"""

from __future__ import annotations

import numpy as np

from ..._bench import best_time

from ...augment import (ClusterPropagation, GPPropagation, ProbeModel, SmoothPropagation, colour_map, compliance,
                        load_probes, make_seed000_object, read_point_cloud, two_cameras, write_ply)
from ...augment.experiment import probe_object
from ...augment.objects import OBJECTS
from ...augment.plots import augmented_panels, touch_sequence
from ..registry import CONTACT_EFFECTS, SENSOR_EFFECTS, TaskSpec, register_task
from ..runner import TaskResult
from ..schema import Field, Section

PARAMS = Section({
    "object": Field("str", default="empty_bottle", choices=OBJECTS, doc="one of seed 000's six objects"),
    "stiffness_scale": Field("float", default=1.0, gt=0, doc="multiplies the object's stiffness field"),
    "touches": Field("int", default=24, ge=1, doc="probes (paper: 24 on the bottles, 17 on the others)"),
    "target_response": Field("float", default=4000.0, gt=0, doc="p̄* of the probe, counts (paper: 4000)"),
    "probe": Field("str", default="contact", choices=("contact", "series"),
                   doc="contact: the contact simulator's force control on one CySkin module through [layer], "
                       "object compliance from [effects.object_compliance]; series: the closed-form "
                       "spring model (object in series with layer_stiffness), fast, with a dense ground truth"),
    "counts_per_pa": Field("float", default=2.0, gt=0,
                           doc="sensor gain of the contact probe when [effects.gain] is not listed"),
    "readings": Field("int", default=10, ge=1, doc="steady-state readings averaged into p̄ (contact probe)"),
    "validation_probes": Field("int", default=24, ge=1,
                               doc="held-out probes that score the propagations (contact probe)"),
    "counts_per_newton": Field("float", default=2000.0, gt=0, doc="series probe: mean response per newton"),
    "layer_stiffness": Field("float", default=5000.0, gt=0, unit="N/m",
                             doc="series probe: soft layer under the probe, in series with the object"),
    "response_noise": Field("float", default=5.0, ge=0, doc="series probe: counts, std of the averaged p̄"),
    "probe_noise": Field("bool", default=True,
                         doc="with [effects.noise] listed, measure each touch's displacement as a robot does: "
                             "position noise and late contact detection (vtcore.augment.probe_noise); a "
                             "non-physical touch is repeated, then rejected and replaced, and counted"),
    "position_noise": Field("float", default=5e-5, ge=0, unit="m",
                            doc="std of each measured robot position (assumption: the order of a Franka "
                                "Panda's 0.1 mm pose repeatability)"),
    "approach_speed": Field("float", default=2e-3, gt=0, unit="m/s",
                            doc="approach before contact; with the skin's 20 Hz frames it sets how late "
                                "contact is detected (assumption)"),
    "detect_k": Field("float", default=5.0, ge=0,
                      doc="contact is detected when p̄ exceeds this many noise deviations of the module's "
                          "10-taxel mean"),
    "probe_retries": Field("int", default=2, ge=0, doc="repeats of a touch whose displacement is non-physical"),
    "cameras": Field("int", default=2, ge=1, le=2, doc="virtual D415s (the paper merges two)"),
    "depth_noise": Field("float", default=3e-4, ge=0, unit="m", doc="depth noise of the cameras"),
    "points": Field("int", default=33676, ge=1, doc="at most this many visual points (paper's bottle: 33,676)"),
    "cloud": Field("path", default="", doc="optional PLY/PCD visual cloud instead of the cameras (metres)"),
    "probes": Field("path", default="", doc="optional recorded probes (CSV/NPZ) instead of simulating"),
    "beta": Field("float", default=-300.0, le=0, unit="1/m", doc="smooth propagation steepness (paper: -300)"),
    "k_nearest": Field("int", default=0, ge=0, doc="truncate the smooth softmax to k contacts (0: all)"),
    "gp": Field("bool", default=False, doc="also run the GP baseline of the appendix"),
    "gp_radius": Field("float", default=0.03, gt=0, unit="m", doc="GP neighbourhood augmentation radius"),
    "gp_voxel": Field("float", default=0.004, gt=0, unit="m", doc="GP training voxel"),
    "c_min": Field("float", default=0.0, doc="shared colour scale, counts/m"),
    "c_max": Field("float", default=1.0e7, gt=0, doc="shared colour scale, counts/m (the stiffest colour)"),
    "cmap": Field("str", default="viridis_r", doc="matplotlib colormap, dark = stiff"),
    "channels": Field("list", default=["compliance"], item=Field("str", choices=("compliance", "friction")),
                      doc="tactile colour channels; compliance first"),
    "ply": Field("bool", default=True, doc="write augmented_{cluster,smooth}.ply"),
})


def contact_prober(scene, ctx, obj):
    """The contact simulator's probe, wired to the scene's [layer] and its listed effects.

    ``object_compliance`` (if listed) gives the object's stiffness at each contact;
    ``gain`` (if listed) is the transfer the force control inverts; the whole
    sensor stage (noise, quantisation, ...) reads the steady state; ``soft_layer``
    decides whether stress spreads through the layer.
    """
    from ...augment.probing import ContactProber
    from ..budget import check_run_sizes
    from ..sections.layer import build_layer, layer_options

    comp = ctx.pipeline.get("object_compliance")          # unlisted: a rigid object, no deflection
    gain = ctx.pipeline.get("gain")
    sensor = ctx.pipeline.stage("sensor")
    opts = layer_options(scene)
    model = opts.pop("model", "finite_layer")
    prober = ContactProber(obj, build_layer(scene), target=scene["task"]["target_response"],
                           counts_per_pa=scene["task"]["counts_per_pa"],
                           sensor=gain.counts if gain is not None else None,
                           stiffness=comp.stiffness if comp is not None else None,
                           readout=(lambda f: ctx.pipeline.apply("sensor", f, ctx)) if sensor else None,
                           readings=scene["task"]["readings"], spread=ctx.pipeline.has("soft_layer"), model=model,
                           press_kw=opts)
    check_run_sizes(scene, len(prober.layout))   # task.readings copies of each probe's pressure go through the sensor
    return prober


#: the probe-noise keys every seed-000 task that probes shares (same meaning, same defaults)
PROBE_NOISE_KEYS = ("probe_noise", "position_noise", "approach_speed", "detect_k", "probe_retries")


def probe_noise(scene, ctx):
    """The :class:`~vtcore.augment.probe_noise.ProbeNoise` of the scene's probes, or None.

    The detection threshold uses the per-taxel noise of the scene's listed ``noise`` effect (the
    one p̄ is read through). Without ``[effects.noise]`` the probes are noise-free: the effect
    contract (docs/inputs.md) computes no effect a scene does not list, so the measured CySkin
    noise is ``[effects.noise] profile = "cyskin"``, not a fallback. Returns ``(noise, sigma, source)``
    (``noise`` None when no probe noise is simulated; ``sigma`` 0 without [effects.noise]).
    """
    from ...augment.probe_noise import ProbeNoise, SkinNoise

    p = scene["task"]
    listed = ctx.pipeline.get("noise")
    if listed is None:
        return None, 0.0, "none: the scene lists no [effects.noise]"
    skin = SkinNoise(float(listed.sigma), p["detect_k"], "the scene's [effects.noise]")
    if not p["probe_noise"]:
        return None, skin.sigma, skin.source
    ctx.pipeline.add_time("noise", 0.0)  # the probes' noise is the listed effect's (timed inside the probes)
    noise = ProbeNoise.from_skin(skin, position_sigma=p["position_noise"], approach_speed=p["approach_speed"],
                                 retries=p["probe_retries"])
    noise.min_displacement = max(noise.expected(probe_floor(scene, ctx), p["target_response"]), 0.0)
    return noise, skin.sigma, skin.source


def probe_floor(scene, ctx) -> float:
    """The smallest physical displacement of the scene's probe (m): its skin layer alone, pressed to the
    target on a rigid flat plate (one contact solve; the series probe's ``F / layer_stiffness``)."""
    from ...augment.probe_noise import rigid_floor, rigid_plate

    p = scene["task"]
    if p["probe"] == "series":
        d = ProbeModel()                                  # tasks without the series keys use its defaults
        cpn = p["counts_per_newton"] if "counts_per_newton" in p else d.counts_per_newton
        k_layer = p["layer_stiffness"] if "layer_stiffness" in p else d.layer_stiffness
        return p["target_response"] / cpn / k_layer
    return rigid_floor(contact_prober(scene, ctx, rigid_plate()))


def probe_model(p):
    """The closed-form series probe of a task's parameters (position noise lives in ProbeNoise)."""
    return ProbeModel(target=p["target_response"], counts_per_newton=p["counts_per_newton"],
                      layer_stiffness=p["layer_stiffness"], response_noise=p["response_noise"], position_noise=0.0)


def _visual_cloud(scene, p):
    """The recorded visual cloud of ``task.cloud`` as (points (P, 3) m, normals (P, 3)), or None to
    simulate the cameras."""
    if not p["cloud"]:
        return None
    pts, nrm = read_point_cloud(p["cloud"])
    if len(pts) == 0:
        raise scene.error("task.cloud", "the visual point cloud is empty")
    if nrm is None:
        raise scene.error("task.cloud", "the cloud has fewer than 3 points: cannot estimate normals")
    return pts, nrm


def _ground_truth(ctx, p, prober, probed, x):
    """What the propagation is scored against: (points (Q, 3) m, Eq. 1 values (Q,), a label)."""
    if prober is None:
        # the series model's noise-free Eq. 1 is known at every visual point: a dense ground truth
        return x, probed.truth, "dense ground truth"
    # no closed form with the contact solve: score on held-out probes at other cloud points
    free = np.setdiff1d(np.arange(len(x)), probed.touch_index)
    held = np.sort(ctx.child_rng("validation").choice(free, min(p["validation_probes"], len(free)),
                                                      replace=False))
    pm, vss = prober(x[held], probed.normals[held])
    ok = np.isfinite(pm)                     # unreachable held-out probes score nothing
    held, pm, vss = held[ok], pm[ok], vss[ok]
    return x[held], compliance(pm, vss, x[held], direction=-probed.normals[held]), f"{len(held)} held-out probes"


def _propagate(scene, p, x, v, c, truth_points, truth):
    """Every propagation method fitted on the touches (v (T, 3) m, c (T,) or (T, C)) and predicted at the
    cloud x (P, 3): ({method: (P,) or (P, C)}, metrics: time and error against the truth)."""
    k = p["k_nearest"] or None
    methods = {"cluster": ClusterPropagation(), "smooth": SmoothPropagation(beta=p["beta"], k_nearest=k)}
    if p["gp"]:
        methods["gp"] = GPPropagation(radius=p["gp_radius"], voxel=p["gp_voxel"], random_state=scene.seed)
    preds, metrics = {}, {}
    for name, est in methods.items():
        if name == "gp":
            t_fit, _ = best_time(lambda: est.fit(v, c, visual_points=x), repeat=1)
        else:
            t_fit, _ = best_time(lambda: est.fit(v, c))
        t_pred, y = best_time(lambda: est.predict(x), repeat=1 if name == "gp" else 3)
        preds[name] = y
        yt = y if truth_points is x else est.predict(truth_points)
        comp = yt if yt.ndim == 1 else yt[:, 0]
        metrics[f"{name}_ms"] = (t_fit + t_pred) * 1e3
        metrics[f"{name}_mae"] = float(np.mean(np.abs(comp - truth)))
        metrics[f"{name}_error_rel_pct"] = 100.0 * metrics[f"{name}_mae"] / float(np.mean(truth))
    return preds, metrics


def _write_plys(ctx, p, x, normals, preds, n_touches) -> list[str]:
    """The augmented clouds of the cluster and smooth propagations as PLY files; their names."""
    files = []
    rgb = {n: colour_map(y if y.ndim == 1 else y[:, 0], p["c_min"], p["c_max"], p["cmap"]) for n, y in preds.items()}
    for name in ("cluster", "smooth"):
        y = preds[name]
        scalars = {"tactile_color": y if y.ndim == 1 else y[:, 0]}
        for j, ch in enumerate(p["channels"][1:], start=1):
            scalars[ch] = y[:, j]
        write_ply(ctx.out / f"augmented_{name}.ply", x, normals=normals, rgb=rgb[name], scalars=scalars,
                  comment=f"vtcore augmented point cloud, {p['object']}, {name} propagation, "
                          f"{n_touches} touches\ncolour scale c_min={p['c_min']:g} c_max={p['c_max']:g} "
                          f"counts/m, {p['cmap']}")
        files.append(f"augmented_{name}.ply")
    return files


def _figures(p, x, v, c, preds, truth_points, truth) -> dict:
    """Fig. 7 (the augmented clouds side by side) and Fig. 2 (touch by touch)."""
    panels = {"smooth": preds["smooth"], "cluster-based": preds["cluster"]}
    if "gp" in preds:
        panels["GP"] = preds["gp"]
    panels = {k2: (y if y.ndim == 1 else y[:, 0]) for k2, y in panels.items()}
    if truth_points is x:
        panels["ground truth"] = truth
    fig = augmented_panels(x, panels, v, c_min=p["c_min"], c_max=p["c_max"], cmap=p["cmap"],
                           title=f"{p['object']}: {len(v)} touches (red), dark = stiff")
    figures = {"fig7_augmented": fig}
    c_scalar = c if c.ndim == 1 else c[:, 0]
    figures["fig2_touches"] = touch_sequence(x, v, c_scalar, beta=p["beta"], c_min=p["c_min"], c_max=p["c_max"],
                                             cmap=p["cmap"], title=f"{p['object']}: touch by touch (Fig. 2)")
    return figures


def run(scene, ctx) -> TaskResult:
    p = scene["task"]
    if p["channels"][:1] != ["compliance"]:
        raise scene.error("task.channels", "must start with \"compliance\"")
    if p["c_max"] <= p["c_min"]:
        raise scene.error("task.c_max", f"must be > c_min ({p['c_min']}), got {p['c_max']}")
    obj = make_seed000_object(p["object"], p["stiffness_scale"])
    probe = probe_model(p)
    noise, _, _ = probe_noise(scene, ctx)
    lo, hi = np.asarray(obj.mesh.bounds)
    cams = two_cameras(target=tuple((lo + hi) / 2), depth_noise=p["depth_noise"])[:p["cameras"]]
    rng = ctx.child_rng("augment")
    cloud = _visual_cloud(scene, p)
    prober = contact_prober(scene, ctx, obj) if p["probe"] == "contact" else None
    # with recorded probes nothing is simulated but the cloud (one closed-form probe keeps the bookkeeping)
    recorded = bool(p["probes"])
    probed = probe_object(obj, 1 if recorded else p["touches"], probe, cameras=cams, n_points=p["points"], rng=rng,
                          channels=tuple(p["channels"]), probe_fn=None if recorded else prober,
                          cloud=cloud, noise=noise)
    tactile = load_probes(p["probes"]) if p["probes"] else probed.tactile
    x, v, c = probed.points, tactile.points, tactile.values
    truth_points, truth, truth_kind = _ground_truth(ctx, p, prober, probed, x)
    preds, metrics = _propagate(scene, p, x, v, c, truth_points, truth)

    c0 = c if c.ndim == 1 else c[:, 0]
    metrics = {
        "c_mean": float(np.mean(c0)),
        "c_min": float(np.min(c0)),
        "c_max": float(np.max(c0)),
        "c_true_mean": float(np.mean(truth)),
        **({"probe_force_mean_n": float(np.mean([r.force for r in prober.results])),
            "probes_unreachable": len(prober.failures)} if prober else {}),
        "probes_repeated": probed.meta["probes_repeated"],
        "probes_rejected": probed.meta["probes_rejected"],
        "touches": len(v),
        "points": len(x),
        "displacement_mean_mm": float(np.mean(tactile.displacement)) * 1e3
        if tactile.displacement is not None else float("nan"),
        **metrics,
    }
    files = _write_plys(ctx, p, x, probed.normals, preds, len(v)) if p["ply"] else []
    figures = _figures(p, x, v, c, preds, truth_points, truth)
    arrays = {"cloud_points": x, "cloud_normals": probed.normals, "contact_points": v, "contact_values": c,
              "truth_points": truth_points, "c_true": truth, **{f"c_{n}": y for n, y in preds.items()}}
    table = [f"## Propagation vs {truth_kind}", "",
             "| method | time (ms) | mean abs error (counts/m) | relative error (%) |", "|---|---|---|---|"]
    for name in preds:
        table.append(f"| {name} | {metrics[name + '_ms']:.2f} | {metrics[name + '_mae']:.4g} | "
                     f"{metrics[name + '_error_rel_pct']:.1f} |")
    return TaskResult(metrics=metrics, arrays=arrays, figures=figures, sections=["\n".join(table)],
                      files=files)


register_task(TaskSpec("augment", run, PARAMS, effects=CONTACT_EFFECTS + SENSOR_EFFECTS,
                       doc="seed 000: probe an object, propagate tactile colours"))
