"""The layout's flat (unrolled) coordinates survive the Blender round trip, so the panel's
"Solve on: Unrolled skin" runs vtcore's unrolled contact solve. Headless, bpy wheel."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

bpy = pytest.importorskip("bpy")
sys.path.insert(0, str(Path(__file__).parent / "blender"))
from bl_helpers import addon_fixtures, build_scene  # noqa: E402

pytestmark = [pytest.mark.blender, pytest.mark.filterwarnings("ignore::UserWarning")]
addon, factory = addon_fixtures()


def _skin():
    return next(o for o in bpy.data.objects if o.vtskin.role == "TAXELS")


def test_flat_survives_save_and_reload_and_the_unrolled_solve_runs(tmp_path):
    from addon import bridge, opbase, skin
    from vtcore.scene import interactive

    ee, ind, centre = build_scene()
    bpy.context.scene.cursor.location = centre
    bpy.context.view_layer.objects.active = ee
    assert bpy.ops.vtskin.lay_patch() == {"FINISHED"}
    ob = _skin()
    # what vtcore lays on the same input (see test_blender_ops.test_lay_patch_matches_vtcore)
    frame = opbase.skin_frame(ee)
    verts, tri = opbase.mesh_in_frame(ee, frame)
    inv = np.linalg.inv(frame)
    cursor = np.array(bpy.context.scene.cursor.location, dtype=np.float64)
    ref = interactive.lay_patch(verts, tri, inv[:3, :3] @ cursor + inv[:3, 3], direction=[1.0, 0, 0])
    assert ref.layout.flat is not None
    np.testing.assert_allclose(skin.read_layout(ob).flat, ref.layout.flat, atol=1e-7)  # float32 storage

    path = str(tmp_path / "skin.blend")
    bpy.ops.wm.save_as_mainfile(filepath=path)
    bpy.ops.wm.open_mainfile(filepath=path)
    ob, ind = _skin(), bpy.data.objects["indenter"]
    layout = skin.read_layout(ob)
    np.testing.assert_allclose(layout.flat, ref.layout.flat, atol=1e-7)

    s = bpy.context.scene.vtskin
    s.indenter, s.thickness, s.force, s.geometry = ind, 0.003, 1.5, "unrolled"
    bpy.context.view_layer.objects.active = ob
    assert bpy.ops.vtskin.simulate() == {"FINISHED"}
    m_ind = bridge.rigid(bridge.matrix(ind))
    world, ftri = bridge.read_mesh(ind)
    inv = np.linalg.inv(m_ind)
    args = (layout, skin.triangles(ob), world @ inv[:3, :3].T + inv[:3, 3], ftri,
            np.linalg.inv(bridge.matrix(ob)) @ m_ind)
    unrolled = interactive.simulate(*args, thickness=0.003, force=1.5, geometry="unrolled")
    plane = interactive.simulate(*args, thickness=0.003, force=1.5)
    got = bridge.get_attribute(ob.data, "pressure")
    np.testing.assert_allclose(got, unrolled.pressure, rtol=1e-5, atol=1e-3)
    assert unrolled.force == pytest.approx(1.5, rel=1e-3) and unrolled.pressure.max() > 0
    # the panel's choice reached the solver: the curved skin reads differently on the plane
    assert np.abs(plane.pressure - unrolled.pressure).max() > 1e-3 * unrolled.pressure.max()


def test_a_second_patch_leaves_no_stale_flat_and_unrolled_says_why():
    from addon import skin

    ee, ind, centre = build_scene()
    bpy.context.scene.cursor.location = centre
    bpy.context.view_layer.objects.active = ee
    assert bpy.ops.vtskin.lay_patch() == {"FINISHED"}
    ob = _skin()
    assert "flat" in ob.data.attributes
    m = np.array([tuple(r) for r in ee.matrix_world])
    bpy.context.scene.cursor.location = centre + m[:3, 0] * 0.035
    bpy.context.view_layer.objects.active = ee
    assert bpy.ops.vtskin.lay_patch() == {"FINISHED"}
    # two patches unrolled about two anchors have no common flat domain
    assert "flat" not in ob.data.attributes and skin.read_layout(ob).flat is None
    s = bpy.context.scene.vtskin
    s.indenter, s.thickness, s.force, s.geometry = ind, 0.003, 1.5, "unrolled"
    bpy.context.view_layer.objects.active = ob
    with pytest.raises(RuntimeError, match="needs the layout's flat coordinates"):  # the operator's report
        bpy.ops.vtskin.simulate()
