"""Settings as PropertyGroups: ``Scene.vtskin`` (tool settings) and ``Object.vtskin`` (per skin).

Stored in the .blend, so a saved file reopens with its skins, settings and results.
Lengths are shown in millimetres in the UI and stored in metres (Blender's unit
system with ``subtype='DISTANCE'``), so values reach ``vtcore`` in SI unchanged.
"""

from __future__ import annotations

import bpy
from bpy.props import (BoolProperty, EnumProperty, FloatProperty, IntProperty, PointerProperty,
                       StringProperty)

COLOR_BY = [
    ("response", "Response", "Sensor response (counts)"),
    ("pressure", "Pressure", "Pressure at the taxels (Pa)"),
    ("edge", "Edge", "Taxels on an edge of the contact"),
    ("tactile_color", "Tactile colour", "Colour propagated onto a point cloud"),
]


class VTSKIN_PG_object(bpy.types.PropertyGroup):
    """Per-object data: what this object is to the add-on and its baked cache."""

    role: EnumProperty(name="Role", items=[
        ("NONE", "None", "Not part of a skin"),
        ("TAXELS", "Taxels", "One vertex per taxel, skin mesh as faces"),
        ("CLOUD", "Point cloud", "Augmented point cloud"),
    ], default="NONE")
    source: StringProperty(name="Source", description="Where the taxels came from (scene file, layout file, placement)")
    end_effector: PointerProperty(name="End-effector", type=bpy.types.Object,
                                  description="The mesh the skin lies on")
    color_by: EnumProperty(name="Colour by", items=COLOR_BY, default="response",
                           update=lambda self, ctx: _color_by_changed(self, ctx))
    cache: PointerProperty(name="Bake cache", type=bpy.types.Mesh,
                           description="Mesh datablock holding one attribute per baked frame")
    bake_start: IntProperty(name="Baked from", default=0)
    bake_end: IntProperty(name="Baked to", default=-1)


def _color_by_changed(settings, context):
    from . import display

    ob = settings.id_data
    if isinstance(ob, bpy.types.Object):
        display.set_color_by(ob, settings.color_by)


class VTSKIN_PG_scene(bpy.types.PropertyGroup):
    """Tool settings of the sidebar panels."""

    scene_file: StringProperty(name="Scene file", subtype="FILE_PATH",
                               description="A vtcore scene (TOML) to run")
    out_dir: StringProperty(name="Output folder", subtype="DIR_PATH",
                            description="Where scene runs write their results (empty: a temporary folder)")


CLASSES = (VTSKIN_PG_object, VTSKIN_PG_scene)


def register_props():
    bpy.types.Object.vtskin = PointerProperty(type=VTSKIN_PG_object)
    bpy.types.Scene.vtskin = PointerProperty(type=VTSKIN_PG_scene)


def unregister_props():
    del bpy.types.Scene.vtskin
    del bpy.types.Object.vtskin
