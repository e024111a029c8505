"""Operators. Each gathers its input from the scene, calls ONE vtcore function and
writes the result; on bad input it reports ``{'ERROR'}``, returns ``{'CANCELLED'}``
and has changed nothing (all computation happens before the first write)."""

from __future__ import annotations

import tempfile
from pathlib import Path

import bpy

from . import display, skin


def _fail(op, message: str):
    op.report({"ERROR"}, message)
    return {"CANCELLED"}


def _out_dir(settings) -> Path:
    if settings.out_dir:
        return Path(bpy.path.abspath(settings.out_dir))
    return Path(tempfile.mkdtemp(prefix="vtskin_"))


class VTSKIN_OT_run_scene(bpy.types.Operator):
    """Run a vtcore scene file and show its taxel responses on a taxel object"""

    bl_idname = "vtskin.run_scene"
    bl_label = "Run Scene"
    bl_options = {"REGISTER", "UNDO"}

    filepath: bpy.props.StringProperty(name="Scene file", subtype="FILE_PATH",
                                       description="Scene TOML (empty: the scene setting)")

    def execute(self, context):
        from vtcore.errors import VtError
        from vtcore.scene.interactive import run_scene_file

        settings = context.scene.vtskin
        path = bpy.path.abspath(self.filepath or settings.scene_file)
        if not path:
            return _fail(self, "No scene file given")
        try:
            res = run_scene_file(path, _out_dir(settings))
        except (VtError, OSError, ValueError) as exc:
            return _fail(self, f"Scene run failed: {exc}")
        name = res.result.get("name") or Path(path).stem
        ob = skin.new_object(context, f"{name} taxels")
        skin.write_layout(ob, res.layout, res.triangles, pressure=res.pressure, response=res.response)
        ob.vtskin.source = str(path)
        display.ensure_display(ob)
        for other in context.view_layer.objects:
            other.select_set(False)
        ob.select_set(True)
        context.view_layer.objects.active = ob
        metrics = res.result.get("metrics", {})
        force = metrics.get("force_n")
        self.report({"INFO"}, f"{name}: {len(res.layout)} taxels"
                    + (f", {force:.3g} N" if isinstance(force, (int, float)) else "")
                    + f", results in {res.out}")
        return {"FINISHED"}


CLASSES = (VTSKIN_OT_run_scene,)
