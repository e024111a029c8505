"""Task ``reach``: seed 000's reaching in clutter (Sect. 4.3, Eqs. 6-7, Fig. 10).

A stiff metal pole and a soft sponge prism stand between A and B, too close
together for the skin-covered link to pass between them untouched. Each is
seen by the virtual cameras and probed; the colours of their augmented clouds
in the task plane set the Eq. 6 radii and Eq. 7 deviations. The augmented run
is compared, as in the paper, with the reactive controller of its reference [39]
(our model: :mod:`vtcore.control.reach`) and with a joint impedance controller of
very low gains, on the same robot and skin: the mean contact intensity in skin
counts (the paper's measure), contact with the pole, time to target, path.
"""

from __future__ import annotations

import numpy as np

from ...augment import ClusterPropagation, CompliantObject, ProbeModel, SmoothPropagation, colour_map
from ...augment.experiment import probe_object
from ...control.link_skin import SIZE_M as LINK_M
from ...control.link_skin import LinkSkin
from ...control.reach import CONTROLLERS, Obstacle, check_steps, influence_radii, reach
from ...layout.io import MAX_COORDINATE_M
from ...plots import pyplot
from ..registry import CONTACT_EFFECTS, SENSOR_EFFECTS, TaskSpec, register_task
from ..runner import TaskResult
from ..schema import Field, Section
from ..sections.layer import build_layer
from .augment import PARAMS as AUGMENT
from .augment import PROBE_NOISE_KEYS, contact_prober, probe_noise

#: seed 000, Sect. 5.3: contact intensity above the augmented run's, and the augmented run's slowdown
PAPER = {"reactive_intensity_excess_pct": 55.8, "impedance_intensity_excess_pct": 33.5, "augmented_slower_pct": 40.0}

#: m: positions and sizes of the task plane within a kilometre, as layout coordinates (a goal of 1e308
#: made the controllers' paths NaN)
KM = MAX_COORDINATE_M

PARAMS = Section({
    "start": Field("vec", default=[0.0, 0.0], length=2, ge=-KM, le=KM, unit="m", doc="A, in the task plane"),
    "goal": Field("vec", default=[0.4, 0.0], length=2, ge=-KM, le=KM, unit="m", doc="B"),
    "plane_height": Field("float", default=0.15, gt=0, le=KM, unit="m", doc="height of the task plane"),
    "pole_centre": Field("vec", default=[0.2, 0.03], length=2, ge=-KM, le=KM, unit="m"),
    "pole_radius": Field("float", default=0.012, gt=0, le=KM, unit="m"),
    "pole_stiffness": Field("float", default=2e5, gt=0, unit="N/m", doc="metal pole (fixed)"),
    "prism_centre": Field("vec", default=[0.2, -0.05], length=2, ge=-KM, le=KM, unit="m"),
    "prism_half_size": Field("vec", default=[0.03, 0.03], length=2, gt=0, le=KM, unit="m"),
    "prism_stiffness": Field("float", default=300.0, gt=0, unit="N/m", doc="sponge"),
    "height": Field("float", default=0.3, gt=0, le=KM, unit="m", doc="height of both obstacles"),
    "touches": Field("int", default=8, ge=1, doc="probes per obstacle"),
    "probe": Field("str", default="contact", choices=("contact", "series"),
                   doc="contact: the contact simulator's probe ([layer], object_compliance, gain); "
                       "series: the closed-form spring model"),
    "target_response": Field("float", default=4000.0, gt=0, doc="p̄* of the probes, counts"),
    "counts_per_pa": Field("float", default=2.0, gt=0, doc="sensor gain when [effects.gain] is not listed"),
    "readings": Field("int", default=10, ge=1),
    "propagation": Field("str", default="cluster", choices=("cluster", "smooth"),
                         doc="the paper notes both give the same uniform colours here"),
    "r_max": Field("float", default=0.07, gt=0, le=KM, unit="m", doc="Eq. 6 (paper: 0.07 m)"),
    "speed": Field("float", default=0.02, gt=0, unit="m/s", doc="nominal speed; no controller exceeds it"),
    "deviation_speed": Field("float", default=0.02, gt=0, unit="m/s",
                             doc="gamma c_max of Eq. 7, weighed against the nominal speed: it sets how far the "
                                 "stiffest obstacle turns the motion (equal: 45 degrees); the speed stays nominal"),
    "controllers": Field("list", default=list(CONTROLLERS), item=Field("str", choices=CONTROLLERS),
                         doc="augmented (Eqs. 6-7 over the reactive controller), reactive (the paper's [39], our "
                             "model), impedance (very low gains), straight (not in the paper: the straight reference "
                             "on the same stiff robot, no reaction, to attribute the differences)"),
    "link_radius": Field("float", default=0.025, ge=LINK_M[0], le=LINK_M[1], unit="m",
                         doc="the skin-covered extra link (outer radius)"),
    "skin_length": Field("float", default=0.05, ge=LINK_M[0], le=LINK_M[1], unit="m",
                         doc="length of the link's skin that meets the (vertical) obstacles"),
    "robot_stiffness": Field("float", default=3000.0, gt=0, unit="N/m",
                             doc="Cartesian stiffness to the commanded reference, augmented and reactive runs "
                                 "(assumption: a Panda's usual impedance gains are 1-3 kN/m)"),
    "low_gain_stiffness": Field("float", default=300.0, gt=0, unit="N/m",
                                doc="the impedance baseline's 'very low gains' (assumption: a tenth)"),
    "react_compression": Field("float", default=0.3, gt=0, lt=1,
                               doc="the reactive controller reacts to a contact whose peak taxel reads the "
                                   "layer compressed by this fraction (assumption: the linear-elastic limit)"),
    "react_full_compression": Field("float", default=0.6, gt=0, le=1,
                                    doc="... and backs away at the nominal speed from this compression on"),
    "dt": Field("float", default=0.01, gt=0, le=1.0, unit="s",
                 doc="control period (the skin reads at 20 Hz); the loops are held to the time and memory budgets"),
    "c_max": Field("float", default=2.0e7, gt=0, doc="shared colour scale of the picture"),
    **{k: AUGMENT.fields[k] for k in PROBE_NOISE_KEYS},
})


def _obstacle_object(name, mesh, stiffness):
    def k(points):
        return np.full(len(points), float(stiffness))

    def mu(points):
        return np.full(len(points), 0.5)

    return CompliantObject(name, mesh, k, mu)


def run(scene, ctx) -> TaskResult:
    import trimesh

    p = scene["task"]
    check_steps(p["dt"], runs=len(set(p["controllers"])), key="task.dt", file=scene.path)   # before the probing
    hgt, zp = p["height"], p["plane_height"]
    if zp >= hgt:
        raise scene.error("task.plane_height", f"must be below the obstacles' height {hgt} m, got {zp}")
    pole_mesh = trimesh.creation.cylinder(radius=p["pole_radius"], height=hgt, sections=48)
    pole_mesh.apply_translation([*p["pole_centre"], hgt / 2])
    hs = p["prism_half_size"]
    prism_mesh = trimesh.creation.box(extents=[2 * hs[0], 2 * hs[1], hgt])
    prism_mesh.apply_translation([*p["prism_centre"], hgt / 2])
    probe = ProbeModel(target=p["target_response"], position_noise=0.0)   # the robot's errors: ProbeNoise
    colours, clouds = {}, {}
    for name, mesh, k in (("pole", pole_mesh, p["pole_stiffness"]), ("prism", prism_mesh, p["prism_stiffness"])):
        obj = _obstacle_object(name, mesh, k)
        lo, hi = np.asarray(mesh.bounds)
        centre = (lo + hi) / 2
        from ...augment.cloud import DepthCamera

        # cameras looking at the scene from the robot's side (-x), like the paper's two D415s
        cams = [DepthCamera(eye=tuple(centre + [-0.45, s * 0.2, 0.1]), target=tuple(centre), width=424, height=240)
                for s in (-1, 1)]
        prober = contact_prober(scene, ctx, obj) if p["probe"] == "contact" else None
        probed = probe_object(obj, p["touches"], probe, cameras=cams, n_points=6000, rng=ctx.child_rng(name),
                              probe_fn=prober, noise=probe_noise(scene, ctx)[0])
        est = (ClusterPropagation() if p["propagation"] == "cluster" else SmoothPropagation()).fit(
            probed.tactile.points, probed.tactile.values)
        pred = est.predict(probed.points)
        band = np.abs(probed.points[:, 2] - zp) < 0.01      # the cloud in the task plane
        if not band.any():
            raise scene.error("task.plane_height", f"the cameras see no point of the {name} near the task plane")
        colours[name] = float(pred[band].mean())
        clouds[name] = (probed.points, pred)
    obstacles = [
        Obstacle("pole", "circle", tuple(p["pole_centre"]), p["pole_radius"], p["pole_stiffness"], colours["pole"]),
        Obstacle("prism", "box", tuple(p["prism_centre"]), tuple(hs), p["prism_stiffness"], colours["prism"]),
    ]
    eps = influence_radii([colours["pole"], colours["prism"]], p["r_max"])
    skin, noise_source = link_skin(scene, ctx, p)
    if not p["react_compression"] < p["react_full_compression"]:
        raise scene.error("task.react_full_compression", f"must be > react_compression ({p['react_compression']})")
    runs = {}
    for name in dict.fromkeys(p["controllers"]):
        runs[name] = reach(p["start"], p["goal"], obstacles, controller=name, skin=skin, r_max=p["r_max"],
                           speed=p["speed"], gamma=p["deviation_speed"] / max(colours.values()),
                           k_robot=p["robot_stiffness"], k_low=p["low_gain_stiffness"],
                           react_threshold=skin.compression_counts(p["react_compression"]),
                           react_full=skin.compression_counts(p["react_full_compression"]), dt=p["dt"],
                           rng=ctx.child_rng(f"skin_{name}"))
    metrics = {"pole_colour": colours["pole"], "prism_colour": colours["prism"],
               "pole_radius_eps_m": float(eps[0]), "prism_radius_eps_m": float(eps[1]),
               "skin_noise_counts": skin.noise, "skin_taxels": skin.taxels}
    metrics.update(run_metrics(runs, p))
    fig = _figure(runs, clouds, obstacles, eps, metrics, p)
    arrays = {}
    for name, r in runs.items():
        for key in ("position", "reference", "force", "time", "frame_time", "intensity", "speed_cmd"):
            arrays[f"{name}_{key}"] = getattr(r, key)
    return TaskResult(metrics=metrics, arrays=arrays, figures={"fig10_reach": fig},
                      sections=[_table(runs, metrics, skin, noise_source)])


def link_skin(scene, ctx, p) -> tuple[LinkSkin, str]:
    """The link's skin: the scene's [layer], its listed gain (else ``task.counts_per_pa``) and listed
    noise (else none: no effect the scene does not list, docs/inputs.md)."""
    layer = build_layer(scene)
    gain = ctx.pipeline.get("gain")
    listed = ctx.pipeline.get("noise")
    sigma, source = (float(listed.sigma), "the scene's [effects.noise]") if listed is not None \
        else (0.0, "none (no [effects.noise])")
    for name, fx in (("gain", gain), ("noise", listed)):
        if fx is not None:
            ctx.pipeline.add_time(name, 0.0)  # read by the link model (its time is the controllers')
    return LinkSkin(radius=p["link_radius"], length=p["skin_length"], thickness=layer.thickness,
                    e_star=layer.e_star, counts_per_pa=gain.counts_per_pa if gain is not None else p["counts_per_pa"],
                    noise=sigma, detect_k=p["detect_k"]), source


def run_metrics(runs, p) -> dict:
    """Per controller: reached, time, contact intensity (counts) and force, pole and prism contact,
    path; and the paper's comparisons: intensity above the augmented run's, its slowdown."""
    m = {}
    dt = p["dt"]
    for name, r in runs.items():
        m[f"{name}_reached"] = bool(r.reached)
        m[f"{name}_time_to_target_s"] = r.time_to_target
        m[f"{name}_contact_intensity_mean"] = r.mean_contact_intensity()
        m[f"{name}_contact_mean_n"] = r.mean_force()
        m[f"{name}_pole_contact_max_n"] = float(r.per_obstacle[:, 0].max(initial=0.0))
        m[f"{name}_pole_contact_s"] = float(np.sum(r.per_obstacle[:, 0] > 0) * dt)
        m[f"{name}_prism_contact_s"] = float(np.sum(r.per_obstacle[:, 1] > 0) * dt)
        m[f"{name}_path_length_m"] = r.path_length()
        m[f"{name}_speed_max_m_s"] = float(r.speed_cmd.max(initial=0.0))
        m[f"{name}_layer_bottomed"] = bool(r.layer_bottomed)
    if "augmented" in runs:
        a_int, a_t = m["augmented_contact_intensity_mean"], m["augmented_time_to_target_s"]
        for base in ("reactive", "impedance", "straight"):
            if base in runs:
                b = m[f"{base}_contact_intensity_mean"]
                m[f"{base}_intensity_excess_pct"] = 100.0 * (b - a_int) / a_int if a_int > 0 else float("nan")
                m[f"augmented_slower_than_{base}_pct"] = 100.0 * (a_t / m[f"{base}_time_to_target_s"] - 1.0)
    return m


def _table(runs, m, skin, noise_source) -> str:
    lines = ["## Reaching in clutter (Fig. 10)", "",
             "| controller | reached | time (s) | mean contact intensity (counts) | mean force (N) | pole max (N) | "
             "pole contact (s) | prism contact (s) | path (m) |", "|---|---|---|---|---|---|---|---|---|"]
    for name in runs:
        lines.append(f"| {name} | {m[name + '_reached']} | {m[name + '_time_to_target_s']:.2f} | "
                     f"{m[name + '_contact_intensity_mean']:.0f} | {m[name + '_contact_mean_n']:.3f} | "
                     f"{m[name + '_pole_contact_max_n']:.2f} | {m[name + '_pole_contact_s']:.2f} | "
                     f"{m[name + '_prism_contact_s']:.2f} | {m[name + '_path_length_m']:.3f} |")
    lines += ["", "| comparison | ours | paper |", "|---|---|---|"]
    for key, label, paper in (("reactive_intensity_excess_pct", "reactive intensity above augmented (%)",
                               PAPER["reactive_intensity_excess_pct"]),
                              ("impedance_intensity_excess_pct", "impedance intensity above augmented (%)",
                               PAPER["impedance_intensity_excess_pct"]),
                              ("augmented_slower_than_reactive_pct", "augmented slower than reactive (%)",
                               PAPER["augmented_slower_pct"]),
                              ("augmented_slower_than_impedance_pct", "augmented slower than impedance (%)",
                               PAPER["augmented_slower_pct"]),
                              ("straight_intensity_excess_pct", "straight (not in the paper) intensity above "
                               "augmented (%)", None),
                              ("augmented_slower_than_straight_pct", "augmented slower than straight (%)", None)):
        if key in m:
            lines.append(f"| {label} | {m[key]:.1f} | {'-' if paper is None else f'{paper:.1f}'} |")
    lines += ["", f"Contact intensity: per {skin.rate:g} Hz skin frame, the summed counts of the link's "
                  f"{skin.taxels} taxels above {skin.detect_k:g} noise deviations ({skin.detect_k * skin.noise:.0f} "
                  f"counts), averaged over the run's frames; skin noise {skin.noise:g} counts from {noise_source}."]
    return "\n".join(lines)


def _figure(runs, clouds, obstacles, eps, m, p):
    plt = pyplot()
    fig, (ax, ax2) = plt.subplots(2, 1, figsize=(7.5, 7.5), gridspec_kw={"height_ratios": [1.3, 1]})
    zp = p["plane_height"]
    for name, (pts, pred) in clouds.items():
        band = np.abs(pts[:, 2] - zp) < 0.02
        ax.scatter(pts[band, 0] * 1e3, pts[band, 1] * 1e3, c=colour_map(pred[band], 0.0, p["c_max"]) / 255, s=3)
    for o, e in zip(obstacles, eps):
        ax.add_patch(plt.Circle(np.asarray(o.centre) * 1e3, e * 1e3, fill=False, ls=":", color="0.5"))
    styles = {"augmented": "-", "reactive": "--", "impedance": "-.", "straight": ":"}
    for name, r in runs.items():
        label = f"{name}: {m[name + '_contact_intensity_mean']:.0f} counts, {r.time_to_target:.1f} s"
        ax.plot(r.position[:, 0] * 1e3, r.position[:, 1] * 1e3, styles[name], label=label)
        ax2.plot(r.frame_time, r.intensity, styles[name], lw=0.8, label=name)
    ax.plot(*(np.asarray(p["start"]) * 1e3), "o", color="green")
    ax.plot(*(np.asarray(p["goal"]) * 1e3), "o", color="red")
    ax.set_aspect("equal")
    ax.set_xlabel("x (mm)")
    ax.set_ylabel("y (mm)")
    ax.legend(fontsize=8, loc="upper left")
    ax.set_title("reaching in clutter: pole (stiff) and sponge prism; dotted: Eq. 6 radii", fontsize=9)
    ax2.set_xlabel("time (s)")
    ax2.set_ylabel("contact intensity (skin counts)")
    ax2.legend(fontsize=8)
    fig.tight_layout()
    return fig


register_task(TaskSpec("reach", run, PARAMS, effects=CONTACT_EFFECTS + SENSOR_EFFECTS,
                       doc="seed 000 Fig. 10: reaching in clutter with Eqs. 6-7 beside the reactive and impedance baselines"))
