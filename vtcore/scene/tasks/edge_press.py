"""Task ``edge_press``: press objects on a skin and filter the contact (seed 002 Fig. 1).

The default scene presses two fingertips (spheres) on the curved patch of seed
002; the Eq. 6 response and the Eq. 7 edges should outline each finger, as in
Fig. 1 (c)-(d). The soft layer is the scene's standard ``[layer]`` table. Reports the number of edge components and how many pressed
taxels each outline encloses.
"""

from __future__ import annotations

import numpy as np

from ...tolerances import LENGTH_TOL
from ..registry import SENSOR_EFFECTS, TaskSpec, register_task
from ..runner import TaskResult
from ..budget import MAX_FORCE_N
from ..schema import Field, Section

FINGER = Section({
    "position": Field("vec", length=2, unit="m", doc="fingertip centre in the control-frame xy plane"),
    "radius": Field("float", default=0.008, gt=0, unit="m", doc="fingertip (sphere) radius"),
})

PARAMS = Section({
    "end_effector": Field("str", default="seed002_curved", choices=("seed002_planar", "seed002_curved")),
    "fingers": Field("tables", default=[], section=FINGER, doc="[[task.fingers]] tables"),
    "force": Field("float", default=10.0, gt=0, le=MAX_FORCE_N, unit="N", doc="total force of all fingers"),
    "fraction": Field("float", default=0.15, ge=0, le=1, doc="Eq. 7 threshold / strongest response"),
    "readings": Field("int", default=5, ge=1, doc="sensor readings while holding the force"),
    "rate": Field("float", default=20.0, gt=0, unit="Hz", doc="CySkin: 20 Hz (seed 002)"),
})


def run(scene, ctx) -> TaskResult:
    import trimesh

    from ...contact import make_object, press
    from ...filters import EdgeFilter, MeshEdgeDetector
    from ...layout import skin_mesh
    from ..effects.contact import spread_options
    from ..sections.layer import build_layer, layer_options
    from .contour import control_skin

    p = scene["task"]
    if not p["fingers"]:
        raise scene.error("task.fingers", "list at least one [[task.fingers]] table (position, radius)")
    layer = build_layer(scene)
    if layer.thickness <= 0:
        raise scene.error("layer.thickness", "edge_press presses through a soft layer: must be > 0 m")
    _, layout, frame = control_skin(p["end_effector"])
    mesh = skin_mesh(layout)
    parts = []
    for f in p["fingers"]:
        s = make_object("sphere", radius=f["radius"])  # rests on z = 0, centre at z = radius
        # upside down above the skin: the sphere's lowest point at the layer surface + 5 mm
        s.apply_translation([f["position"][0], f["position"][1], -f["radius"]])
        s.apply_translation([0.0, 0.0, 2 * f["radius"] + layer.thickness + 0.005])
        parts.append(s)
    obj = trimesh.util.concatenate(parts)
    # the stress spreads through the layer only with [effects.soft_layer] (the effect contract)
    res = press(layout, obj, np.eye(4), layer, force=p["force"], direction=[0.0, 0.0, -1.0],
                **{**layer_options(scene), **spread_options(ctx.pipeline)})
    pressure = np.broadcast_to(res.pressure, (p["readings"], len(layout))).copy()
    frames = np.asarray(ctx.pipeline.apply("sensor", pressure.copy(), ctx))
    ef = EdgeFilter(mesh)
    response = ef(frames)
    det = MeshEdgeDetector(mesh, fraction=p["fraction"])
    edges = np.array([det.edges(fr)[1] for fr in frames])
    feats = det.detect(frames[0])
    pressed = res.pressure > 0.05 * res.pressure.max()
    metrics = {
        "force_n": float(res.force), "indentation_mm": float(res.indentation) * 1e3,
        "taxels": len(layout), "pressed_taxels": int(pressed.sum()),
        "edge_taxels": int(edges[0].sum()), "edge_components": feats.n_components,
        "fingers": len(p["fingers"]),
        "edge_on_pressed_fraction": float((edges[0] & pressed).sum() / max(edges[0].sum(), 1)),
    }
    from ...plots import png_writer

    figures = {"fig1": png_writer(_figure, layout, frames[0], response[0], edges[0], scene.name)}
    note = (f"Seed 002 Fig. 1: {len(p['fingers'])} finger(s) at {p['force']:.0f} N on "
            f"{p['end_effector']} through {layer.thickness * 1e3:g} mm of {layer.material} ([layer]; seed 002 "
            "does not describe its cover); the Eq. 6/7 edges form {feats.n_components} connected component(s) "
            f"over {int(edges[0].sum())} taxels around {int(pressed.sum())} pressed taxels. Eq. 6 marks "
            "the low side of a rise, so the outline lies just outside each contact "
            f"({metrics['edge_on_pressed_fraction']:.0%} of edge taxels are themselves pressed).")
    return TaskResult(metrics=metrics, arrays={
        "positions": layout.positions, "normals": layout.normals, "pressure": pressure, "frames": frames,
        "force": np.full(p["readings"], float(res.force)), "edge": edges, "response": response,
        "timestamps": np.arange(p["readings"]) / p["rate"], "control_frame": frame},
        figures=figures, sections=[note])


def _figure(layout, frame, response, edge, name):
    from ...plots import pyplot

    plt = pyplot()
    fig = plt.figure(figsize=(13, 4))
    xyz = layout.positions * 1e3
    ax = fig.add_subplot(1, 3, 1, projection="3d")
    ax.scatter(*xyz.T, c=frame, cmap="Greys", s=14, edgecolor="0.6", linewidth=0.3)
    ax.set_box_aspect(np.ptp(xyz, axis=0) + LENGTH_TOL)
    ax.set_title("(b) skin and contact, 3-D (mm)")
    # top view: the skin unrolled (its flat coordinates), which is how seed 002 draws it
    xyz = np.column_stack([layout.flat * 1e3, np.zeros(len(layout))]) if layout.flat is not None else xyz
    ax2 = fig.add_subplot(1, 3, 2)
    sc = ax2.scatter(xyz[:, 0], xyz[:, 1], c=frame, cmap="Greys", s=30, edgecolor="0.6", linewidth=0.3)
    fig.colorbar(sc, ax=ax2, shrink=0.8)
    ax2.set_title("(c) response (top view)")
    ax3 = fig.add_subplot(1, 3, 3)
    ax3.scatter(xyz[:, 0], xyz[:, 1], c="0.85", s=30)
    ax3.scatter(xyz[edge, 0], xyz[edge, 1], c=response[edge], cmap="viridis", s=40)
    ax3.set_title("(d) Eq. 6-7 edges (top view)")
    for a in (ax2, ax3):
        a.set_aspect("equal")
        a.set_xlabel("x (mm)")
    fig.suptitle(f"{name}: two fingers on the curved patch (seed 002 Fig. 1)")
    fig.tight_layout()
    return fig


register_task(TaskSpec("edge_press", run, PARAMS, sections=("layer",),
                       effects=("soft_layer",) + SENSOR_EFFECTS,
                       doc="press fingertips on a skin and show the seed 002 edge filter (Fig. 1)"))
