"""Skin layout operators: lay or fill a patch, remove and move modules, export the layout."""

from __future__ import annotations

import bpy
import numpy as np

from . import bake, bridge, display, skin
from .opbase import (Cancel, Op, fail, failing, mesh_in_frame, need_skin, patch_direction, selection_anchor,
                     skin_frame, to_frame, triangle_faces)

def _apply_report(ob, edit):
    """The whole skin's report and warnings onto ``ob`` (the panel's report box shows them)."""
    from vtcore.layout.summary import report_lines

    report = edit.report
    s = ob.vtskin
    s.strain_max = 100.0 * float(report.get("strain_max") or 0.0)
    s.strain_mean = 100.0 * float(report.get("strain_mean") or 0.0)
    s.overlaps = int(report.get("overlaps") or 0)
    cov = report.get("coverage")
    s.coverage = -1.0 if cov is None else 100.0 * float(cov)
    s.report = "\n".join(report_lines(report))
    s.warnings = "\n".join(edit.warnings)


def _carry(ob, edit):
    """Per-taxel results of the skin before the edit kept for the taxels that stayed where they were
    (``edit.kept``: old index, -1 for new or moved taxels, whose results are zero); the bake cache
    too. Returns (pressure, response, edge) for ``skin.write_layout``."""
    n = len(edit.layout)
    kept = np.asarray(edit.kept if edit.kept is not None else np.full(n, -1), np.int64)
    me = ob.data if ob is not None else None
    out = []
    for name, kind in (("pressure", float), ("response", float), ("edge", bool)):
        old = bridge.get_attribute(me, name) if me is not None and name in me.attributes else None
        vals = np.zeros(n, kind)
        if old is not None and len(old):
            ok = (kept >= 0) & (kept < len(old))
            vals[ok] = np.asarray(old)[kept[ok]]
        out.append(vals)
    if ob is not None and ob.vtskin.cache is not None:
        bake.remap(ob, kept)
    return out


def _write_edit(context, ee, skin_ob, frame, edit, module):
    """Write a LayoutEdit to ``skin_ob`` (created on ``ee`` if None). Returns the object."""
    pressure, response, edge = _carry(skin_ob, edit)
    if skin_ob is None:
        skin_ob = skin.new_object(context, f"{ee.name} skin", matrix=frame)
        skin_ob.vtskin.end_effector = ee
        skin_ob.vtskin.module_type = module
        skin.follow(skin_ob, ee)
    skin.write_layout(skin_ob, edit.layout, edit.triangles, pressure=pressure, response=response, edge=edge)
    n = len(edit.layout)
    bridge.set_attribute(skin_ob.data, "strain", np.zeros(n) if edit.strain is None else edit.strain)
    bridge.set_attribute(skin_ob.data, "overlap", np.zeros(n) if edit.overlap is None else edit.overlap.astype(float))
    _apply_report(skin_ob, edit)
    display.ensure_display(skin_ob)
    return skin_ob


def _say(op, ob, edit, what):
    """The edit's warnings as WARNING reports (the status bar and the Info log), then one INFO line."""
    for line in edit.warnings:
        op.report({"WARNING"}, line)
    op.report({"INFO"}, f"{ob.name}: {what}; {len(edit.layout)} taxels, max strain {ob.vtskin.strain_max:.1f} %, "
                        f"{ob.vtskin.overlaps} overlaps")


def _link_input(ee, s):
    """A Fill on a link object of an imported robot: the robot, link and geometry it holds (vtcore
    fills the link's exposed surface only, as ``vtcore layout fill ROBOT --link``); None for any other
    mesh (filled as it is)."""
    from vtcore.scene import interactive

    if not ee.vtskin.link or not ee.vtskin.robot_file:
        return None
    with failing("Cannot lay the patch"):
        packages = interactive.parse_packages(s.robot_packages)
    return {"robot": bpy.path.abspath(ee.vtskin.robot_file), "link": ee.vtskin.link, "geometry": ee.vtskin.geometry,
            "packages": packages, "anywhere": s.fill_anywhere}


def _show_exposure(op, ee, ob, shown):
    """The exposure a Fill on a link judged: ``ee``'s faces coloured by it with its legend (the Robot
    panel), what the fill left out in the skin's report and the Info log."""
    from vtcore.robot import exposure

    faces = triangle_faces(ee)
    if shown.reason is not None and len(faces) == len(shown.reason):  # (a modifier changes the triangles)
        colours = np.zeros((len(ee.data.polygons), 4))
        colours[faces] = exposure.face_colours(shown.reason)  # per triangle -> its polygon
        display.show_exposure(ee.data, colours)
        ee.vtskin.exposure_legend = "\n".join(shown.legend)
    ob.vtskin.report = "\n".join([ob.vtskin.report, *shown.excluded]).strip("\n")
    for line in shown.excluded:
        op.report({"INFO"}, f"{ee.name}: {line}")


def _fill_settings(s):
    """lay_patch's strain limit, crease angle, islands and force from the scene's settings."""
    return dict(max_strain=(s.max_strain / 100.0) or None, crease_angle=float(np.degrees(s.crease_angle)),
                islands=s.islands, force=s.keep_refused)


class VTSKIN_OT_lay_patch(Op, bpy.types.Operator):
    """Conform a patch of modules onto the active mesh at the 3D cursor or the selected faces"""

    bl_idname = "vtskin.lay_patch"
    bl_label = "Lay Patch"

    fill: bpy.props.BoolProperty(name="Fill region", default=False,
                                 description="Tile the selected faces with whole modules")

    def _gather(self, context):
        """Everything the placement needs, read from the scene (no writes): the end-effector,
        the skin already on it (or None), the skin frame and lay_patch's arguments."""
        from vtcore.layout import get_module

        s = context.scene.vtskin
        ee = context.active_object
        if ee is None or ee.type != "MESH" or skin.is_taxels(ee):
            raise Cancel("Select the end-effector mesh to lay the skin on (the active object)")
        existing = skin.skin_of(context)
        frame = skin_frame(existing) if existing is not None else skin_frame(ee)
        verts, tri = mesh_in_frame(ee, frame)
        if len(tri) == 0:
            raise Cancel(f"{ee.name!r} has no faces: a skin needs a surface")
        region, extra = None, {}
        by_selection = (self.fill and s.fill_region == "SELECTED") or (not self.fill and s.place_at == "SELECTED")
        if by_selection:
            at, sel = selection_anchor(ee, frame)
            if at is None:
                raise Cancel(f"No faces of {ee.name!r} are selected: select the faces to cover in Edit Mode")
            if self.fill:
                region = np.isin(triangle_faces(ee), sel)
        else:
            at = to_frame(frame, context.scene.cursor.location)
        if self.fill and s.fill_region == "RADIUS":
            extra["radius"] = s.fill_radius
        elif self.fill and s.fill_region == "FACING":
            at_sel, sel = selection_anchor(ee, frame)
            if at_sel is not None:  # the faces of the selection that face that way
                region, at = np.isin(triangle_faces(ee), sel), at_sel
            # the direction is given in the end-effector's frame: into the skin frame
            rot = np.linalg.inv(frame)[:3, :3] @ bridge.matrix(ee)[:3, :3]
            extra.update(facing=rot @ np.asarray(s.facing, float), within=float(np.degrees(s.within)))
        patch = f"strip:{s.strip_modules}" if s.patch == "strip" else s.patch
        base = skin.read_layout(existing) if existing is not None and len(existing.data.vertices) else None
        with failing("Cannot lay the patch"):
            module = get_module(s.module, mirror=s.mirror)
        args = dict(vertices=verts, triangles=tri, at=at, existing=base, patch=patch, module=module,
                    direction=patch_direction(s.rotation), offset=s.offset, method=s.method, fill_region=region,
                    max_faces=s.solve_faces or None, link=_link_input(ee, s) if self.fill else None,
                    **extra, **_fill_settings(s))
        return ee, existing, frame, args

    def _write(self, context, ee, existing, frame, edit):
        ob = _write_edit(context, ee, existing, frame, edit, context.scene.vtskin.module)
        if edit.exposure is not None:  # a Fill on a robot's link
            _show_exposure(self, ee, ob, edit.exposure)
        _say(self, ob, edit, "filled" if self.fill else "patch laid")
        return {"FINISHED"}

    def run(self, context):
        from vtcore.scene import interactive

        ee, existing, frame, args = self._gather(context)
        with failing("Cannot lay the patch"):
            edit = interactive.lay_patch(**args)
        return self._write(context, ee, existing, frame, edit)

    # A fill from the UI runs as a modal operator: vtcore fills in a worker thread (vtcore's Job)
    # while a timer shows its progress on the cursor and in the status bar, and Esc cancels it
    # (the fill stops at its next progress call; the scene is left as it was). In background
    # mode (the bpy wheel, scripts: no event loop) and from execute() it runs to completion.

    def invoke(self, context, event):
        if not self.fill or bpy.app.background or context.window is None:
            return self.execute(context)
        try:
            self._start(context)
        except Cancel as exc:
            return fail(self, str(exc), exc.details)
        context.window_manager.modal_handler_add(self)
        return {"RUNNING_MODAL"}

    def _start(self, context):
        """Gather the input, start the fill in a Job, the timer and the progress display."""
        from vtcore.scene import interactive

        self._input = self._gather(context)
        self._job = interactive.Job(interactive.lay_patch, **self._input[3])
        wm = context.window_manager
        self._timer = wm.event_timer_add(0.1, window=context.window)
        wm.progress_begin(0, 100)
        self._status(context)

    def _status(self, context, text=None):
        if text is None:
            text = f"Filling selected faces: {100 * self._job.fraction:.0f} % (Esc to cancel)"
        context.window_manager.progress_update(int(100 * self._job.fraction))
        if context.workspace is not None:
            context.workspace.status_text_set(text)

    def _end(self, context):
        wm = context.window_manager
        wm.event_timer_remove(self._timer)
        wm.progress_end()
        if context.workspace is not None:
            context.workspace.status_text_set(None)

    def modal(self, context, event):
        if event.type == "ESC":
            # the worker stops at its next progress call and its result is dropped: no need to wait
            self._job.cancel()
            self._end(context)
            self.report({"WARNING"}, "Fill cancelled: the skin is unchanged")
            return {"CANCELLED"}
        if event.type != "TIMER" or not self._job.done:
            if event.type == "TIMER":
                self._status(context)
            return {"RUNNING_MODAL"}  # other input waits until the fill is done or cancelled
        self._end(context)
        try:
            with failing("Cannot lay the patch"):
                edit = self._job.result()
        except Cancel as exc:
            return fail(self, str(exc), exc.details)
        ee, existing, frame, _ = self._input
        return self._write(context, ee, existing, frame, edit)


def _skin_layout(ob):
    """The skin's layout with what the last edit knew of it (module type, coverage)."""
    layout = skin.read_layout(ob)
    layout.meta["module_type"] = ob.vtskin.module_type
    if ob.vtskin.coverage >= 0:
        layout.meta["placement"] = {"coverage": ob.vtskin.coverage / 100.0}
    return layout


def _selected_modules(ob):
    if ob.mode == "EDIT":
        ob.update_from_editmode()
    sel = bridge.selected_vertices(ob.data)
    if not len(sel) or "module_id" not in ob.data.attributes:
        return np.zeros(0, np.int64)
    return np.unique(bridge.get_attribute(ob.data, "module_id")[sel])


class VTSKIN_OT_remove_module(Op, bpy.types.Operator):
    """Remove the modules of the selected taxels (or the given module) from the skin"""

    bl_idname = "vtskin.remove_module"
    bl_label = "Remove Module"

    module: bpy.props.IntProperty(name="Module", default=-1, min=-1,
                                  description="Module id to remove (-1: those of the selected taxels)")

    def run(self, context):
        from vtcore.scene import interactive

        ob = need_skin(context, "Select a skin (taxel object)")
        mods = [self.module] if self.module >= 0 else _selected_modules(ob)
        layout = _skin_layout(ob)
        with failing("Cannot remove"):
            edit = interactive.remove_modules(layout, mods, module=ob.vtskin.module_type)
        edit.layout.meta.clear()
        _write_edit(context, ob.vtskin.end_effector, ob, None, edit, ob.vtskin.module_type)
        _say(self, ob, edit, f"removed module(s) {', '.join(map(str, np.asarray(mods).tolist()))}")
        return {"FINISHED"}


class VTSKIN_OT_move_module(Op, bpy.types.Operator):
    """Move a module of the skin to the 3D cursor (re-conformed to the surface there)"""

    bl_idname = "vtskin.move_module"
    bl_label = "Move Module to Cursor"

    module: bpy.props.IntProperty(name="Module", default=-1, min=-1,
                                  description="Module id to move (-1: the one of the selected taxels)")

    def run(self, context):
        from vtcore.scene import interactive

        ob = need_skin(context, "Select a skin (taxel object)")
        ee = ob.vtskin.end_effector
        if ee is None or ee.type != "MESH":
            raise Cancel(f"{ob.name!r} has no end-effector mesh to move on")
        mods = [self.module] if self.module >= 0 else _selected_modules(ob)
        if len(mods) != 1:
            raise Cancel(f"Select the taxels of exactly one module (got {len(mods)} modules)")
        frame = bridge.matrix(ob)
        verts, tri = mesh_in_frame(ee, frame)
        layout = _skin_layout(ob)
        s = context.scene.vtskin
        with failing("Cannot move"):
            edit = interactive.move_module(layout, int(mods[0]), verts, tri,
                                           to_frame(frame, context.scene.cursor.location),
                                           patch_direction(s.rotation), s.offset, module_type=ob.vtskin.module_type,
                                           force=s.keep_refused, max_strain=(s.max_strain / 100.0) or None)
        _write_edit(context, ee, ob, frame, edit, ob.vtskin.module_type)
        _say(self, ob, edit, f"moved module {int(mods[0])}")
        return {"FINISHED"}


class VTSKIN_OT_export(Op, bpy.types.Operator):
    """Write the skin layout in a calibrated layout format"""

    bl_idname = "vtskin.export"
    bl_label = "Export Layout"
    bl_options = {"REGISTER"}

    filepath: bpy.props.StringProperty(name="File", subtype="FILE_PATH")

    def run(self, context):
        from vtcore.scene import interactive

        s = context.scene.vtskin
        ob = need_skin(context, "Select a skin with taxels to export", taxels=True)
        path = bpy.path.abspath(self.filepath or s.export_path)
        if not path:
            raise Cancel("No export file given")
        transform = frame = None
        if s.export_frame is not None and s.export_frame != ob:  # the taxels written in that object's frame
            transform = np.linalg.inv(skin_frame(s.export_frame)) @ bridge.matrix(ob)
            frame = skin.frame_name(s.export_frame)
        with failing("Export failed"):
            out = interactive.export_layout(skin.read_layout(ob), skin.triangles(ob), path, s.export_format,
                                            transform, frame)
        self.report({"INFO"}, f"Wrote {out}")
        return {"FINISHED"}


CLASSES = (VTSKIN_OT_lay_patch, VTSKIN_OT_remove_module, VTSKIN_OT_move_module, VTSKIN_OT_export)
