"""Render the pictures of docs/blender.md headless with the bpy wheel (Cycles on the CPU).

    .venv/bin/python scripts/render_docs.py [--out docs/img] [--samples 16]

Builds a scene with the add-on's own operators (seed 002's curved end-effector,
a hexagonal patch laid at its middle, a 30 mm sphere pressed at 3 N through 3 mm of
Ecoflex 00-20, the edge filter), then renders
- ``skin_response.png``: taxel discs coloured by response, skin-mesh edges as tubes;
- ``skin_edges.png``: the same skin coloured by the edge filter's output;
- ``panels.png``: the sidebar panels. A panel cannot be screenshotted without a
  window (the bpy wheel has none), so this is a mock-up drawn with matplotlib
  from the rows, properties and buttons each panel's ``draw()`` really emits.
"""

from __future__ import annotations

import argparse
import os
import sys
import warnings
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "tests" / "blender"))


def build(context):
    import bpy

    from addon import bridge
    from bl_helpers import build_scene

    ee, ind, centre = build_scene(indenter_radius=0.03)
    grey = bpy.data.materials.new("end effector")
    grey.use_nodes = True
    grey.node_tree.nodes["Principled BSDF"].inputs["Base Color"].default_value = (0.55, 0.57, 0.6, 1)
    grey.node_tree.nodes["Principled BSDF"].inputs["Roughness"].default_value = 0.6
    ee.data.materials.append(grey)
    for p in ee.data.polygons:  # smooth shading; small mesh, once
        p.use_smooth = True
    s = context.scene.vtskin
    context.scene.cursor.location = centre
    context.view_layer.objects.active = ee
    assert bpy.ops.vtskin.lay_patch() == {"FINISHED"}
    m = bridge.matrix(ee)
    context.scene.cursor.location = centre + m[:3, 0] * 0.06
    context.view_layer.objects.active = ee
    assert bpy.ops.vtskin.lay_patch() == {"FINISHED"}
    skin = next(o for o in bpy.data.objects if o.vtskin.role == "TAXELS")
    s.indenter, s.thickness, s.force = ind, 0.003, 3.0
    context.view_layer.objects.active = skin
    assert bpy.ops.vtskin.simulate() == {"FINISHED"}
    s.edge_fraction = 0.3
    assert bpy.ops.vtskin.edges(show=False) == {"FINISHED"}
    ind.hide_render = True
    return ee, skin, centre


def camera_and_light(context, target, normal):
    import bpy
    from mathutils import Vector

    cam_data = bpy.data.cameras.new("camera")
    cam_data.lens = 50
    cam = bpy.data.objects.new("camera", cam_data)
    context.scene.collection.objects.link(cam)
    cam.location = Vector(target) + Vector(normal) * 0.16 + Vector((0.06, -0.12, 0.0))
    direction = Vector(target) - cam.location
    cam.rotation_euler = direction.to_track_quat("-Z", "Y").to_euler()
    context.scene.camera = cam
    sun_data = bpy.data.lights.new("sun", "SUN")
    sun_data.energy = 3.0
    sun = bpy.data.objects.new("sun", sun_data)
    sun.rotation_euler = (0.6, 0.2, 0.8)
    context.scene.collection.objects.link(sun)
    world = bpy.data.worlds.new("world")
    world.use_nodes = True
    world.node_tree.nodes["Background"].inputs["Color"].default_value = (0.8, 0.82, 0.85, 1)
    world.node_tree.nodes["Background"].inputs["Strength"].default_value = 0.6
    context.scene.world = world


def render(context, path, samples, size=(960, 640)):
    import bpy

    sc = context.scene
    sc.render.engine = "CYCLES"
    sc.cycles.device = "CPU"
    sc.cycles.samples = samples
    sc.cycles.use_denoising = False
    sc.render.resolution_x, sc.render.resolution_y = size
    sc.render.resolution_percentage = 100
    sc.render.film_transparent = False
    sc.view_settings.view_transform = "Standard"
    sc.render.filepath = str(path)
    bpy.ops.render.render(write_still=True)


# ---------------------------------------------------------------------------
# panel mock-up from the panels' own draw() calls


class _Recorder:
    """Stands in for ``Panel.layout``: records what ``draw()`` asks for, as text rows."""

    def __init__(self, rows, depth=0):
        self.rows, self.depth, self.enabled = rows, depth, True
        self.active = True

    def column(self, **kw):
        return _Recorder(self.rows, self.depth)

    def row(self, **kw):
        return _Row(self.rows, self.depth)

    def box(self):
        self.rows.append((self.depth, "box", ""))
        return _Recorder(self.rows, self.depth + 1)

    def _add(self, kind, text):
        self.rows.append((self.depth, kind, text))

    def label(self, text="", **kw):
        self._add("label", text)

    def prop(self, data, name, text=None, **kw):
        import bpy

        rna = data.bl_rna.properties[name]
        value = getattr(data, name)
        if isinstance(value, bpy.types.ID):
            value = value.name
        elif value is None:
            value = "-"
        elif rna.type == "ENUM":
            value = next((i.name for i in rna.enum_items if i.identifier == value), value)
        elif rna.type == "FLOAT":
            if getattr(rna, "subtype", "") == "DISTANCE":
                value = f"{value * 1e3:g} mm"
            elif getattr(rna, "subtype", "") == "ANGLE":
                value = f"{np.degrees(value):g}°"
            else:
                value = f"{value:g}"
        elif rna.type == "BOOLEAN":
            value = "[x]" if value else "[ ]"
        self._add("prop", f"{text or rna.name}: {value}" if value != "" else f"{text or rna.name}: (empty)")

    def operator(self, idname, text=None, icon=None, **kw):
        import bpy

        mod, name = idname.split(".")
        op = getattr(getattr(bpy.ops, mod), name)
        label = text or op.get_rna_type().name
        self._add("button", label)
        return _Props()


class _Row(_Recorder):
    def __init__(self, rows, depth):
        super().__init__([], depth)
        self._parent = rows
        self._parent.append((depth, "row", self))

    def row(self, **kw):
        return self


class _Props:
    def __setattr__(self, key, value):
        pass


def panel_rows(context):
    from addon import panel

    out = []
    for cls in panel.CLASSES:
        rows = []
        shim = type("PanelShim", (), {"layout": _Recorder(rows)})()
        cls.draw(shim, context)  # draw() only touches self.layout
        out.append((cls.bl_label, rows))
    return out


def draw_panels(context, path):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    panels = panel_rows(context)
    lines = []
    for title, rows in panels:
        lines.append(("title", 0, title))
        for depth, kind, item in rows:
            if kind == "row":
                parts = [t for _, _, t in item.rows]
                if parts:
                    lines.append(("row", depth, "   |   ".join(parts)))
            elif kind != "box":
                lines.append((kind, depth, item))
        lines.append(("gap", 0, ""))
    h = 0.22 * len(lines) + 0.6
    fig = plt.figure(figsize=(4.6, h), facecolor="#303030")
    ax = fig.add_axes([0, 0, 1, 1])
    ax.set_axis_off()
    ax.set_xlim(0, 1)
    ax.set_ylim(len(lines) + 1, -1)
    ax.text(0.03, -0.4, "Sidebar > Skin   (mock-up from the panels' draw(); not a screenshot)",
            color="#a0a0a0", fontsize=6.5, va="center")
    for i, (kind, depth, text) in enumerate(lines):
        x = 0.05 + 0.04 * depth
        if kind == "title":
            ax.add_patch(plt.Rectangle((0.02, i - 0.45), 0.96, 0.9, color="#3d3d3d"))
            ax.text(0.04, i, "v  " + text, color="white", fontsize=8.5, weight="bold", va="center")
        elif kind == "button":
            ax.add_patch(plt.Rectangle((x, i - 0.38), 0.9 - x, 0.76, color="#545454"))
            ax.text((x + 0.9) / 2 + 0.02, i, text, color="white", fontsize=7.5, va="center", ha="center")
        elif kind == "row":
            ax.text(x, i, text, color="#e0e0e0", fontsize=7, va="center")
        elif kind in ("prop", "label"):
            ax.text(x, i, text, color="#e0e0e0" if kind == "prop" else "#b8d0ff", fontsize=7.5, va="center")
    fig.savefig(path, dpi=130, facecolor=fig.get_facecolor())
    plt.close(fig)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--out", default=str(ROOT / "docs" / "img"))
    ap.add_argument("--samples", type=int, default=16)
    args = ap.parse_args()
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    warnings.simplefilter("ignore")
    os.environ.setdefault("VTCORE_PROGRESS", "0")

    import bpy

    from addon import bridge
    from bl_helpers import register_addon

    addon = register_addon()
    bpy.ops.wm.read_factory_settings(use_empty=True)
    context = bpy.context
    ee, skin, centre = build(context)
    m = bridge.matrix(ee)
    camera_and_light(context, centre + m[:3, 0] * 0.03, m[:3, 2])
    skin.vtskin.color_by = "response"
    render(context, out / "skin_response.png", args.samples)
    skin.vtskin.color_by = "edge"
    render(context, out / "skin_edges.png", args.samples)
    skin.vtskin.color_by = "response"
    context.view_layer.objects.active = skin
    draw_panels(context, out / "panels.png")
    print("wrote", *(str(out / n) for n in ("skin_response.png", "skin_edges.png", "panels.png")))
    sys.stdout.flush()
    addon.unregister()
    os._exit(0)


if __name__ == "__main__":
    main()
