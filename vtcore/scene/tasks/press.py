"""Task ``press``: press the scene's object onto the skin at a target force and read the skin."""

from __future__ import annotations

import numpy as np

from ...contact import median_taxel_area, press_sphere
from ...plots import taxel_map
from ..registry import TaskSpec, register_task
from ..runner import TaskResult
from ..schema import Field, Section
from ..sections.layout import build_layout

PARAMS = Section({
    "force": Field("float", default=10.0, gt=0, unit="N", doc="target total normal force"),
    "readings": Field("int", default=10, ge=1, doc="sensor readings taken while holding the force"),
    "rate": Field("float", default=20.0, gt=0, unit="Hz", doc="sensor sampling rate"),
})


def run(scene, ctx) -> TaskResult:
    layout = build_layout(scene)
    if not scene["objects"]:
        raise scene.error("objects", "task 'press' needs at least one [[objects]] table")
    obj = scene["objects"][0]
    layer = scene["layer"]
    area = median_taxel_area(layout.positions)
    surface, depth = press_sphere(layout.positions, layout.normals, obj["position"], obj["radius"],
                                  scene["task"]["force"], layer["thickness"], layer["young_modulus"],
                                  layer["poisson"], taxel_area=area)
    state = {"positions": layout.positions, "pressure": surface, "thickness": layer["thickness"],
             "taxel_area": area}
    pressure = ctx.pipeline.apply("contact", state, ctx)["pressure"]
    t = scene["task"]["readings"]
    pressure_t = np.broadcast_to(pressure, (t, len(layout))).copy()
    frames = ctx.pipeline.apply("sensor", pressure_t.copy(), ctx)
    timestamps = np.arange(t) / scene["task"]["rate"]
    force = np.full(t, surface.sum() * area)
    mean = frames.mean(axis=0)
    flat = layout.flat
    metrics = {
        "force_n": float(force[0]),
        "indentation_mm": depth * 1e3,
        "taxels": len(layout),
        "active_taxels": int((pressure > 1e-3 * max(pressure.max(), 1e-12)).sum()),
        "pressure_max_pa": float(pressure.max()),
        "response_max": float(mean.max()),
        "response_mean": float(mean.mean()),
    }
    figures = {
        "response": taxel_map(flat, mean, title=f"{scene.name}: mean response, {obj['name']}",
                              label="counts" if ctx.pipeline.stage("sensor") else "Pa"),
    }
    return TaskResult(metrics=metrics, arrays={
        "positions": layout.positions, "normals": layout.normals, "taxel_ids": layout.taxel_ids,
        "timestamps": timestamps, "frames": frames, "pressure": pressure_t, "force": force},
        figures=figures)


register_task(TaskSpec("press", run, PARAMS, sections=("layout", "objects"),
                       doc="press an object at a target force"))
