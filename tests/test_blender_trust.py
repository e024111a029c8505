"""The add-on's trust signals (issue 26), headless in the bpy wheel: a patch far off the surface is
refused (CANCELLED, the reason in the report) unless *Keep anyway*, warnings reach the skin's report
box, *Move Module* onto another module is judged against the whole skin (overlaps counted and
coloured), *Remove Module* after a simulation keeps the other taxels' response and recomputes the
report, fill regions by radius and by facing direction, and no-module-fits details."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

bpy = pytest.importorskip("bpy")
sys.path.insert(0, str(Path(__file__).parent / "blender"))
from bl_helpers import addon_fixtures, attr, build_scene, scene_state  # noqa: E402

pytestmark = [pytest.mark.blender, pytest.mark.filterwarnings("ignore::UserWarning")]

addon, factory = addon_fixtures()


def skin_ob():
    return next(o for o in bpy.data.objects if o.vtskin.role == "TAXELS")


def lay(ee, at, **settings):
    s = bpy.context.scene.vtskin
    for k, v in settings.items():
        setattr(s, k, v)
    bpy.context.scene.cursor.location = at
    bpy.context.view_layer.objects.active = ee
    return bpy.ops.vtskin.lay_patch()


def test_a_patch_far_off_the_surface_is_refused_then_kept_with_warnings():
    ee, _, centre = build_scene()
    before = scene_state()
    with pytest.raises(RuntimeError, match=r"refused: 'at' is [0-9.]+ mm off the surface"):
        lay(ee, centre + np.array([0.0, 0.0, 5.0]))
    assert scene_state() == before
    assert lay(ee, centre + np.array([0.0, 0.0, 5.0]), keep_refused=True) == {"FINISHED"}
    ob = skin_ob()
    assert "'at' is" in ob.vtskin.warnings and "mm off the surface" in ob.vtskin.warnings


def test_move_onto_another_module_counts_and_colours_the_overlap():
    ee, _, centre = build_scene()
    assert lay(ee, centre) == {"FINISHED"}  # a hexagon of 6 modules
    ob = skin_ob()
    assert ob.vtskin.overlaps == 0 and not attr(ob, "overlap").any()
    pos = attr(ob, "module_id") == 0
    m = np.array([tuple(r) for r in ob.matrix_world])
    target = m[:3, :3] @ np.asarray([tuple(v.co) for v in ob.data.vertices])[pos].mean(0) + m[:3, 3]
    bpy.context.scene.cursor.location = target  # module 5 onto module 0
    bpy.context.view_layer.objects.active = ob
    assert bpy.ops.vtskin.move_module(module=5) == {"FINISHED"}
    assert ob.vtskin.overlaps >= 1
    moved, first = attr(ob, "module_id") == 5, attr(ob, "module_id") == 0
    over = attr(ob, "overlap") > 0.5
    assert over[moved].any() and over[first].any()
    assert "overlap" in ob.vtskin.warnings
    ob.vtskin.color_by = "overlap"
    from addon import display

    assert display.legend_lines(ob)[0].startswith("Overlap with another module: yellow yes")


def test_remove_after_a_simulation_keeps_the_other_responses():
    ee, ind, centre = build_scene()
    assert lay(ee, centre) == {"FINISHED"}
    ob = skin_ob()
    s = bpy.context.scene.vtskin
    s.indenter, s.thickness, s.force = ind, 0.003, 1.5
    bpy.context.view_layer.objects.active = ob
    assert bpy.ops.vtskin.simulate() == {"FINISHED"}
    resp, mods, ids = attr(ob, "response"), attr(ob, "module_id"), attr(ob, "taxel_id")
    assert resp.max() > 0
    cov = ob.vtskin.coverage
    assert bpy.ops.vtskin.remove_module(module=2) == {"FINISHED"}
    keep = mods != 2
    np.testing.assert_array_equal(attr(ob, "taxel_id"), ids[keep])
    np.testing.assert_allclose(attr(ob, "response"), resp[keep])  # the others' response holds
    assert ob.vtskin.report and ob.vtskin.overlaps == 0
    assert ob.vtskin.coverage == pytest.approx(cov * 5 / 6, rel=1e-4)
    assert len(attr(ob, "strain")) == keep.sum()


def test_fill_by_radius_and_by_direction_and_why_nothing_fits():
    ee, _, centre = build_scene()
    bpy.context.view_layer.objects.active = ee
    s = bpy.context.scene.vtskin
    s.fill_region, s.fill_radius = "RADIUS", 0.03
    bpy.context.scene.cursor.location = centre
    assert bpy.ops.vtskin.lay_patch(fill=True) == {"FINISHED"}
    ob = skin_ob()
    n_radius = len(ob.data.vertices)
    assert n_radius >= 30
    m = np.array([tuple(r) for r in ob.matrix_world])
    local = np.asarray([tuple(v.co) for v in ob.data.vertices])
    c_local = np.linalg.inv(m) @ np.append(np.asarray(centre), 1.0)
    assert np.linalg.norm(local - c_local[:3], axis=1).max() < 0.03 + 0.002
    bpy.data.objects.remove(ob)
    s.fill_region, s.facing, s.within = "FACING", (0.0, 0.0, 1.0), 0.2  # seed 002's flat top
    bpy.context.view_layer.objects.active = ee
    assert bpy.ops.vtskin.lay_patch(fill=True) == {"FINISHED"}
    ob = skin_ob()
    nrm = attr(ob, "normal")
    assert len(nrm) >= 20 and (nrm[:, 2] > np.cos(0.2) - 1e-3).all()
    bpy.data.objects.remove(ob)
    s.fill_region, s.fill_radius = "RADIUS", 0.005  # smaller than a module
    bpy.context.view_layer.objects.active = ee
    with pytest.raises(RuntimeError, match=r"Cannot lay the patch: region: .*mm across.*needs 19\.5 mm"):
        bpy.ops.vtskin.lay_patch(fill=True)
