"""Shared helpers for the in-process Blender tests (imported by tests/test_blender_*.py)."""

from __future__ import annotations

import atexit
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
        # Safety net behind the fixtures' teardown: the bpy 4.5 wheel hangs at interpreter exit
        # while add-on classes are registered. atexit runs handlers last-registered first, so
        # this runs before bpy's own exit code.
        atexit.register(_unregister_if_registered, addon)
    return addon


def _unregister_if_registered(addon):
    import bpy

    if hasattr(bpy.types.Scene, "vtskin"):
        addon.unregister()


def addon_fixtures():
    """The two fixtures every Blender test module uses: ``addon`` (the add-on registered for
    the module, unregistered after it: the bpy wheel hangs at exit while Python classes stay
    registered) and ``factory`` (autouse: a factory-empty scene before every test, warnings
    ignored). Use as ``addon, factory = addon_fixtures()`` at module level."""
    import warnings

    import pytest

    @pytest.fixture(scope="module")
    def addon():
        mod = register_addon()
        yield mod
        mod.unregister()

    @pytest.fixture(autouse=True)
    def factory(addon):
        reset_scene()
        warnings.simplefilter("ignore")
        yield

    return addon, factory


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


def build_scene(indenter_radius=0.015, gap=0.002):
    """A curved end-effector (seed 002's) and a sphere indenter above its middle.

    Returns (end_effector object, indenter object, centre (3,) world point on the surface).
    The end-effector object has a non-trivial pose so frames matter.
    """
    import bpy
    import numpy as np
    from vtcore.contact import make_object, placement_pose
    from vtcore.layout import seed002_curved

    from addon import bridge

    mesh, lay = seed002_curved()
    centre = lay.positions[np.argmin(np.linalg.norm(lay.positions - lay.positions.mean(0), axis=1))]
    me = bpy.data.meshes.new("end_effector")
    bridge.write_mesh(me, mesh.vertices, mesh.faces)
    ee = bpy.data.objects.new("end_effector", me)
    bpy.context.scene.collection.objects.link(ee)
    pose_ee = np.eye(4)
    pose_ee[:3, 3] = [0.1, -0.05, 0.2]
    c, s = np.cos(0.3), np.sin(0.3)
    pose_ee[:3, :3] = [[c, -s, 0], [s, c, 0], [0, 0, 1]]
    ee.matrix_world = bridge.to_matrix(pose_ee)
    sphere = make_object("sphere", radius=indenter_radius)
    me2 = bpy.data.meshes.new("indenter")
    bridge.write_mesh(me2, sphere.vertices, sphere.faces)
    ind = bpy.data.objects.new("indenter", me2)
    bpy.context.scene.collection.objects.link(ind)
    pose = placement_pose(sphere, xy=centre[:2], top=centre[2] + 0.003, gap=gap)
    ind.matrix_world = bridge.to_matrix(pose_ee @ pose)
    world_centre = pose_ee[:3, :3] @ centre + pose_ee[:3, 3]
    bpy.context.view_layer.objects.active = ee
    ee.select_set(True)
    bpy.context.view_layer.update()
    return ee, ind, world_centre


def attr(ob, name):
    """The point attribute ``name`` of taxel object ``ob``'s mesh, as numpy (the add-on's bridge)."""
    from addon import bridge

    return bridge.get_attribute(ob.data, name)


def display_colours(ob):
    """(n, 4) display colours of the evaluated disc instances of taxel object ``ob`` (the
    ``vtskin_display`` instance attribute the disc material reads), or None without one."""
    import bpy
    import numpy as np

    ev = ob.evaluated_get(bpy.context.evaluated_depsgraph_get())
    geometry = ev.evaluated_geometry()  # keep it alive: the point cloud below belongs to it
    cloud = geometry.instances_pointcloud()
    if cloud is None or "vtskin_display" not in cloud.attributes:
        return None
    attr = cloud.attributes["vtskin_display"]
    out = np.empty(4 * len(attr.data), np.float32)
    attr.data.foreach_get("color", out)
    return out.reshape(-1, 4)
