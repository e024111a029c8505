"""Sidebar panels (View3D > Sidebar > Skin). Panels only draw; operators do the work."""

from __future__ import annotations

import bpy


class _Panel:
    bl_space_type = "VIEW_3D"
    bl_region_type = "UI"
    bl_category = "Skin"


class VTSKIN_PT_scene(_Panel, bpy.types.Panel):
    bl_idname = "VTSKIN_PT_scene"
    bl_label = "Scene file"

    def draw(self, context):
        s = context.scene.vtskin
        col = self.layout.column()
        col.prop(s, "scene_file")
        col.prop(s, "out_dir")
        col.operator("vtskin.run_scene", icon="PLAY")


CLASSES = (VTSKIN_PT_scene,)
