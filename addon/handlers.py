"""Application handlers (persistent across file loads).

``frame_change_pre`` plays baked contacts back from their cache without
recomputing anything: it copies the cached frame's attributes into the taxel
object's ``pressure``/``response``/``edge`` attributes.
"""

from __future__ import annotations

import bpy
from bpy.app.handlers import persistent


@persistent
def on_frame_change(scene, depsgraph=None):
    from . import bake

    bake.apply_all(scene)


def register():
    from . import display, live

    display.register_ids()
    live.register()
    if on_frame_change not in bpy.app.handlers.frame_change_pre:
        bpy.app.handlers.frame_change_pre.append(on_frame_change)


def unregister():
    from . import display, live

    display.unregister_ids()
    live.unregister()
    if on_frame_change in bpy.app.handlers.frame_change_pre:
        bpy.app.handlers.frame_change_pre.remove(on_frame_change)
