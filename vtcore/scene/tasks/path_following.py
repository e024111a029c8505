"""Task ``path_following``: seed 000's Fig. 9, sliding on the empty bottle with the Eq. 5 set-point.

The bottle's augmented cloud is built as in the ``augment`` task (same seed,
same touches); the end-effector then slides 0.065 m down the body at 1.5 mm/s
while its force set-point follows the cloud's colour at the contact point, once
with the cluster-based and once with the smooth propagation, with the same
controller gains. Reported for both, beside the paper: the mean force-tracking
error, the path intervals where the module lost contact with the bottle's real
surface (its ring groove, or rib) and the error outside them, and the overshoots
of the noise-free response. The loop reads p̄ through the skin's measured noise.
"""

from __future__ import annotations

import numpy as np

from ...augment import ClusterPropagation, ProbeModel, SmoothPropagation, make_seed000_object, two_cameras
from ...augment.experiment import probe_object
from ...augment.objects import BOTTLE, bottle_radius_at
from ...augment.cloud import colour_map
from ...augment.experiment import voxel_filter
from ...augment.plots import view_coordinates
from ...control.path_following import (ForceController, check_steps, contact_response_table, follow_path,
                                       position_loop_problem)
from ...errors import InputError
from ...inputs import need_time
from ...plots import pyplot
from ..budget import CONTACT_FRAME_S
from ..registry import CONTACT_EFFECTS, SENSOR_EFFECTS, TaskSpec, register_task
from ..runner import TaskResult
from ..schema import Field, Section
from ..sections.layer import build_layer, layer_options
from .augment import PARAMS as AUGMENT
from .augment import PROBE_NOISE_KEYS, contact_prober, probe_noise

PARAMS = Section({
    "object": Field("str", default="empty_bottle", choices=("empty_bottle", "full_bottle")),
    "touches": Field("int", default=24, ge=1),
    "target_response": Field("float", default=4000.0, gt=0, doc="p̄* of the probes, counts"),
    "probe": Field("str", default="contact", choices=("contact", "series"),
                   doc="contact: touches probed and the sliding contact solved by the contact simulator "
                       "([layer], object_compliance, gain); series: the closed-form spring model"),
    "counts_per_pa": Field("float", default=2.0, gt=0, doc="sensor gain when [effects.gain] is not listed"),
    "readings": Field("int", default=10, ge=1),
    "stations": Field("int", default=27, ge=2, doc="contact solves along the path (contact plant), evenly spaced"),
    "ring_stations": Field("float", default=1e-3, ge=0, unit="m",
                           doc="extra stations this far apart where the module overlaps the bottle's ring "
                               "(0: none), so that the plant resolves a groove or rib it can lose"),
    "groove_depth": Field("float", default=None, unit="m",
                          doc="depth of the bottle's ring (negative: a rib); default the object's (1.2 mm)"),
    "groove_width": Field("float", default=None, gt=0, unit="m",
                          doc="full width of the bottle's ring; default the object's (4 mm)"),
    "counts_per_newton": Field("float", default=2000.0, gt=0),
    "layer_stiffness": Field("float", default=5000.0, gt=0, unit="N/m"),
    "points": Field("int", default=33676, ge=1),
    "beta": Field("float", default=-300.0, le=0, unit="1/m"),
    "p_max": Field("float", default=2000.0, gt=0, doc="p̄*_max of Eq. 5, counts (paper: 2000)"),
    "c_max_from": Field("str", default="path", choices=("path", "cloud"),
                        doc="c_max of Eq. 5: the stiffest colour along the path, or in the whole cloud"),
    "speed": Field("float", default=1.5e-3, gt=0, unit="m/s", doc="sliding speed (paper: 1.5 mm/s)"),
    "length": Field("float", default=0.065, gt=0, unit="m", doc="path length (paper: 0.065 m)"),
    "start_height": Field("float", default=0.123, gt=0, unit="m",
                          doc="height of the path's start on the bottle (near the shoulder)"),
    "azimuth": Field("float", default=0.0, unit="deg", doc="side of the bottle the path runs on"),
    "ki": Field("float", default=4e-6, gt=0, doc="integral gain, m/(count s)"),
    "omega": Field("float", default=25.0, gt=0, unit="rad/s", doc="robot position loop bandwidth"),
    "zeta": Field("float", default=0.6, gt=0, doc="robot position loop damping"),
    "noise": Field("float", default=None, ge=0,
                   doc="counts, read noise of one taxel in the loop (added per taxel, clipped at 0, with the "
                       "contact plant; divided by sqrt(10) on the mean with the series plant); default the "
                       "scene's [effects.noise] sigma, else none"),
    "overshoot_threshold": Field("float", default=100.0, ge=0,
                                 doc="counts: an excursion larger than this that crosses the set-point counts its "
                                     "excursion past it as an overshoot"),
    "dt": Field("float", default=2e-3, gt=0, unit="s"),
    "setpoint_period": Field("float", default=1e-2, gt=0, unit="s", doc="on-the-fly query period"),
    "c_min": Field("float", default=0.0),
    "c_max": Field("float", default=2.0e7, gt=0, doc="shared colour scale of the pictures, counts/m"),
    **{k: AUGMENT.fields[k] for k in PROBE_NOISE_KEYS},
})


def _check_loop(scene, p) -> None:
    """The path's step count and the position loop's stability, checked before any probing."""
    # before the probing: the speed is to blame if the path is too long even at the default control period
    slowest = max(p["dt"], PARAMS.fields["dt"].default)
    check_steps(p["length"], p["speed"], slowest, key="task.speed", file=scene.path,
                remedy="raise task.speed or shorten task.length")
    check_steps(p["length"], p["speed"], p["dt"], key="task.dt", file=scene.path, remedy="raise task.dt")
    unstable = position_loop_problem(p["omega"], p["zeta"], p["dt"])
    if unstable:
        raise scene.error("task.omega", unstable.replace("omega, zeta or dt", "task.omega, task.zeta or task.dt"))


def _path_line(scene, p):
    """The planned straight path down the bottle's side: (start (3,) m, end (3,) m, outward radial (3,))."""
    z0, z1 = p["start_height"], p["start_height"] - p["length"]
    if z1 < 0 or z0 > BOTTLE["body_top"] + 0.02:
        raise scene.error("task.start_height", f"the path from z={z0} m down {p['length']} m must stay on the "
                          f"bottle's side wall (0 .. {BOTTLE['body_top'] + 0.02:.3f} m)")
    az = np.radians(p["azimuth"])
    radial = np.array([np.cos(az), np.sin(az), 0.0])
    r_line = BOTTLE["radius"]
    return r_line * radial + [0, 0, z0], r_line * radial + [0, 0, z1], radial


def _response_table(scene, ctx, p, obj, prober, start, end, radial):
    """With the contact probe, the skin's response along the path from the contact solve
    (``contact_response_table``); None with the series probe."""
    if prober is None:
        return None
    comp = ctx.pipeline.get("object_compliance")
    stiff = (lambda r: comp.stiffness(obj.stiffness, obj.mesh, r)) if comp is not None else None
    opts = layer_options(scene)
    return contact_response_table(obj.mesh, start, end, radial, build_layer(scene), stiffness=stiff,
                                  counts=prober.sensor or (lambda pr: prober.counts_per_pa * pr),
                                  stations=stations(p, p["start_height"], prober.layout),
                                  spread=ctx.pipeline.has("soft_layer"), **opts)


def _path_metrics(p, obj, runs, sigma, prober, probed) -> dict:
    """The loop's noise, the groove, each propagation's run metrics and the probing's bookkeeping."""
    z0 = p["start_height"]
    metrics = {"loop_noise_taxel_counts": float(sigma), "loop_noise_mean_counts": float(sigma / np.sqrt(10.0)),
               "groove_depth_mm": 1e3 * obj.meta.get("groove_depth", BOTTLE["groove_depth"]),
               "groove_width_mm": 1e3 * obj.meta.get("groove_width", BOTTLE["groove_width"]),
               "groove_at_mm": 1e3 * (z0 - BOTTLE["groove_z"])}
    for name, r in runs.items():
        metrics.update({f"{name}_{k}": val for k, val in run_metrics(r, p).items()})
    metrics["duration_s"] = float(runs["cluster"].time[-1])
    if prober is not None:
        metrics["probes_unreachable"] = len(prober.failures)
    metrics["probes_repeated"] = probed.meta["probes_repeated"]
    metrics["probes_rejected"] = probed.meta["probes_rejected"]
    metrics["path_length_m"] = p["length"]
    return metrics


def _path_arrays(runs) -> dict:
    """Time (T,) s and path position (T,) m, then per propagation its set-point, responses, colour and
    contact-loss intervals."""
    arrays = {"timestamps": runs["cluster"].time, "path_s": runs["cluster"].s}
    for name, r in runs.items():
        arrays[f"{name}_setpoint"] = r.setpoint
        arrays[f"{name}_response"] = r.response
        arrays[f"{name}_response_true"] = r.response_true
        arrays[f"{name}_response_expected"] = r.response_expected
        arrays[f"{name}_colour"] = r.colour
        arrays[f"{name}_contact_loss_intervals"] = np.asarray(r.contact_loss_intervals(), float).reshape(-1, 2)
    return arrays


def run(scene, ctx) -> TaskResult:
    p = scene["task"]
    _check_loop(scene, p)
    groove = {k: p[k] for k in ("groove_depth", "groove_width") if p[k] is not None}
    try:
        obj = make_seed000_object(p["object"], **groove)
    except InputError as exc:
        raise scene.error("task.groove_depth", exc.reason) from None
    probe = ProbeModel(target=p["target_response"], counts_per_newton=p["counts_per_newton"],
                       layer_stiffness=p["layer_stiffness"], position_noise=0.0)   # the robot's errors: ProbeNoise
    lo, hi = np.asarray(obj.mesh.bounds)
    prober = contact_prober(scene, ctx, obj) if p["probe"] == "contact" else None
    probed = probe_object(obj, p["touches"], probe, cameras=two_cameras(target=tuple((lo + hi) / 2),
                                                                          depth_noise=3e-4),
                          n_points=p["points"], rng=ctx.child_rng("augment"), probe_fn=prober,
                          noise=probe_noise(scene, ctx)[0])
    v, c = probed.tactile.points, probed.tactile.values
    start, end, radial = _path_line(scene, p)
    sigma, noise_source = loop_noise(scene, ctx, p)

    def plant_c(x):
        return probe.true_c(obj.stiffness(x))

    def gap(x):                                  # the real surface below the straight planned path
        return np.clip(BOTTLE["radius"] - bottle_radius_at(x[:, 2], **groove), 0.0, None)

    table = _response_table(scene, ctx, p, obj, prober, start, end, radial)
    # per taxel with the contact table (clipped at 0 like the real read-out); on the mean otherwise
    per_taxel = table is not None
    ctl = ForceController(ki=p["ki"], omega=p["omega"], zeta=p["zeta"], dt=p["dt"],
                          noise=sigma if per_taxel else sigma / np.sqrt(10.0), setpoint_period=p["setpoint_period"])
    runs, preds = {}, {}
    for name, est in (("cluster", ClusterPropagation()), ("smooth", SmoothPropagation(beta=p["beta"]))):
        est.fit(v, c)
        preds[name] = est.predict(probed.points)
        path_pts = start + np.linspace(0, 1, 200)[:, None] * (end - start)
        c_max = float(preds[name].max() if p["c_max_from"] == "cloud" else est.predict(path_pts).max())
        plant = {"response": table} if table is not None else {"plant_c": plant_c, "gap": gap}
        runs[name] = follow_path(start, end, est.predict, speed=p["speed"], p_max=p["p_max"], c_max=c_max,
                                 controller=ctl, rng=ctx.child_rng(f"path_{name}"), **plant)
    metrics = _path_metrics(p, obj, runs, sigma, prober, probed)
    fig = _figure(runs, probed, preds, start, end, radial, p)
    return TaskResult(metrics=metrics, arrays=_path_arrays(runs), figures={"fig9_path_following": fig},
                      sections=[_table(runs, metrics, p, noise_source)])


def loop_noise(scene, ctx, p) -> tuple[float, str]:
    """Per-taxel read noise (counts) of the loop and where it comes from: ``task.noise``, else the
    listed ``[effects.noise]``, else none (no effect the scene does not list; docs/inputs.md)."""
    if p["noise"] is not None:
        return float(p["noise"]), "task.noise"
    listed = ctx.pipeline.get("noise")
    if listed is not None:
        ctx.pipeline.add_time("noise", 0.0)  # read by the loop (its time is the loop's)
        return float(listed.sigma), "the scene's [effects.noise]"
    return 0.0, "none (no task.noise, no [effects.noise])"


def stations(p, z0, layout) -> np.ndarray:
    """Arc lengths (m) of the contact solves: ``p["stations"]`` evenly, plus ``ring_stations``-spaced
    ones wherever the module (its largest extent from the centre, plus the ring's width) overlaps
    the bottle's ring, so that the table sees the module bridge it or drop into it. Each is a contact
    solve: their number is held to the time budget first (a ring_stations of 1e-320 is unbounded)."""
    need_time(p["stations"], CONTACT_FRAME_S, key="task.stations", what=f"{p['stations']} contact solves")
    even = np.linspace(0.0, p["length"], p["stations"])
    if not p["ring_stations"] > 0:
        return even
    reach_m = float(np.linalg.norm(layout.positions[:, :2], axis=1).max()) + 0.003
    width = p["groove_width"] or BOTTLE["groove_width"]
    s_ring = z0 - BOTTLE["groove_z"]
    lo, hi = max(s_ring - reach_m - width, 0.0), min(s_ring + reach_m + width, p["length"])
    if hi <= lo:
        return even
    n_ring = (hi - lo) / p["ring_stations"]
    need_time(p["stations"] + n_ring, CONTACT_FRAME_S, key="task.ring_stations",
              what=f"{p['stations']} + {n_ring:.3g} contact solves (every {p['ring_stations']:g} m across the ring)")
    dense = np.arange(lo, hi + 1e-12, p["ring_stations"])
    s = np.unique(np.round(np.concatenate([even, dense]), 9))
    return s[np.concatenate([[True], np.diff(s) > 1e-6])]


def run_metrics(r, p) -> dict:
    """One run's numbers: tracking error (all, and outside the contact-loss intervals), contact loss,
    overshoots of the noise-free response, the set-point's steps."""
    losses = r.contact_loss_intervals()
    shoots = r.overshoots(p["overshoot_threshold"])
    return {"tracking_error": r.tracking_error(), "tracking_error_in_contact": r.tracking_error(True),
            "peak_error": r.peak_error(), "setpoint_max_jump": r.setpoint_max_jump(),
            "setpoint_steps": int(np.sum(np.abs(np.diff(r.setpoint)) > 0.02 * p["p_max"])),
            "contact_lost_mm": 1e3 * r.contact_lost_length(), "contact_losses": len(losses),
            "contact_loss_first_mm": 1e3 * losses[0][0] if losses else float("nan"),
            "overshoot_max_counts": max((o[1] for o in shoots), default=0.0), "overshoots": len(shoots),
            "overshoot_first_mm": 1e3 * shoots[0][0] if shoots else float("nan")}


def _table(runs, m, p, noise_source) -> str:
    lines = ["## Force tracking (Fig. 9)", "",
             f"Loop read noise {m['loop_noise_taxel_counts']:.0f} counts per taxel ({noise_source}), "
             f"{m['loop_noise_mean_counts']:.0f} on a 10-taxel mean. The bottle's ring: depth "
             f"{m['groove_depth_mm']:.2f} mm (negative: a rib), width {m['groove_width_mm']:.1f} mm, "
             f"{m['groove_at_mm']:.1f} mm along the path.", "",
             "| propagation | mean abs error (counts) | error outside contact loss | contact lost (mm of path) | "
             "loss intervals (mm) | largest overshoot (counts) | overshoots | largest set-point step |",
             "|---|---|---|---|---|---|---|---|"]
    for name, r in runs.items():
        iv = ", ".join(f"{1e3 * a:.1f}-{1e3 * b:.1f}" for a, b in r.contact_loss_intervals()) or "none"
        lines.append(f"| {name} | {m[name + '_tracking_error']:.1f} | {m[name + '_tracking_error_in_contact']:.1f} | "
                     f"{m[name + '_contact_lost_mm']:.2f} | {iv} | {m[name + '_overshoot_max_counts']:.0f} | "
                     f"{m[name + '_overshoots']} | {m[name + '_setpoint_max_jump']:.0f} |")
    lines += ["", "Paper (real robot, one trial each): cluster-based 52.92, smooth 120.86 counts of mean error; "
                  "smooth with smaller overshoots; the smooth run's only overshoot, at 0.025 m, follows a loss of "
                  "contact \"because of its shape at that point\"."]
    return "\n".join(lines)


def _figure(runs, probed, preds, start, end, radial, p):
    plt = pyplot()
    fig, axes = plt.subplots(2, 2, figsize=(10, 6.5), gridspec_kw={"width_ratios": [1, 2.4]})
    for row, name in enumerate(("cluster", "smooth")):
        r = runs[name]
        ax = axes[row][0]
        keep = voxel_filter(probed.points, 0.003)
        xy, depth = view_coordinates(probed.points[keep], radial)
        o = np.argsort(depth)
        ax.scatter(xy[o, 0] * 1e3, xy[o, 1] * 1e3, c=colour_map(preds[name][keep][o], p["c_min"], p["c_max"]) / 255,
                   s=2, linewidths=0)
        pxy, _ = view_coordinates(np.array([start, end]), radial)
        ax.plot(pxy[:, 0] * 1e3, pxy[:, 1] * 1e3, "-", color="tab:red", lw=1.5)
        ax.set_aspect("equal")
        ax.set_title(f"{name}: path on the augmented cloud", fontsize=9)
        ax.set_xlabel("mm")
        ax = axes[row][1]
        ax.plot(r.s, r.response, color="tab:blue", lw=0.4, label="p̄ (measured)")
        ax.plot(r.s, r.response_true, color="tab:orange", lw=0.8, label="p̄ (noise-free)")
        ax.plot(r.s, r.setpoint, color="k", lw=1.5, label="p̄* (desired, Eq. 5)")
        for k, (a, b) in enumerate(r.contact_loss_intervals()):
            ax.axvspan(a, max(b, a + 2e-4), color="tab:red", alpha=0.25, label="contact lost" if k == 0 else None)
        ax.set_ylabel("counts")
        ax.set_title(f"{name}: tracking error {r.tracking_error():.1f} counts, contact lost "
                     f"{1e3 * r.contact_lost_length():.2f} mm", fontsize=9)
        ax.legend(fontsize=7, loc="upper right")
    axes[1][1].set_xlabel("path length (m)")
    fig.tight_layout()
    return fig


register_task(TaskSpec("path_following", run, PARAMS, effects=CONTACT_EFFECTS + SENSOR_EFFECTS,
                       doc="seed 000 Fig. 9: path following with the Eq. 5 force set-point"))
