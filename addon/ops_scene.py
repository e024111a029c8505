"""Run a vtcore scene file and show it on a taxel object."""

from __future__ import annotations

from pathlib import Path

import bpy

from . import display, skin
from .opbase import Cancel, Op, failing, out_dir
from .ops_replay import store_replay

class VTSKIN_OT_run_scene(Op, bpy.types.Operator):
    """Run a vtcore scene file and show its taxel responses on a taxel object"""

    bl_idname = "vtskin.run_scene"
    bl_label = "Run Scene"

    filepath: bpy.props.StringProperty(name="Scene file", subtype="FILE_PATH",
                                       description="Scene TOML (empty: the scene setting)")

    def run(self, context):
        from vtcore.scene.interactive import run_scene_file

        settings = context.scene.vtskin
        path = bpy.path.abspath(self.filepath or settings.scene_file)
        if not path:
            raise Cancel("No scene file given")
        if not Path(path).is_file():  # before _out_dir, which may create a temporary folder
            raise Cancel(f"{path}: not a readable scene file")
        with failing("Scene run failed"):
            # a replay scene also comes back prepared for the timeline, at its [output] fps
            res = run_scene_file(path, out_dir(settings))
        name = res.result.get("name") or Path(path).stem
        ob = skin.new_object(context, f"{name} taxels")
        skin.write_layout(ob, res.layout, res.triangles, pressure=res.pressure, response=res.response)
        ob.vtskin.source = str(path)
        display.ensure_display(ob)
        for other in context.view_layer.objects:
            other.select_set(False)
        ob.select_set(True)
        context.view_layer.objects.active = ob
        rendered = ""
        if res.replay is not None:
            store_replay(context.scene, ob, res.replay, res.replay.meta.get("path", path))
            if res.output.get("video"):
                from . import render

                try:
                    rendered = f", rendered {render.render_replay(context, ob, res.out, res.output)}"
                except RuntimeError as exc:  # Blender's render failed (no GPU context, codec missing)
                    self.report({"WARNING"}, f"The skin and replay are loaded; rendering failed: {exc}")
        metrics = res.result.get("metrics", {})
        force = metrics.get("force_n")
        self.report({"INFO"}, f"{name}: {len(res.layout)} taxels"
                    + (f", {force:.3g} N" if isinstance(force, (int, float)) else "")
                    + f", results in {res.out}" + rendered)
        return {"FINISHED"}



CLASSES = (VTSKIN_OT_run_scene,)
