"""Design maps on the robot mesh (*Evaluate Skin*) and their legend; live touch lives in ``live.py``.

*Evaluate Skin* reads the skin and the mesh it lies on (its end-effector), makes ONE call,
``vtcore.scene.interactive.evaluate_skin``, and writes per-vertex attributes on that mesh:
``threshold_n`` (N), ``localisation_mm``, ``two_point_mm``, ``detect_rate``, ``blind``,
``evaluated``, ``covered``, and one colour attribute per map (``vtskin_map_threshold``, ...). The
shown map is the mesh's active colour attribute (the viewport's *Attribute* colour) and the colour a
material ``vtskin design map`` reads, set on the object's material slots (object-linked, the mesh's own
materials are kept underneath; *Clear Map* gives them back). The legend (title, units, range, what red
means) is in the panel and, for renders, a colour bar with labels beside the object (*Legend*).
"""

from __future__ import annotations

import bpy
import mathutils
import numpy as np

from . import bridge, display, skin
from .opbase import Cancel, Op, failing

MATERIAL = "vtskin design map"
LEGEND = "vtskin map legend"
COLOUR_PREFIX = "vtskin_map_"
FLOATS = ("threshold_n", "localisation_mm", "two_point_mm", "detect_rate")
FLAGS = ("blind", "evaluated", "covered")


def srgb_to_linear(rgba):
    """RGBA (n, 4) in sRGB (the ramp's colours) -> scene-linear, what a float colour attribute holds."""
    c = np.asarray(rgba, float).copy()
    rgb = c[:, :3]
    c[:, :3] = np.where(rgb <= 0.04045, rgb / 12.92, ((rgb + 0.055) / 1.055) ** 2.4)
    return c


def map_material():
    """The material that shows the active map's colour attribute."""
    mat = bpy.data.materials.get(MATERIAL)
    if mat is None:
        mat = bpy.data.materials.new(MATERIAL)
        nt = display.shader_nodes(mat)
        bsdf = nt.nodes.get("Principled BSDF")
        attr = nt.nodes.new("ShaderNodeAttribute")
        attr.name = "map"
        attr.attribute_type = "GEOMETRY"
        attr.location = (-400, 0)
        nt.links.new(attr.outputs["Color"], bsdf.inputs["Base Color"])
        nt.links.new(attr.outputs["Color"], bsdf.inputs["Emission Color"])
        bsdf.inputs["Emission Strength"].default_value = 0.25
    return mat


def mesh_of_skin(context, ob):
    """The mesh the skin ``ob`` lies on: its end-effector, else the active mesh if it is not the skin."""
    ee = ob.vtskin.end_effector
    if ee is None or ee.type != "MESH":
        act = context.active_object
        ee = act if act is not None and act.type == "MESH" and act != ob else None
    if ee is None or len(ee.data.polygons) == 0:
        raise Cancel("The skin has no end-effector mesh with faces: select the mesh it lies on as active")
    return ee


def mesh_in_skin_frame(ee, ob):
    """The end-effector's own vertices (its mesh data, in order, no modifiers) in the skin's frame, and
    its triangles: the attributes go onto exactly these vertices."""
    me = ee.data
    world = bridge.vertex_positions(me, bridge.matrix(ee))
    me.calc_loop_triangles()
    tri = np.empty(3 * len(me.loop_triangles), np.int32)
    me.loop_triangles.foreach_get("vertices", tri)
    inv = np.linalg.inv(bridge.matrix(ob))
    return world @ inv[:3, :3].T + inv[:3, 3], tri.reshape(-1, 3).astype(np.int64)


def show_map(scene, name: str) -> None:
    """Show map ``name`` on every mesh that has it (the ``map_show`` property's update)."""
    for ob in scene.objects:
        if ob.type != "MESH" or f"{COLOUR_PREFIX}{name}" not in ob.data.attributes:
            continue
        me = ob.data
        me.color_attributes.active_color = me.color_attributes[f"{COLOUR_PREFIX}{name}"]
        mat = map_material()
        mat.node_tree.nodes["map"].attribute_name = f"{COLOUR_PREFIX}{name}"
        legend = ob.get("vtskin_legends", {}).get(name)
        if legend:
            ob.vtskin.map_legend = legend
        me.update()


def use_map_material(ob) -> None:
    """Put the map material on every slot of ``ob`` as an object-linked override (the mesh keeps its own)."""
    mat = map_material()
    if not ob.material_slots:
        ob.data.materials.append(None)
    for slot in ob.material_slots:
        slot.link = "OBJECT"
        slot.material = mat


class VTSKIN_OT_evaluate_skin(Op, bpy.types.Operator):
    """Map where a touch goes unnoticed, how light a touch is felt, how precisely it is located and how far
    apart two fingers must be, on the mesh the skin lies on"""

    bl_idname = "vtskin.evaluate_skin"
    bl_label = "Evaluate Skin"

    def run(self, context):
        from vtcore.scene import interactive

        s = context.scene.vtskin
        ob = skin.skin_of(context)
        if ob is None or len(ob.data.vertices) == 0:
            raise Cancel("Select a skin with taxels (lay a patch first)")
        if s.thickness <= 0:
            raise Cancel("The soft layer has zero thickness: set a thickness > 0 in the Soft layer panel")
        ee = mesh_of_skin(context, ob)
        verts, tri = mesh_in_skin_frame(ee, ob)
        with failing("Evaluate Skin failed"):
            m = interactive.evaluate_skin(skin.read_layout(ob), verts, tri, thickness=s.thickness,
                                          material=s.material, reference_force=s.map_reference_force,
                                          spacing=s.map_spacing, margin=s.map_margin, probe=s.map_probe,
                                          two_point=s.map_two_point, counts_per_pa=s.sensor_gain())
        me = ee.data
        for name in FLOATS:
            if name in m.values:
                bridge.set_attribute(me, name, m.values[name], "FLOAT")
        for name in FLAGS:
            bridge.set_attribute(me, name, m.values[name], "BOOLEAN")
        legends = {}
        for key, rgba in m.colours.items():
            bridge.set_attribute(me, f"{COLOUR_PREFIX}{key}", srgb_to_linear(rgba), "FLOAT_COLOR")
            legends[key] = "\n".join(m.legends[key].lines() + m.lines)
        ee["vtskin_legends"] = legends
        ee["vtskin_legend_data"] = {k: {"title": g.title, "unit": g.unit, "lo": g.lo, "hi": g.hi, "log": g.log,
                                        "no_value": g.no_value} for k, g in m.legends.items()}
        use_map_material(ee)
        show = s.map_show if s.map_show in m.colours else "threshold"
        show_map(context.scene, show)
        self.report({"INFO"}, "; ".join(x for x in m.lines if x.startswith(("threshold", "blind:"))))
        # the maps live on the mesh's own vertices: a collision hull's few long faces show a map as
        # blotches, so say so (splitting faces is the user's call: it edits the robot's mesh)
        edges = np.linalg.norm(verts[tri[:, [1, 2, 0]]] - verts[tri], axis=2)
        median_edge = float(np.median(edges)) if edges.size else 0.0
        if median_edge > 3 * s.map_spacing:
            self.report({"WARNING"}, f"{ee.name}: its edges ({median_edge * 1e3:.3g} mm median) are much longer "
                        f"than the map's {s.map_spacing * 1e3:.3g} mm spacing, so the map shows coarsely: subdivide "
                        "the mesh (Edit Mode > Subdivide) and evaluate again")
        return {"FINISHED"}


class VTSKIN_OT_clear_map(Op, bpy.types.Operator):
    """Give the mesh its own materials back and remove the design map's attributes"""

    bl_idname = "vtskin.clear_map"
    bl_label = "Clear Map"

    def run(self, context):
        ob = context.active_object
        sk = skin.skin_of(context)
        if sk is not None and sk.vtskin.end_effector is not None:
            ob = sk.vtskin.end_effector
        if ob is None or ob.type != "MESH" or "threshold_n" not in ob.data.attributes:
            raise Cancel("The active mesh has no design map")
        me = ob.data
        for name in FLOATS + FLAGS + tuple(a.name for a in me.attributes if a.name.startswith(COLOUR_PREFIX)):
            attr = me.attributes.get(name)
            if attr is not None:
                me.attributes.remove(attr)
        for slot in ob.material_slots:
            if slot.link == "OBJECT" and slot.material is not None and slot.material.name == MATERIAL:
                slot.material = None
                slot.link = "DATA"
        for key in ("vtskin_legends", "vtskin_legend_data"):
            if key in ob:
                del ob[key]
        ob.vtskin.map_legend = ""
        legend = bpy.data.objects.get(LEGEND)
        if legend is not None:
            remove_legend()
        return {"FINISHED"}


def remove_legend() -> None:
    coll = bpy.data.collections.get(LEGEND)
    if coll is None:
        return
    for o in list(coll.objects):
        data = o.data
        bpy.data.objects.remove(o)
        if data is not None and data.users == 0:
            (bpy.data.meshes if isinstance(data, bpy.types.Mesh) else bpy.data.curves).remove(data)
    bpy.data.collections.remove(coll)


def _legend_frame(context, ob):
    """(place(offset) -> world point, rotation, bar height): where the legend goes. With a scene camera,
    at the right of its view just in front of the mapped object, facing it (so renders show it);
    else beside the object's bounding box, in its orientation."""
    cam = context.scene.camera
    bb = np.array([tuple(ob.matrix_world @ mathutils.Vector(c)) for c in ob.bound_box])
    if cam is not None and cam.type == "CAMERA":
        m = cam.matrix_world.copy()
        # in front of the object's nearest corner, so the object never hides it
        near = float(np.linalg.norm(bb - np.array(m.translation), axis=1).min())
        dist = 0.8 * near
        half_w = dist * (cam.data.sensor_width / 2) / cam.data.lens
        h = 0.55 * half_w
        base = mathutils.Vector((0.4 * half_w, -0.5 * h, -dist))
        return (lambda off: m @ (base + mathutils.Vector(off))), m.to_quaternion(), h
    m = ob.matrix_world.copy()
    h = 0.6 * float(np.ptp(bb, axis=0).max())
    corner = mathutils.Vector(tuple(bb.max(axis=0) + np.array([0.1 * h, 0.0, 0.0])))
    return (lambda off: corner + m.to_3x3() @ mathutils.Vector(off)), m.to_quaternion(), h


def _legend_object(coll, name, data, place, rot, off):
    o = bpy.data.objects.new(name, data)
    coll.objects.link(o)
    o.rotation_mode = "QUATERNION"
    o.location, o.rotation_quaternion = place(off), rot
    o.visible_shadow = False  # a legend, not part of the scene: it casts no shadow on the mesh
    return o


def build_legend(context, ob, key: str):
    """A colour bar with its labels for map ``key`` of ``ob`` (renders with the scene): 32 coloured quads
    from the map's lowest to its highest value, the title with its unit, tick values, and a red swatch
    for 'no value' (see :func:`_legend_frame` for where)."""
    from vtcore.evaluate.colours import NO_VALUE, ramp

    data = ob.get("vtskin_legend_data", {}).get(key)
    if data is None:
        raise Cancel(f"{ob.name} has no {key} map: run Evaluate Skin first")
    remove_legend()
    coll = bpy.data.collections.new(LEGEND)
    context.scene.collection.children.link(coll)
    place, rot, h = _legend_frame(context, ob)
    w, n = 0.08 * h, 32
    ys = np.linspace(0.0, h, n + 1)
    v = np.concatenate([np.column_stack([np.zeros(n + 1), ys, np.zeros(n + 1)]),
                        np.column_stack([np.full(n + 1, w), ys, np.zeros(n + 1)])])
    quads = np.column_stack([np.arange(n), np.arange(n) + n + 1, np.arange(n) + n + 2, np.arange(n) + 1])
    me = bpy.data.meshes.new(f"{LEGEND} bar")
    bridge.write_mesh(me, v, np.vstack([quads[:, [0, 1, 2]], quads[:, [0, 2, 3]]]))
    rgba = np.column_stack([ramp(np.linspace(0, 1, n + 1)), np.ones(n + 1)])
    bridge.set_attribute(me, "vtskin_map_legend", srgb_to_linear(np.vstack([rgba, rgba])), "FLOAT_COLOR")
    mat = bpy.data.materials.new(f"{LEGEND} bar")
    nt = display.shader_nodes(mat)
    attr = nt.nodes.new("ShaderNodeAttribute")
    attr.attribute_name = "vtskin_map_legend"
    emit = nt.nodes.new("ShaderNodeEmission")
    nt.links.new(attr.outputs["Color"], emit.inputs["Color"])
    nt.links.new(emit.outputs["Emission"], nt.nodes.get("Material Output").inputs["Surface"])
    me.materials.append(mat)
    bar = _legend_object(coll, f"{LEGEND} bar", me, place, rot, (0, 0, 0))
    ticks = np.geomspace(data["lo"], data["hi"], 4) if data["log"] else np.linspace(data["lo"], data["hi"], 5)
    span = (np.log(ticks / data["lo"]) / np.log(data["hi"] / data["lo"]) if data["log"]
            else (ticks - data["lo"]) / max(data["hi"] - data["lo"], 1e-300))
    labels = [(f"{data['title']} ({data['unit']})", (0.0, 1.08 * h, 0.0))]
    labels += [(f"{tv:.3g}" + (" or more" if i == len(ticks) - 1 else ""), (1.4 * w, float(sv) * h - 0.02 * h, 0.0))
               for i, (tv, sv) in enumerate(zip(ticks, span))]
    import textwrap

    red_text = "\n".join(textwrap.wrap(f"red: {data['no_value']}", 26))
    labels.append((red_text, (1.4 * w, -0.16 * h, 0.0)))
    text = bpy.data.materials.new(f"{LEGEND} text")
    text.diffuse_color = (0.05, 0.05, 0.06, 1.0)
    display.shader_nodes(text).nodes.get("Principled BSDF").inputs["Base Color"].default_value = (0.02, 0.02, 0.02, 1)
    for i, (words, off) in enumerate(labels):
        cu = bpy.data.curves.new(f"{LEGEND} text {i}", "FONT")
        cu.body = words
        cu.size = 0.075 * h
        cu.materials.append(text)
        _legend_object(coll, f"{LEGEND} text {i}", cu, place, rot, off)
    swatch = bpy.data.meshes.new(f"{LEGEND} red")
    bridge.write_mesh(swatch, np.array([[0, 0, 0], [w, 0, 0], [w, w, 0], [0, w, 0.0]]), [[0, 1, 2], [0, 2, 3]])
    red = bpy.data.materials.new(f"{LEGEND} red")
    red.diffuse_color = (*NO_VALUE, 1.0)
    red_emit = display.shader_nodes(red)
    red_emit.nodes.get("Principled BSDF").inputs["Base Color"].default_value = (
        *srgb_to_linear(np.array([[*NO_VALUE, 1.0]]))[0, :3], 1.0)
    swatch.materials.append(red)
    _legend_object(coll, f"{LEGEND} red", swatch, place, rot, (0.0, -0.18 * h, 0.0))
    return bar


class VTSKIN_OT_map_legend(Op, bpy.types.Operator):
    """Put a colour bar with the shown map's units and range beside the mapped mesh (for renders)"""

    bl_idname = "vtskin.map_legend"
    bl_label = "Legend"

    def run(self, context):
        s = context.scene.vtskin
        ob = next((o for o in context.scene.objects if o.type == "MESH" and "vtskin_legend_data" in o), None)
        if ob is None:
            raise Cancel("No mesh has a design map: run Evaluate Skin first")
        build_legend(context, ob, s.map_show)
        return {"FINISHED"}


CLASSES = (VTSKIN_OT_evaluate_skin, VTSKIN_OT_clear_map, VTSKIN_OT_map_legend)
