"""Shared helpers for the in-process Blender tests (imported by tests/test_blender_*.py)."""

from __future__ import annotations

import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]


def register_addon():
    """Import the repository's ``addon`` package and register it (once per process)."""
    import bpy

    if str(ROOT) not in sys.path:
        sys.path.insert(0, str(ROOT))
    import addon

    if not hasattr(bpy.types.Scene, "vtskin"):
        addon.register()
    return addon


def reset_scene():
    """Factory-empty scene (the dev add-on registered by hand stays registered)."""
    import bpy

    bpy.ops.wm.read_factory_settings(use_empty=True)


def scene_state():
    """A comparable summary of the scene: objects, meshes with geometry and attribute data."""
    import bpy
    import numpy as np

    state = {}
    for ob in bpy.data.objects:
        entry = {"type": ob.type, "matrix": tuple(round(v, 9) for row in ob.matrix_world for v in row),
                 "modifiers": tuple(m.name for m in ob.modifiers)}
        if ob.type == "MESH":
            me = ob.data
            co = np.empty(3 * len(me.vertices), np.float32)
            me.vertices.foreach_get("co", co)
            entry["co"] = co.tobytes()
            entry["faces"] = len(me.polygons)
            attrs = {}
            for a in me.attributes:
                if a.name.startswith("."):
                    continue
                attrs[a.name] = (a.data_type, a.domain, len(a.data))
            entry["attrs"] = attrs
        state[ob.name] = entry
    state["_meshes"] = sorted(m.name for m in bpy.data.meshes)
    state["_objects"] = sorted(o.name for o in bpy.data.objects)
    return state
