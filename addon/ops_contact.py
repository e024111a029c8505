"""Contact operators: press the indenter on the skin for one frame or bake a frame range."""

from __future__ import annotations

import bpy
import numpy as np

from . import bake, bridge, display, skin
from .opbase import Cancel, Op, failing

def _contact_input(op, context):
    """(skin object, layout, triangles, indenter verts (own frame), faces, pose in skin frame) or an error string."""
    s = context.scene.vtskin
    ob = skin.skin_of(context)
    if ob is None or len(ob.data.vertices) == 0:
        return "Select a skin with taxels (lay a patch first)"
    ind = s.indenter
    if ind is None or ind.type != "MESH":
        return "Choose an indenter mesh object in the Contact panel"
    if s.thickness <= 0:
        return "The soft layer has zero thickness: set a thickness > 0 in the Soft layer panel"
    world, tri = bridge.read_mesh(ind)
    if len(tri) == 0:
        return f"The indenter {ind.name!r} has no faces"
    m_ind = bridge.rigid(bridge.matrix(ind))
    inv_ind = np.linalg.inv(m_ind)
    verts = world @ inv_ind[:3, :3].T + inv_ind[:3, 3]
    pose = np.linalg.inv(bridge.matrix(ob)) @ m_ind
    return ob, skin.read_layout(ob), skin.triangles(ob), verts, tri, pose


class VTSKIN_OT_simulate(Op, bpy.types.Operator):
    """Press the indenter onto the skin at the target force (current frame) and show the response"""

    bl_idname = "vtskin.simulate"
    bl_label = "Simulate Frame"

    def run(self, context):
        from vtcore.scene import interactive

        s = context.scene.vtskin
        got = _contact_input(self, context)
        if isinstance(got, str):
            raise Cancel(got)
        ob, layout, tri, verts, faces, pose = got
        with failing("Contact failed"):
            c = interactive.simulate(layout, tri, verts, faces, pose, thickness=s.thickness, material=s.material,
                                     force=s.force if s.use_force else None, counts_per_pa=s.sensor_gain(),
                                     edge_fraction=s.edge_fraction, geometry=s.geometry)
        me = ob.data
        bridge.set_attribute(me, "pressure", c.pressure)
        bridge.set_attribute(me, "response", c.response)
        bridge.set_attribute(me, "edge_response", c.edge_response, "FLOAT")
        bridge.set_attribute(me, "edge", c.edge)
        ob.vtskin.force = c.force
        display.ensure_display(ob)
        self.report({"INFO"}, f"{c.force:.3g} N, indentation {c.indentation * 1e3:.2f} mm, "
                    f"{int(c.edge.sum())} edge taxels")
        if c.warning:
            self.report({"WARNING"}, c.warning)
        return {"FINISHED"}


class VTSKIN_OT_bake(Op, bpy.types.Operator):
    """Simulate every frame of the range (indenter animation, animated force) and store it for playback"""

    bl_idname = "vtskin.bake"
    bl_label = "Bake Contact"

    def run(self, context):
        from vtcore.scene import interactive

        scene = context.scene
        s = scene.vtskin
        if s.frame_end < s.frame_start:
            raise Cancel(f"Empty frame range {s.frame_start}..{s.frame_end}")
        frames = np.arange(s.frame_start, s.frame_end + 1)
        current = scene.frame_current
        poses, forces = [], []
        got = None
        try:
            # Gather the animated input (poses, forces): frame_set evaluates the animation.
            for f in frames:
                scene.frame_set(int(f))
                got = _contact_input(self, context)
                if isinstance(got, str):
                    break
                poses.append(got[5])
                forces.append(s.force)
        finally:
            scene.frame_set(current)
        if isinstance(got, str):
            raise Cancel(got)
        ob, layout, tri, verts, faces, _ = got
        wm = context.window_manager
        wm.progress_begin(0, len(frames))
        try:
            with failing("Bake failed"):
                res = interactive.bake(layout, tri, verts, faces, np.stack(poses), thickness=s.thickness,
                                       material=s.material, forces=np.array(forces) if s.use_force else None,
                                       counts_per_pa=s.sensor_gain(), edge_fraction=s.edge_fraction,
                                       callback=lambda i, t: wm.progress_update(i + 1), geometry=s.geometry)
        finally:
            wm.progress_end()
        if "edge" not in ob.data.attributes:
            bridge.set_attribute(ob.data, "edge", np.zeros(len(layout), bool))
        bake.store(ob, frames, pressure=res["pressure"], response=res["response"], edge=res["edge"])
        display.ensure_display(ob)
        bake.apply(ob, current)
        self.report({"INFO"}, f"Baked {len(frames)} frames on {ob.name}")
        if res.get("warning"):
            self.report({"WARNING"}, res["warning"])
        return {"FINISHED"}


class VTSKIN_OT_clear_bake(Op, bpy.types.Operator):
    """Remove the baked contact of the skin"""

    bl_idname = "vtskin.clear_bake"
    bl_label = "Clear Bake"

    def run(self, context):
        ob = skin.skin_of(context)
        if ob is None or ob.vtskin.cache is None:
            raise Cancel("The selected skin has no baked contact")
        bake.clear(ob)
        return {"FINISHED"}


class VTSKIN_OT_add_fingerpad(Op, bpy.types.Operator):
    """Add a finger pad (a capsule lying on the skin, as a real one-finger press) and make it the indenter"""

    bl_idname = "vtskin.add_fingerpad"
    bl_label = "Add Finger Pad"
    bl_options = {"REGISTER", "UNDO"}

    radius: bpy.props.FloatProperty(name="Radius", default=0.008, min=1e-4, max=0.1, unit="LENGTH",
                                    description="Half the pad's width (an adult fingertip: ~8 mm)")
    length: bpy.props.FloatProperty(name="Length", default=0.04, min=2e-4, max=0.5, unit="LENGTH",
                                    description="Tip to tip, at least twice the radius")
    bend_radius: bpy.props.FloatProperty(name="Bend Radius", default=0.0, min=0.0, max=10.0, unit="LENGTH",
                                         description="0: straight; else the radius its axis bends to "
                                                     "(to lie along a convex skin of radius R: R + layer + radius)")

    def run(self, context):
        from vtcore.scene import interactive

        with failing("Could not build the finger pad"):
            verts, faces = interactive.indenter_mesh("fingerpad", radius=self.radius, length=self.length,
                                                     bend_radius=self.bend_radius)
        # built pressed face up, resting on z = 0: turned over (pi about x) it faces a skin below it,
        # its back at the 3D cursor
        verts = verts * np.array([1.0, -1.0, -1.0])
        m = np.eye(4)
        m[:3, 3] = np.asarray(context.scene.cursor.location, float)
        ob = skin.new_object(context, "FingerPad", role="NONE", matrix=m)
        bridge.write_mesh(ob.data, verts, faces)
        context.scene.vtskin.indenter = ob
        self.report({"INFO"}, f"Finger pad {self.radius * 2e3:.3g} x {self.length * 1e3:.3g} mm is the indenter")
        return {"FINISHED"}


CLASSES = (VTSKIN_OT_simulate, VTSKIN_OT_bake, VTSKIN_OT_clear_bake, VTSKIN_OT_add_fingerpad)
