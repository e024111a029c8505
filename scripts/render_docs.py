"""Render the pictures of docs/blender.md headless with the bpy wheel (Cycles on the CPU).

    .venv/bin/python scripts/render_docs.py [--out docs/img] [--samples 32]

Builds a scene with the add-on's own operators (seed 002's curved end-effector,
a hexagonal patch laid at its middle, a 30 mm sphere pressed at 3 N through 3 mm of
Ecoflex 00-20, the edge filter), then renders
- ``skin_response.png``: taxel discs coloured by response, skin-mesh edges as tubes;
- ``skin_edges.png``: the same skin coloured by the edge filter's output;
- ``replay_response.png`` / ``replay_edges.png``: a recorded CAN log replayed on its skin
  (``scenes/replay_cyskin16_slide.toml`` run with *Run Scene*, which loads the log onto the
  timeline), at the frame with the most edge taxels: baseline-compensated response, and edges;
- ``panels.png``: the sidebar panels. A panel cannot be screenshotted without a
  window (the bpy wheel has none), so this is a mock-up drawn with matplotlib
  from the rows, properties and buttons each panel's ``draw()`` really emits.
"""

from __future__ import annotations

import argparse
import os
import sys
import traceback
import warnings
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "tests" / "blender"))


def build(context):
    """A skin as a designer lays it: the end-effector's top and curved flank filled with whole
    modules (the Fill operator on a face selection), a sphere pressed on it.

    Filling tiles the selected faces with modules on one lattice, so no two modules share
    taxels; the script checks that (closest taxels at least 0.8 pitch apart, no overlaps
    reported) and stops if not, instead of rendering a skin nobody would build.
    """
    import bpy
    from scipy.spatial import cKDTree

    from addon import bridge, skin as skin_mod
    from bl_helpers import build_scene

    ee, ind, centre = build_scene(indenter_radius=0.02)
    from addon import display

    grey = bpy.data.materials.new("end effector")
    bsdf = display.shader_nodes(grey).nodes["Principled BSDF"]  # use_nodes is deprecated in 5.x
    bsdf.inputs["Base Color"].default_value = (0.42, 0.45, 0.5, 1)
    bsdf.inputs["Roughness"].default_value = 0.55
    ee.data.materials.append(grey)
    me = ee.data
    nf = len(me.polygons)
    me.polygons.foreach_set("use_smooth", np.ones(nf, bool))
    # Select the faces to cover: a compact region 50 mm round a point 20 mm from the middle
    # towards the curved flank, over the flank, that does not face away (the underside stays
    # bare). The end-effector's local frame, metres.
    c = np.empty(3 * nf, np.float32)
    me.polygons.foreach_get("center", c)
    nrm = np.empty(3 * nf, np.float32)
    me.polygons.foreach_get("normal", nrm)
    c, nrm = c.reshape(-1, 3), nrm.reshape(-1, 3)
    m = bridge.matrix(ee)
    inv = np.linalg.inv(m)
    anchor = inv[:3, :3] @ centre + inv[:3, 3] + np.array([0.02, 0.0, 0.0])
    region = (np.linalg.norm(c - anchor, axis=1) < 0.05) & (nrm[:, 2] > -0.2)
    me.polygons.foreach_set("select", region)
    s = context.scene.vtskin
    s.module, s.place_at = "cyskin10", "SELECTED"
    context.view_layer.objects.active = ee
    assert bpy.ops.vtskin.lay_patch(fill=True) == {"FINISHED"}
    me.polygons.foreach_set("select", np.zeros(nf, bool))
    skin = next(o for o in bpy.data.objects if o.vtskin.role == "TAXELS")
    lay = skin_mod.read_layout(skin)
    d, _ = cKDTree(lay.positions).query(lay.positions, k=2)
    pitch, closest = float(np.median(d[:, 1])), float(d[:, 1].min())
    print(f"skin: {len(lay)} taxels in {len(np.unique(lay.module_ids))} modules, pitch "
          f"{pitch * 1e3:.2f} mm, closest taxels {closest * 1e3:.2f} mm apart, "
          f"{skin.vtskin.overlaps} overlaps")
    if closest < 0.8 * pitch or skin.vtskin.overlaps:
        raise RuntimeError(f"render_docs: modules overlap (closest taxels {closest * 1e3:.2f} mm apart)")
    s.indenter, s.thickness, s.force = ind, 0.003, 4.0
    context.view_layer.objects.active = skin
    assert bpy.ops.vtskin.simulate() == {"FINISHED"}
    s.edge_fraction = 0.3
    assert bpy.ops.vtskin.edges(show=False) == {"FINISHED"}
    ind.hide_render = True
    mw = np.array(skin.matrix_world)
    middle = mw[:3, :3] @ lay.positions.mean(0) + mw[:3, 3]  # world point the camera aims at
    return ee, skin, middle


def camera_and_light(context, target, m):
    """Camera three-quarters above the skin, looking over the curved flank; soft sun, grey sky.

    target : (3,) world point aimed at; m : (4, 4) end-effector pose (its z is the top's normal,
    its +x points to the curved flank).
    """
    import bpy
    from mathutils import Vector

    n = Vector(m[:3, 2]).normalized()
    x = Vector(m[:3, 0]).normalized()
    y = n.cross(x)
    cam_data = bpy.data.cameras.new("camera")
    cam_data.lens = 55
    cam = bpy.data.objects.new("camera", cam_data)
    context.scene.collection.objects.link(cam)
    cam.location = Vector(target) + n * 0.20 + x * 0.13 - y * 0.12
    direction = Vector(target) - cam.location
    cam.rotation_euler = direction.to_track_quat("-Z", "Y").to_euler()
    context.scene.camera = cam
    sun_data = bpy.data.lights.new("sun", "SUN")
    sun_data.energy = 2.2
    sun_data.angle = 0.3  # soft shadows
    sun = bpy.data.objects.new("sun", sun_data)
    sun.rotation_euler = (-(n * 1.0 - x * 0.4 - y * 0.5)).to_track_quat("-Z", "Y").to_euler()
    context.scene.collection.objects.link(sun)
    from addon import display

    world = bpy.data.worlds.new("world")
    background = display.shader_nodes(world).nodes["Background"]  # use_nodes is deprecated in 5.x
    background.inputs["Color"].default_value = (0.78, 0.8, 0.83, 1)
    background.inputs["Strength"].default_value = 0.45
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


def render_with_legend(context, path, samples, skin, size=(960, 640)):
    """Render, then put the colour bar of what ``skin``'s discs are coloured by under the picture
    (quantity, unit and range, ``vtcore.plots.add_colorbar``): the viewport panel's legend, in print."""
    import numpy as np
    from vtcore.plots import add_colorbar

    from addon import bridge

    render(context, path, samples, size)
    name = skin.vtskin.color_by
    values = bridge.get_attribute(skin.data, name).astype(float) if name in skin.data.attributes else np.zeros(1)
    add_colorbar(path, name, float(values.min()), float(values.max()))


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

    def template_color_ramp(self, data, name, **kw):
        self._add("ramp", "")  # drawn as a colour bar (viridis, the discs' ramp)

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
        elif rna.type == "FLOAT" and getattr(rna, "array_length", 0):
            value = "(" + ", ".join(f"{v:.3g}" for v in value) + ")"
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
        # draw() only touches self.layout and the panel's own class attributes.
        ns = {k: getattr(cls, k) for k in ("draw", "draw_more", "props", "button") if hasattr(cls, k)}
        shim = type("PanelShim", (), ns)()
        shim.layout = _Recorder(rows)
        shim.draw(context)
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
        elif kind == "ramp":  # the legend's colour ramp, as template_color_ramp draws it
            ax.imshow([[v / 255 for v in range(256)]], extent=(x, 0.9, i + 0.35, i - 0.35), aspect="auto",
                      cmap="viridis")
    fig.savefig(path, dpi=130, facecolor=fig.get_facecolor())
    plt.close(fig)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--out", default=str(ROOT / "docs" / "img"))
    ap.add_argument("--samples", type=int, default=32)
    ap.add_argument("--only", choices=("replay",), default="", help="render only these pictures")
    args = ap.parse_args()
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    warnings.simplefilter("ignore")
    os.environ.setdefault("VTCORE_PROGRESS", "0")

    import bpy

    from bl_helpers import register_addon

    addon = register_addon()
    code = 0
    try:
        if args.only != "replay":
            _render_all(bpy.context, out, args.samples)
        _render_replay(bpy.context, out, args.samples)
    except BaseException:  # noqa: BLE001 - report any failure, then exit non-zero without hanging
        traceback.print_exc()
        code = 1
    finally:
        # The bpy 4.5 wheel hangs at interpreter exit while add-on classes are registered.
        addon.unregister()
        sys.stdout.flush()
        sys.stderr.flush()
    os._exit(code)


def _render_all(context, out, samples):
    import bpy

    from addon import bridge

    bpy.ops.wm.read_factory_settings(use_empty=True)
    context = bpy.context  # the factory reset replaced the scene
    ee, skin, mid = build(context)
    m = bridge.matrix(ee)
    camera_and_light(context, mid, m)
    skin.vtskin.color_by = "response"
    render_with_legend(context, out / "skin_response.png", samples, skin)
    skin.vtskin.color_by = "edge"
    render_with_legend(context, out / "skin_edges.png", samples, skin)
    skin.vtskin.color_by = "response"
    context.view_layer.objects.active = skin
    draw_panels(context, out / "panels.png")
    print("wrote", *(str(out / n) for n in ("skin_response.png", "skin_edges.png", "panels.png")))


def _render_replay(context, out, samples):
    """The replay pictures: the example cyskin16 log replayed on its 60-taxel hexagon."""
    import tempfile

    import bpy
    import numpy as np

    from addon import bake, render as vt_render

    bpy.ops.wm.read_factory_settings(use_empty=True)
    context = bpy.context
    context.scene.vtskin.out_dir = tempfile.mkdtemp(prefix="vtskin_docs_")
    assert bpy.ops.vtskin.run_scene(filepath=str(ROOT / "scenes" / "replay_cyskin16_slide.toml")) == {"FINISHED"}
    ob = context.view_layer.objects.active
    s = ob.vtskin
    counts = [int(bake.frame_values(ob, f)["edge"].sum()) for f in range(s.bake_start, s.bake_end + 1)]
    frame = s.bake_start + int(np.argmax(counts))
    context.scene.frame_set(frame)
    vt_render.frame_camera(context, ob, lens=60.0)
    render_with_legend(context, out / "replay_response.png", samples, ob, size=(720, 540))
    s.color_by = "edge"
    render_with_legend(context, out / "replay_edges.png", samples, ob, size=(720, 540))
    print(f"wrote replay pictures of frame {frame} ({max(counts)} edge taxels)",
          *(str(out / n) for n in ("replay_response.png", "replay_edges.png")))


if __name__ == "__main__":
    main()
