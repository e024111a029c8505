"""Robot operators: Import Robot (one object per link, parented as the kinematic tree), Import
Layout (a calibrated layout onto the active link object, ids intact), Export Skinned Robot (the
robot's own URDF or MJCF with the skins of its links in it), Skin Whole Robot (every link filled by
``vtcore.robot.skin_robot``, files written to a folder)."""

from __future__ import annotations

from pathlib import Path

import bpy

from . import bridge, display, skin
from .opbase import Cancel, Op, fail, failing, file_path, skin_frame


def _robot_collection(context, name):
    coll = bpy.data.collections.new(name)
    (context.scene.collection).children.link(coll)
    return coll


class VTSKIN_OT_import_robot(Op, bpy.types.Operator):
    """Import a URDF or MJCF robot: one mesh object per link at the panel's joint values, parented as
    the kinematic tree, each carrying its link name and robot file"""

    bl_idname = "vtskin.import_robot"
    bl_label = "Import Robot"

    filepath: bpy.props.StringProperty(name="Robot", subtype="FILE_PATH",
                                       description="URDF or MJCF file (empty: the panel's)")

    def run(self, context):
        from vtcore.robot import exposure
        from vtcore.scene import interactive

        s = context.scene.vtskin
        path = file_path(self, s.robot_file, "robot file")
        with failing("Cannot import the robot"):
            joints = interactive.parse_joint_values(s.robot_joints)
            packages = interactive.parse_packages(s.robot_packages)
            robot = interactive.import_robot(path, geometry=s.robot_geometry, joints=joints, packages=packages)
        coll = _robot_collection(context, robot.name)
        objects = {}
        for part in robot.links:  # parents come before children in a URDF's tree only by chance: two passes
            me = bpy.data.meshes.new(part.name)
            if len(part.faces):
                bridge.write_mesh(me, part.vertices, part.faces)
                if part.exposure is not None:  # the exposed surface, coloured; its legend in the Robot panel
                    display.show_exposure(me, exposure.face_colours(part.exposure))
            ob = bpy.data.objects.new(part.name, me)
            coll.objects.link(ob)
            ob.vtskin.link, ob.vtskin.robot_file, ob.vtskin.geometry = part.name, str(robot.path), robot.geometry
            ob.vtskin.exposure_legend = "\n".join(part.legend)
            objects[part.name] = ob
        parent = {p.name: p.parent for p in robot.links}

        def depth(name):
            return 0 if parent.get(name) not in objects else 1 + depth(parent[name])

        for part in sorted(robot.links, key=lambda p: depth(p.name)):  # a parent placed before its children
            ob = objects[part.name]
            if part.parent in objects:
                ob.parent = objects[part.parent]
                ob.matrix_parent_inverse.identity()
            ob.matrix_world = bridge.to_matrix(part.matrix)
        s.robot_file = str(robot.path)
        missing = [f"{p.name}: {p.note}" for p in robot.links if p.note and p.note != "no geometry"
                   and not len(p.faces)]
        self.report({"WARNING"} if missing or robot.notes else {"INFO"},
                    f"{robot.name}: {len(robot.links)} links" + (f"; without a mesh: {'; '.join(missing)}"
                                                                 if missing else "")
                    + "".join(f"; {n}" for n in robot.notes))
        return {"FINISHED"}


def _link_object(context):
    ob = context.active_object
    if ob is None or ob.type != "MESH" or skin.is_taxels(ob):
        raise Cancel("Select the link object (or mesh) to put the layout on (the active object)")
    return ob


class VTSKIN_OT_import_layout(Op, bpy.types.Operator):
    """Put a calibrated layout file (json, icub, cyskin, csv, ply) on the active link object, its taxel
    ids intact, so that a recording of that skin replays on it"""

    bl_idname = "vtskin.import_layout"
    bl_label = "Import Layout"

    filepath: bpy.props.StringProperty(name="Layout", subtype="FILE_PATH",
                                       description="Layout file (empty: the panel's)")

    def run(self, context):
        from vtcore.scene import interactive

        s = context.scene.vtskin
        ee = _link_object(context)
        path = file_path(self, s.layout_file, "layout file")
        fmt = None if s.layout_format == "AUTO" else s.layout_format
        units = None if s.layout_units == "AUTO" else s.layout_units
        with failing("Cannot import the layout"):
            edit = interactive.import_layout(path, fmt, units=units, link=skin.frame_name(ee))
        frame = skin_frame(ee)
        ob = skin.new_object(context, f"{ee.name} skin", matrix=frame)
        ob.vtskin.end_effector = ee
        ob.vtskin.source = str(path)
        ob.vtskin.module_type = str(edit.layout.meta.get("module_type") or "")
        skin.follow(ob, ee)
        skin.write_layout(ob, edit.layout, edit.triangles)
        ob.vtskin.report = "\n".join(edit.report["notes"])
        display.ensure_display(ob)
        self.report({"INFO"}, f"{ob.name}: {len(edit.layout)} taxels from {Path(path).name}"
                    + (f" ({'; '.join(edit.report['notes'])})" if edit.report["notes"] else ""))
        return {"FINISHED"}


def _skins_of_robot(context, robot_file):
    """The skins laid on link objects of the robot ``robot_file``, in the scene's order."""
    out = []
    for ob in context.scene.objects:
        ee = ob.vtskin.end_effector if skin.is_taxels(ob) else None
        if ee is not None and ee.vtskin.link and bpy.path.abspath(ee.vtskin.robot_file) == robot_file \
                and len(ob.data.vertices):
            out.append(ob)
    return out


class VTSKIN_OT_export_robot(Op, bpy.types.Operator):
    """Write the robot's own URDF or MJCF with the skins laid on its links: one fixed frame per taxel
    (URDF), or sites and touch sensors in the link's body (MJCF)"""

    bl_idname = "vtskin.export_robot"
    bl_label = "Export Skinned Robot"
    bl_options = {"REGISTER"}

    filepath: bpy.props.StringProperty(name="File", subtype="FILE_PATH",
                                       description="Output .urdf or .xml (empty: the panel's)")

    def run(self, context):
        from vtcore.scene import interactive

        s = context.scene.vtskin
        active = context.active_object
        robot_file = (active.vtskin.robot_file if active is not None and active.vtskin.link else "") or s.robot_file
        robot_file = bpy.path.abspath(robot_file)
        if not robot_file:
            raise Cancel("No robot: import one first (Import Robot)")
        out = file_path(self, s.skinned_path, "output file")
        obs = _skins_of_robot(context, robot_file)
        if not obs:
            raise Cancel(f"No skin on a link of {Path(robot_file).name}: lay, fill or import one on a link object")
        opts = {} if s.skinned_format == "urdf" else {"footprint": s.skinned_footprint, "pad": s.skinned_pad}
        with failing("Export failed"):
            packages = interactive.parse_packages(s.robot_packages)
            records = interactive.export_skinned_robot(robot_file, [skin.read_layout(o) for o in obs], out,
                                                       s.skinned_format, prefix=s.skinned_prefix or None,
                                                       packages=packages, **opts)
        self.report({"INFO"}, f"Wrote {out}: " + ", ".join(f"{r['taxels']} taxels on {r['link']}" for r in records))
        for r in records:  # vtcore's contact check of the written model: taxels no touch can reach
            if r.get("unreadable"):
                first = r["unreadable"][0]
                self.report({"WARNING"}, f"{len(r['unreadable'])} of {r['taxels']} taxels on {r['link']} cannot "
                                         f"read ({first}: {r['unreadable_why'][first]})")
        return {"FINISHED"}


class VTSKIN_OT_skin_robot(Op, bpy.types.Operator):
    """Fill every link of the panel's robot that can carry a module (in parallel over links) and write
    the layouts, the skinned robot (URDF, MJCF) and report.md to the panel's folder"""

    bl_idname = "vtskin.skin_robot"
    bl_label = "Skin Whole Robot"
    bl_options = {"REGISTER"}

    # From the UI it runs as a modal operator: vtcore skins the robot in a worker thread (vtcore's Job,
    # which starts the worker processes) while a timer shows its progress in the status bar, and Esc
    # stops it (finished links stay written). In background mode and from execute() it runs to the end.

    def _gather(self, context) -> dict:
        from vtcore.scene import interactive

        s = context.scene.vtskin
        robot_file = bpy.path.abspath(s.robot_file)
        if not robot_file:
            raise Cancel("No robot: choose a URDF or MJCF file (Robot)")
        out = bpy.path.abspath(s.skin_robot_dir)
        if not out:
            raise Cancel("Choose the folder to write the skins to (Folder)")
        with failing("Cannot skin the robot"):
            packages = interactive.parse_packages(s.robot_packages)
        return {"robot_path": robot_file, "out": out, "geometry": s.robot_geometry, "packages": packages,
                "bars": False}

    def _done(self, rep) -> set:
        c = rep["counts"]
        bad = [f"{r['link']}: {r['reason']}" for r in rep["links"] if r["status"] in ("refused", "failed")]
        self.report({"WARNING"} if c["failed"] else {"INFO"},
                    f"{rep['modules']} modules on {c['ok']} links ({c['refused']} refused, {c['failed']} failed) "
                    f"in {rep['seconds']:.0f} s: {Path(rep['robot']).name} skinned, report.md written")
        for line in bad:
            self.report({"INFO"}, line)
        return {"FINISHED"}

    def run(self, context):
        from vtcore.robot.skin_robot import skin_robot

        kw = self._gather(context)
        with failing("Cannot skin the robot"):
            rep = skin_robot(**kw)
        return self._done(rep)

    def invoke(self, context, event):
        from vtcore.robot.skin_robot import skin_robot
        from vtcore.scene import interactive

        if bpy.app.background or context.window is None:
            return self.execute(context)
        try:
            self._job = interactive.Job(skin_robot, **self._gather(context))
        except Cancel as exc:
            return fail(self, str(exc), exc.details)
        wm = context.window_manager
        self._timer = wm.event_timer_add(0.2, window=context.window)
        wm.progress_begin(0, 100)
        wm.modal_handler_add(self)
        return {"RUNNING_MODAL"}

    def _status(self, context, text):
        context.window_manager.progress_update(int(100 * self._job.fraction))
        if context.workspace is not None:
            context.workspace.status_text_set(text)

    def modal(self, context, event):
        if event.type == "ESC":
            self._job.cancel()  # the links written so far stay; the report says which were stopped
        if event.type != "TIMER" or not self._job.done:
            if event.type == "TIMER":
                self._status(context, f"Skinning the robot: {100 * self._job.fraction:.0f} % (Esc to stop)")
            return {"RUNNING_MODAL"}
        context.window_manager.event_timer_remove(self._timer)
        context.window_manager.progress_end()
        self._status(context, None)
        try:
            with failing("Cannot skin the robot"):
                rep = self._job.result()
        except Cancel as exc:
            return fail(self, str(exc), exc.details)
        return self._done(rep)


CLASSES = (VTSKIN_OT_import_robot, VTSKIN_OT_import_layout, VTSKIN_OT_export_robot, VTSKIN_OT_skin_robot)
