"""Issue 26's hard cases through the add-on's operators (headless bpy): a selection of 31 islands
on a CAD link modelled in millimetres (object scale 0.001), Panda's 200-triangle link-7 hull, a
16 mm fingertip, and a hexagon forced onto the curved visual mesh of Panda's hand."""

from __future__ import annotations

import sys
import sysconfig
from pathlib import Path

import numpy as np
import pytest

bpy = pytest.importorskip("bpy")
sys.path.insert(0, str(Path(__file__).parent / "blender"))
from bl_helpers import addon_fixtures, scene_state  # noqa: E402

pytestmark = [pytest.mark.blender, pytest.mark.slow, pytest.mark.filterwarnings("ignore::UserWarning")]

addon, factory = addon_fixtures()
ROBOTS = Path(sysconfig.get_paths()["purelib"]) / "cmeel.prefix" / "share" / "example-robot-data" / "robots"


def add_object(vertices, faces, name, scale=1.0):
    from addon import bridge

    me = bpy.data.meshes.new(name)
    bridge.write_mesh(me, np.asarray(vertices), np.asarray(faces))
    ob = bpy.data.objects.new(name, me)
    bpy.context.scene.collection.objects.link(ob)
    ob.scale = (scale, scale, scale)
    bpy.context.view_layer.objects.active = ob
    bpy.context.view_layer.update()
    return ob


def skin_ob():
    return next(o for o in bpy.data.objects if o.vtskin.role == "TAXELS")


def test_a_selection_of_many_islands_in_millimetres():
    import trimesh

    from vtcore.layout import cadmeshes
    from vtcore.layout.regions import face_islands

    link = cadmeshes.cad_link(mm=True)  # millimetres, as a CAD export imported without scaling ...
    ee = add_object(link.vertices, link.faces, "cad_link", scale=0.001)  # ... then scaled in Blender
    # select on Blender's own polygons (it dropped the export's duplicate faces: indices moved)
    me = ee.data
    co = np.empty(3 * len(me.vertices), np.float32)
    me.vertices.foreach_get("co", co)
    polys = np.empty(3 * len(me.polygons), np.int32)
    me.polygons.foreach_get("vertices", polys)
    seen = trimesh.Trimesh(co.reshape(-1, 3), polys.reshape(-1, 3), process=False)
    side, region = cadmeshes.island_selection(seen)
    assert len(face_islands(seen, region)) >= 15
    me.polygons.foreach_set("select", region)
    assert bpy.ops.vtskin.lay_patch(fill=True) == {"FINISHED"}
    ob = skin_ob()
    assert ob.vtskin.overlaps == 0 and len(ob.data.vertices) >= 100
    assert "islands" in ob.vtskin.warnings and "left out as smaller than a module" in ob.vtskin.warnings


@pytest.mark.skipif(not (ROBOTS / "panda_description").is_dir(), reason="example-robot-data not installed")
def test_a_200_triangle_hull_and_a_hexagon_forced_onto_a_curved_visual_mesh():
    from vtcore.layout.meshinput import load_mesh

    hull = load_mesh(ROBOTS / "panda_description/meshes/collision/link7.stl")
    ee = add_object(hull.vertices, hull.faces, "link7")
    flange = hull.face_normals[:, 2] < -0.99
    ee.data.polygons.foreach_set("select", flange)
    assert bpy.ops.vtskin.lay_patch(fill=True) == {"FINISHED"}
    assert len(skin_ob().data.vertices) >= 60  # at least the six modules a person lays on the flange
    bpy.data.objects.remove(skin_ob())
    hand = load_mesh(ROBOTS / "panda_description/meshes/visual/hand.dae")
    ee = add_object(hand.vertices, hand.faces, "hand")
    bpy.context.scene.cursor.location = (0.0, 0.0, 0.0)
    before = scene_state()
    with pytest.raises(RuntimeError, match="hexagon refused: .*taxels fall off the surface"):
        bpy.ops.vtskin.lay_patch()
    assert scene_state() == before


def test_a_16_mm_fingertip_says_what_fits():
    import trimesh

    tip = trimesh.creation.box(extents=[0.016, 0.03, 0.008]).subdivide_to_size(0.002)
    ee = add_object(tip.vertices, tip.faces, "fingertip")
    ee.data.polygons.foreach_set("select", tip.face_normals[:, 2] > 0.9)
    with pytest.raises(RuntimeError, match=r"16\.0 mm across.*needs 19\.5 mm.*icub10, needs 17\.0 mm"):
        bpy.ops.vtskin.lay_patch(fill=True)
