"""Task ``reach``: seed 000's reaching in clutter (Sect. 4.3, Eqs. 6-7, Fig. 10).

A stiff metal pole and a soft sponge prism stand between A and B, too close
together for the skin-covered link to pass between them untouched. Each is
seen by the virtual cameras and probed; the colours of their augmented clouds
in the task plane set the Eq. 6 radii and Eq. 7 deviations. The run with the
augmented cloud is compared with the straight (minimum-distance) path on the
same compliant robot: contact intensity, contact with the pole, time to target.
"""

from __future__ import annotations

import numpy as np

from ...augment import ClusterPropagation, CompliantObject, ProbeModel, SmoothPropagation, colour_map
from ...augment.experiment import probe_object
from ...control.reach import Obstacle, influence_radii, reach
from ...plots import pyplot
from ..registry import TaskSpec, register_task
from ..runner import TaskResult
from ..schema import Field, Section
from .augment import PARAMS as AUGMENT
from .augment import PROBE_NOISE_KEYS, contact_prober, probe_noise

PARAMS = Section({
    "start": Field("vec", default=[0.0, 0.0], length=2, unit="m", doc="A, in the task plane"),
    "goal": Field("vec", default=[0.4, 0.0], length=2, unit="m", doc="B"),
    "plane_height": Field("float", default=0.15, gt=0, unit="m", doc="height of the task plane"),
    "pole_centre": Field("vec", default=[0.2, 0.03], length=2, unit="m"),
    "pole_radius": Field("float", default=0.012, gt=0, unit="m"),
    "pole_stiffness": Field("float", default=2e5, gt=0, unit="N/m", doc="metal pole (fixed)"),
    "prism_centre": Field("vec", default=[0.2, -0.05], length=2, unit="m"),
    "prism_half_size": Field("vec", default=[0.03, 0.03], length=2, unit="m"),
    "prism_stiffness": Field("float", default=300.0, gt=0, unit="N/m", doc="sponge"),
    "height": Field("float", default=0.3, gt=0, unit="m", doc="height of both obstacles"),
    "touches": Field("int", default=8, ge=1, doc="probes per obstacle"),
    "probe": Field("str", default="contact", choices=("contact", "series"),
                   doc="contact: the contact simulator's probe ([layer], object_compliance, gain); "
                       "series: the closed-form spring model"),
    "target_response": Field("float", default=4000.0, gt=0, doc="p̄* of the probes, counts"),
    "counts_per_pa": Field("float", default=2.0, gt=0, doc="sensor gain when [effects.gain] is not listed"),
    "readings": Field("int", default=10, ge=1),
    "propagation": Field("str", default="cluster", choices=("cluster", "smooth"),
                         doc="the paper notes both give the same uniform colours here"),
    "r_max": Field("float", default=0.07, gt=0, unit="m", doc="Eq. 6 (paper: 0.07 m)"),
    "speed": Field("float", default=0.02, gt=0, unit="m/s"),
    "deviation_speed": Field("float", default=0.02, gt=0, unit="m/s",
                             doc="gamma c_max of Eq. 7: the stiffest obstacle's tangential deviation speed"),
    "link_radius": Field("float", default=0.025, gt=0, unit="m", doc="the skin-covered extra link"),
    "robot_stiffness": Field("float", default=800.0, gt=0, unit="N/m", doc="Cartesian impedance"),
    "slow_force": Field("float", default=2.0, gt=0, unit="N", doc="speed halves at this contact force"),
    "dt": Field("float", default=0.01, gt=0, unit="s"),
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
    hgt, zp = p["height"], p["plane_height"]
    if zp >= hgt:
        raise scene.error("task.plane_height", f"must be below the obstacles' height {hgt} m, got {zp}")
    pole_mesh = trimesh.creation.cylinder(radius=p["pole_radius"], height=hgt, sections=48)
    pole_mesh.apply_translation([*p["pole_centre"], hgt / 2])
    hs = p["prism_half_size"]
    prism_mesh = trimesh.creation.box(extents=[2 * hs[0], 2 * hs[1], hgt])
    prism_mesh.apply_translation([*p["prism_centre"], hgt / 2])
    probe = ProbeModel(target=p["target_response"])
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
    runs = {}
    for name, use in (("straight", False), ("augmented", True)):
        runs[name] = reach(p["start"], p["goal"], obstacles, use_colours=use, r_max=p["r_max"], speed=p["speed"],
                           gamma=p["deviation_speed"] / max(colours.values()),
                           r_link=p["link_radius"], k_robot=p["robot_stiffness"], f_slow=p["slow_force"],
                           dt=p["dt"])
    metrics = {"pole_colour": colours["pole"], "prism_colour": colours["prism"],
               "pole_radius_eps_m": float(eps[0]), "prism_radius_eps_m": float(eps[1])}
    for name, r in runs.items():
        metrics[f"{name}_reached"] = bool(r.reached)
        metrics[f"{name}_time_to_target_s"] = r.time_to_target
        metrics[f"{name}_contact_mean_n"] = r.mean_contact_intensity()
        metrics[f"{name}_pole_contact_max_n"] = float(r.per_obstacle[:, 0].max(initial=0.0))
        metrics[f"{name}_pole_contact_s"] = float(np.sum(r.per_obstacle[:, 0] > 0) * p["dt"])
        metrics[f"{name}_prism_contact_s"] = float(np.sum(r.per_obstacle[:, 1] > 0) * p["dt"])
    a, s = metrics["augmented_contact_mean_n"], metrics["straight_contact_mean_n"]
    metrics["straight_contact_excess_pct"] = 100.0 * (s - a) / a if a > 0 else float("nan")

    plt = pyplot()
    fig, ax = plt.subplots(figsize=(7, 4.2))
    for name, (pts, pred) in clouds.items():
        band = np.abs(pts[:, 2] - zp) < 0.02
        ax.scatter(pts[band, 0] * 1e3, pts[band, 1] * 1e3, c=colour_map(pred[band], 0.0, p["c_max"]) / 255, s=3)
    for o, e in zip(obstacles, eps):
        ax.add_patch(plt.Circle(np.asarray(o.centre) * 1e3, e * 1e3, fill=False, ls=":", color="0.5"))
    for name, style in (("straight", "--"), ("augmented", "-")):
        r = runs[name]
        ax.plot(r.position[:, 0] * 1e3, r.position[:, 1] * 1e3, style,
                label=f"{name}: {metrics[name + '_contact_mean_n']:.2f} N mean contact, "
                      f"{r.time_to_target:.1f} s")
    ax.plot(*(np.asarray(p["start"]) * 1e3), "o", color="green")
    ax.plot(*(np.asarray(p["goal"]) * 1e3), "o", color="red")
    ax.set_aspect("equal")
    ax.set_xlabel("x (mm)")
    ax.set_ylabel("y (mm)")
    ax.legend(fontsize=8, loc="upper left")
    ax.set_title("reaching in clutter: pole (stiff) and sponge prism; dotted: Eq. 6 radii", fontsize=9)
    arrays = {}
    for name, r in runs.items():
        arrays[f"{name}_position"] = r.position
        arrays[f"{name}_force"] = r.force
        arrays[f"{name}_time"] = r.time
    table = ["## Reaching in clutter (Fig. 10)", "", "| run | reached | time (s) | mean contact (N) | "
             "pole max (N) | pole contact (s) | prism contact (s) |", "|---|---|---|---|---|---|---|"]
    for name in runs:
        m = metrics
        table.append(f"| {name} | {m[name + '_reached']} | {m[name + '_time_to_target_s']:.2f} | "
                     f"{m[name + '_contact_mean_n']:.3f} | {m[name + '_pole_contact_max_n']:.2f} | "
                     f"{m[name + '_pole_contact_s']:.2f} | {m[name + '_prism_contact_s']:.2f} |")
    return TaskResult(metrics=metrics, arrays=arrays, figures={"fig10_reach": fig}, sections=["\n".join(table)])


register_task(TaskSpec("reach", run, PARAMS, doc="seed 000 Fig. 10: reaching in clutter with Eqs. 6-7"))
