"""Sidebar panels (View3D > Sidebar > Skin). Panels only draw; operators do the work.

Most panels are a column of ``Scene.vtskin`` properties and one button: they say so
with ``props`` and ``button`` and inherit ``draw``; panels with more to show add it in
``draw_more`` (between the properties and the button).
"""

from __future__ import annotations

import bpy


class _Panel:
    bl_space_type = "VIEW_3D"
    bl_region_type = "UI"
    bl_category = "Skin"
    props: tuple = ()  # names of Scene.vtskin properties, one per row
    button: tuple | None = None  # (operator idname, icon, {operator property: value})

    def draw(self, context):
        s = context.scene.vtskin
        col = self.layout.column()
        for name in self.props:
            col.prop(s, name)
        self.draw_more(col, s, context)
        if self.button is not None:
            _button(col, *self.button)

    def draw_more(self, col, s, context):
        """Rows after ``props`` and before ``button`` (none by default)."""


def _button(layout, idname, icon, settings=None, text=None):
    """One operator button, with its operator properties set."""
    op = layout.operator(idname, icon=icon) if text is None else layout.operator(idname, text=text, icon=icon)
    for key, value in (settings or {}).items():
        setattr(op, key, value)
    return op


def _row(col, s, *names, enabled=True):
    """Properties ``names`` of ``s`` side by side on one row (greyed out unless ``enabled``)."""
    row = col.row(align=True)
    row.enabled = enabled
    for name in names:
        row.prop(s, name)
    return row


def _skin(context):
    from .skin import skin_of

    return skin_of(context)


class VTSKIN_PT_robot(_Panel, bpy.types.Panel):
    bl_idname = "VTSKIN_PT_robot"
    bl_label = "Robot"
    props = ("robot_file", "robot_geometry", "robot_joints", "robot_packages")

    def draw_more(self, col, s, context):
        _button(col, "vtskin.import_robot", "IMPORT")
        ob = context.active_object
        if ob is not None and ob.vtskin.link:
            col.label(text=f"Link {ob.vtskin.link} ({ob.vtskin.geometry})")
            if ob.vtskin.exposure_legend:  # the face colours Import Robot gave the link
                box = col.box()
                for line in ob.vtskin.exposure_legend.splitlines():
                    box.label(text=line)
        col.separator()
        col.prop(s, "layout_file")
        _row(col, s, "layout_format", "layout_units")
        _button(col, "vtskin.import_layout", "IMPORT")
        col.separator()
        col.prop(s, "skinned_path")
        _row(col, s, "skinned_format", "skinned_prefix")
        _row(col, s, "skinned_footprint", "skinned_pad", enabled=s.skinned_format == "mjcf")
        _button(col, "vtskin.export_robot", "EXPORT")
        col.separator()
        col.prop(s, "skin_robot_dir")
        _button(col, "vtskin.skin_robot", "MOD_SKIN")


class VTSKIN_PT_layout(_Panel, bpy.types.Panel):
    bl_idname = "VTSKIN_PT_layout"
    bl_label = "Skin layout"
    def draw_more(self, col, s, context):
        _row(col, s, "module", "mirror")
        _row(col, s, *(("patch", "strip_modules") if s.patch == "strip" else ("patch",)))
        for name in ("place_at", "rotation", "offset", "method", "solve_faces"):
            col.prop(s, name)
        _button(col, "vtskin.lay_patch", "MESH_ICOSPHERE", {"fill": False})
        fill = col.box()
        fill.prop(s, "fill_region")
        if s.fill_region == "RADIUS":
            fill.prop(s, "fill_radius")
        elif s.fill_region == "FACING":
            _row(fill, s, "facing")
            fill.prop(s, "within")
        _row(fill, s, "islands")
        ob = context.active_object
        if ob is not None and ob.vtskin.link:  # a robot's link: exposed surface only unless this
            fill.prop(s, "fill_anywhere")
        fill.prop(s, "crease_angle")
        _button(fill, "vtskin.lay_patch", "MOD_TRIANGULATE", {"fill": True}, text="Fill")
        _row(col, s, "max_strain", "keep_refused")
        row = col.row(align=True)
        _button(row, "vtskin.remove_module", "X")
        _button(row, "vtskin.move_module", "PIVOT_CURSOR")
        ob = _skin(context)
        if ob is not None:
            box = col.box()
            v = ob.vtskin
            box.label(text=f"{ob.name}: {len(ob.data.vertices)} taxels")
            # vtcore words the placement report (the same lines as `vtcore layout place`)
            for line in v.report.splitlines():
                box.label(text=line[:1].upper() + line[1:])
            for line in v.warnings.splitlines():  # what the last edit warned about, not only in a terminal
                box.label(text=line[:1].upper() + line[1:], icon="ERROR")
            draw_legend(box, ob)


def draw_legend(layout, ob):
    """Colour by, the colour ramp as drawn on the taxels and what its ends mean, with units."""
    from . import display

    v = ob.vtskin
    layout.prop(v, "color_by")
    for line in display.legend_lines(ob):
        layout.label(text=line)
    ramp = display.ramp_node(ob)
    if ramp is not None:
        layout.template_color_ramp(ramp, "color_ramp", expand=False)
    layout.prop(v, "show_ids")


class VTSKIN_PT_layer(_Panel, bpy.types.Panel):
    bl_idname = "VTSKIN_PT_layer"
    bl_label = "Soft layer"
    props = ("thickness", "material")


def _sensor_line(gain) -> str:
    """The sensor every operator simulates, as vtcore names it (a bad profile: its error, shown)."""
    from vtcore.scene import interactive

    try:
        return interactive.sensor_summary(gain)
    except ValueError as exc:
        return str(exc)


class VTSKIN_PT_contact(_Panel, bpy.types.Panel):
    bl_idname = "VTSKIN_PT_contact"
    bl_label = "Contact"
    props = ("indenter", "geometry")

    def draw_more(self, col, s, context):
        _button(col, "vtskin.add_fingerpad", "HAND")
        row = col.row(align=True)
        row.prop(s, "use_force")
        _row(row, s, "force", enabled=s.use_force)
        row = col.row(align=True)
        row.prop(s, "gain_override")
        _row(row, s, "counts_per_pa", enabled=s.gain_override)
        col.label(text=_sensor_line(s.sensor_gain()))
        _button(col, "vtskin.simulate", "PLAY")
        _row(col, s, "frame_start", "frame_end")
        row = col.row(align=True)
        _button(row, "vtskin.bake", "REC")
        _button(row, "vtskin.clear_bake", "TRASH")
        ob = _skin(context)
        if ob is not None and ob.vtskin.cache is not None:
            col.label(text=f"Baked frames {ob.vtskin.bake_start}..{ob.vtskin.bake_end}")
        row = col.row(align=True)
        row.prop(s, "live_touch", toggle=True, icon="HAND")
        row.prop(s, "live_model", text="")
        if s.live_touch and s.live_note:
            col.label(text=s.live_note[:120], icon="INFO")


class VTSKIN_PT_evaluate(_Panel, bpy.types.Panel):
    bl_idname = "VTSKIN_PT_evaluate"
    bl_label = "Design maps"
    props = ("map_reference_force", "map_probe", "map_spacing", "map_margin", "map_two_point")

    def draw_more(self, col, s, context):
        row = col.row(align=True)
        _button(row, "vtskin.evaluate_skin", "SHADING_RENDERED")
        _button(row, "vtskin.clear_map", "TRASH")
        col.prop(s, "map_show")
        ob = _skin(context)
        ee = ob.vtskin.end_effector if ob is not None else None
        if ee is not None and ee.vtskin.map_legend:
            box = col.box()
            for line in ee.vtskin.map_legend.splitlines():
                box.label(text=line)
            _button(box, "vtskin.map_legend", "COLOR")


class VTSKIN_PT_replay(_Panel, bpy.types.Panel):
    bl_idname = "VTSKIN_PT_replay"
    bl_label = "Replay"
    props = ("recording_file", "recording_codec")

    def draw_more(self, col, s, context):
        if s.recording_codec == "icub":
            col.prop(s, "recording_boards")
        col.prop(s, "replay_rate")
        _row(col, s, "baseline", "baseline_rows")
        col.prop(s, "min_response")
        _button(col, "vtskin.load_recording", "FILE_MOVIE")
        ob = _skin(context)
        if ob is None or not ob.vtskin.replay_source or ob.vtskin.cache is None:
            return
        v = ob.vtskin
        box = col.box()
        box.label(text=f"{bpy.path.basename(v.replay_source)}: frames {v.bake_start}..{v.bake_end}")
        box.label(text=f"{v.replay_rows} rows at {v.recording_hz:.4g} Hz")
        box.label(text=f"Lost: {v.lost_rows} rows ({v.lost_samples} samples), shown held in {v.lost_frames} frames")
        # vtcore words the mismatch report and the decoder's summary
        for line in v.replay_report.splitlines():
            box.label(text=line.strip())
        draw_legend(box, ob)


class VTSKIN_PT_filters(_Panel, bpy.types.Panel):
    bl_idname = "VTSKIN_PT_filters"
    bl_label = "Filters"
    props = ("edge_fraction",)
    button = ("vtskin.edges", "MOD_EDGESPLIT", {"show": True})


class VTSKIN_PT_augment(_Panel, bpy.types.Panel):
    bl_idname = "VTSKIN_PT_augment"
    bl_label = "Augmented point cloud"
    props = ("cloud", "probe_source")
    button = ("vtskin.augment", "COLOR")

    def draw_more(self, col, s, context):
        col.prop(s, "probe_file" if s.probe_source == "FILE" else "probe_attribute")
        col.prop(s, "propagation")
        _row(col, s, "beta", enabled=s.propagation == "smooth")


class VTSKIN_PT_export(_Panel, bpy.types.Panel):
    bl_idname = "VTSKIN_PT_export"
    bl_label = "Export"
    props = ("export_path", "export_format", "export_frame")
    button = ("vtskin.export", "EXPORT")


class VTSKIN_PT_scene(_Panel, bpy.types.Panel):
    bl_idname = "VTSKIN_PT_scene"
    bl_label = "Scene file"
    bl_options = {"DEFAULT_CLOSED"}
    props = ("scene_file", "out_dir")
    button = ("vtskin.run_scene", "PLAY")


CLASSES = (VTSKIN_PT_robot, VTSKIN_PT_layout, VTSKIN_PT_layer, VTSKIN_PT_contact, VTSKIN_PT_evaluate, VTSKIN_PT_replay,
           VTSKIN_PT_filters,
           VTSKIN_PT_augment,
           VTSKIN_PT_export, VTSKIN_PT_scene)
