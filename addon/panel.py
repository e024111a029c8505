"""Sidebar panels (View3D > Sidebar > Skin). Panels only draw; operators do the work."""

from __future__ import annotations

import bpy


class _Panel:
    bl_space_type = "VIEW_3D"
    bl_region_type = "UI"
    bl_category = "Skin"


def _skin(context):
    from .ops import _skin_of

    return _skin_of(context)


class VTSKIN_PT_layout(_Panel, bpy.types.Panel):
    bl_idname = "VTSKIN_PT_layout"
    bl_label = "Skin layout"

    def draw(self, context):
        s = context.scene.vtskin
        col = self.layout.column()
        col.prop(s, "module")
        row = col.row(align=True)
        row.prop(s, "patch")
        if s.patch == "strip":
            row.prop(s, "strip_modules")
        col.prop(s, "place_at")
        col.prop(s, "rotation")
        col.prop(s, "offset")
        col.prop(s, "method")
        col.prop(s, "solve_faces")
        col.operator("vtskin.lay_patch", icon="MESH_ICOSPHERE").fill = False
        col.operator("vtskin.lay_patch", text="Fill Selected Faces", icon="MOD_TRIANGULATE").fill = True
        row = col.row(align=True)
        row.operator("vtskin.remove_module", icon="X")
        row.operator("vtskin.move_module", icon="PIVOT_CURSOR")
        ob = _skin(context)
        if ob is not None:
            box = col.box()
            v = ob.vtskin
            box.label(text=f"{ob.name}: {len(ob.data.vertices)} taxels")
            box.label(text=f"Strain max {v.strain_max:.1f} %, mean {v.strain_mean:.1f} %")
            box.label(text=f"Overlaps {v.overlaps}, coverage "
                      + ("n/a" if v.coverage < 0 else f"{v.coverage:.0f} %"))
            box.prop(v, "color_by")


class VTSKIN_PT_layer(_Panel, bpy.types.Panel):
    bl_idname = "VTSKIN_PT_layer"
    bl_label = "Soft layer"

    def draw(self, context):
        s = context.scene.vtskin
        col = self.layout.column()
        col.prop(s, "thickness")
        col.prop(s, "material")


class VTSKIN_PT_contact(_Panel, bpy.types.Panel):
    bl_idname = "VTSKIN_PT_contact"
    bl_label = "Contact"

    def draw(self, context):
        s = context.scene.vtskin
        col = self.layout.column()
        col.prop(s, "indenter")
        row = col.row(align=True)
        row.prop(s, "use_force")
        sub = row.row()
        sub.enabled = s.use_force
        sub.prop(s, "force")
        col.prop(s, "counts_per_pa")
        col.operator("vtskin.simulate", icon="PLAY")
        row = col.row(align=True)
        row.prop(s, "frame_start")
        row.prop(s, "frame_end")
        row = col.row(align=True)
        row.operator("vtskin.bake", icon="REC")
        row.operator("vtskin.clear_bake", icon="TRASH")
        ob = _skin(context)
        if ob is not None and ob.vtskin.cache is not None:
            col.label(text=f"Baked frames {ob.vtskin.bake_start}..{ob.vtskin.bake_end}")


class VTSKIN_PT_filters(_Panel, bpy.types.Panel):
    bl_idname = "VTSKIN_PT_filters"
    bl_label = "Filters"

    def draw(self, context):
        s = context.scene.vtskin
        col = self.layout.column()
        col.prop(s, "edge_fraction")
        col.operator("vtskin.edges", icon="MOD_EDGESPLIT").show = True


class VTSKIN_PT_augment(_Panel, bpy.types.Panel):
    bl_idname = "VTSKIN_PT_augment"
    bl_label = "Augmented point cloud"

    def draw(self, context):
        s = context.scene.vtskin
        col = self.layout.column()
        col.prop(s, "cloud")
        col.prop(s, "probe_source")
        if s.probe_source == "FILE":
            col.prop(s, "probe_file")
        else:
            col.prop(s, "probe_attribute")
        col.prop(s, "propagation")
        sub = col.row()
        sub.enabled = s.propagation == "smooth"
        sub.prop(s, "beta")
        col.operator("vtskin.augment", icon="COLOR")


class VTSKIN_PT_export(_Panel, bpy.types.Panel):
    bl_idname = "VTSKIN_PT_export"
    bl_label = "Export"

    def draw(self, context):
        s = context.scene.vtskin
        col = self.layout.column()
        col.prop(s, "export_path")
        col.prop(s, "export_format")
        col.prop(s, "export_frame")
        col.operator("vtskin.export", icon="EXPORT")


class VTSKIN_PT_scene(_Panel, bpy.types.Panel):
    bl_idname = "VTSKIN_PT_scene"
    bl_label = "Scene file"
    bl_options = {"DEFAULT_CLOSED"}

    def draw(self, context):
        s = context.scene.vtskin
        col = self.layout.column()
        col.prop(s, "scene_file")
        col.prop(s, "out_dir")
        col.operator("vtskin.run_scene", icon="PLAY")


CLASSES = (VTSKIN_PT_layout, VTSKIN_PT_layer, VTSKIN_PT_contact, VTSKIN_PT_filters, VTSKIN_PT_augment,
           VTSKIN_PT_export, VTSKIN_PT_scene)
