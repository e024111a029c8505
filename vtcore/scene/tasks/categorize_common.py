"""What the ``categorize`` and ``categorize_sweep`` tasks share (seed 001): their common parameters, the
objects pressed through the scene's layer (:class:`Pressures`, cached per object and thickness), the
sensor read-out through the scene's pipeline (:func:`sensor_readout`, :func:`variant_sensor`) and the
Fig. 8 accuracy table (:func:`fig8_table`). Registers no task.
"""

from __future__ import annotations

import time

import numpy as np

from ...categorize import PAPER_FIG8
from ...errors import UnreachableTargetError
from ..budget import MAX_FORCE_N
from ..schema import Field

COMMON_PARAMS = {
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

PLACEMENT_PARAMS = {
    "radius_reading": Field("str", default="radius", choices=("radius", "diameter"),
                            doc="seed 001 gives the sphere and half-cylinder as 'radius = 30mm': read as a "
                                "radius (the objects' radius as given) or as a diameter (their radius halved)"),
    "object_yaw": Field("float", default=0.0, unit="rad",
                        doc="turn every object about the press axis (the paper does not give how the long "
                            "objects lay on the patch)"),
}


# -- the contact part: layout, objects, pressures (cached per object and thickness) ----------------

class Pressures:
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


def sensor_readout(ctx, rate):
    """``(T, N) Pa -> (T, N) readings``: the listed sensor effects, through the scene's pipeline."""

    def apply(block):
        out = ctx.pipeline.apply("sensor", {"frames": block, "timestamps": np.arange(len(block)) / rate}, ctx)
        return np.asarray(out["frames"], dtype=np.float64)

    return apply


def variant_sensor(ctx, rate, p_half):
    """Like :func:`sensor_readout` but with the listed ``gain`` replaced by one of transfer ``p_half`` (Pa, None:
    linear) and the same slope; every other listed sensor effect (noise, clipping, ...) runs as listed."""
    from ...contact.sensor import gain

    listed = ctx.pipeline.get("gain")
    if listed is None:
        if not p_half:
            return sensor_readout(ctx, rate)
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


def fig8_table(rows, tasks, paper=True) -> str:
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
