"""Every operator of the add-on on a real scene (curved end-effector, sphere indenter),
checked against vtcore called directly on the same data; save/reload; bad input
leaves the scene unchanged. Headless, bpy 4.5 wheel, one xdist worker (loadfile)."""

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


def M(ob):
    return np.array([tuple(r) for r in ob.matrix_world])


def skin_frame_input(ee, skin_ob):
    """End-effector vertices/faces in the skin's frame, computed independently of the add-on."""
    me = ee.data
    co = np.empty(3 * len(me.vertices))
    me.vertices.foreach_get("co", co)
    me.calc_loop_triangles()
    tri = np.empty(3 * len(me.loop_triangles), np.int32)
    me.loop_triangles.foreach_get("vertices", tri)
    world = co.reshape(-1, 3) @ M(ee)[:3, :3].T + M(ee)[:3, 3]
    inv = np.linalg.inv(M(skin_ob))
    return world @ inv[:3, :3].T + inv[:3, 3], tri.reshape(-1, 3)


def lay(ee, at):
    bpy.context.scene.cursor.location = at
    bpy.context.view_layer.objects.active = ee
    assert bpy.ops.vtskin.lay_patch() == {"FINISHED"}
    return next(o for o in bpy.data.objects if o.vtskin.role == "TAXELS")


@pytest.fixture
def skinned():
    ee, ind, centre = build_scene()
    ob = lay(ee, centre)
    return ee, ind, centre, ob


def test_lay_patch_matches_vtcore(skinned):
    from vtcore.scene import interactive

    from addon import opbase

    ee, _, centre, ob = skinned
    verts, tri = skin_frame_input(ee, ob)
    # The same data the operator passed (identical float round-off): a taxel next to a
    # crease of the mesh may otherwise take the normal of the other face.
    frame = opbase.skin_frame(ee)
    np.testing.assert_allclose(frame, M(ob), atol=1e-6)
    v2, t2 = opbase.mesh_in_frame(ee, frame)
    np.testing.assert_allclose(v2, verts, atol=1e-9)
    np.testing.assert_array_equal(t2, tri)
    verts = v2
    inv = np.linalg.inv(frame)
    cursor = np.array(bpy.context.scene.cursor.location, dtype=np.float64)  # float32 in Blender
    ref = interactive.lay_patch(verts, tri, inv[:3, :3] @ cursor + inv[:3, 3], direction=[1.0, 0, 0])
    n = len(ref.layout)
    assert len(ob.data.vertices) == n == 60
    co = np.empty(3 * n, np.float32)
    ob.data.vertices.foreach_get("co", co)
    np.testing.assert_allclose(co.reshape(-1, 3), ref.layout.positions, atol=2e-6)
    np.testing.assert_array_equal(attr(ob, "taxel_id"), ref.layout.taxel_ids)
    np.testing.assert_array_equal(attr(ob, "module_id"), ref.layout.module_ids)
    np.testing.assert_allclose(attr(ob, "normal"), ref.layout.normals, atol=1e-5)
    assert len(ob.data.polygons) == len(ref.triangles) > 0
    assert ob.vtskin.strain_max == pytest.approx(100 * ref.report["strain_max"], rel=1e-4)
    assert ob.vtskin.overlaps == ref.report["overlaps"]
    # The skin sits on the end-effector: its frame is the end-effector's (rigid part).
    np.testing.assert_allclose(M(ob), M(ee), atol=1e-6)
    # Discs: the evaluated object carries instances and the display colour.
    from bl_helpers import display_colours

    colours = display_colours(ob)  # one disc instance per taxel, plus one tube per skin-mesh edge
    assert colours is not None and len(colours) == len(ob.data.vertices) + len(ob.data.edges)


def test_second_patch_remove_and_move(skinned):
    ee, _, centre, ob = skinned
    m = M(ee)
    bpy.context.scene.cursor.location = centre + m[:3, 0] * 0.035
    bpy.context.view_layer.objects.active = ee
    assert bpy.ops.vtskin.lay_patch() == {"FINISHED"}
    assert len([o for o in bpy.data.objects if o.vtskin.role == "TAXELS"]) == 1  # same skin, extended
    mods = attr(ob, "module_id")
    assert len(mods) == 120 and set(mods) == set(range(12))
    ids = attr(ob, "taxel_id")
    assert len(np.unique(ids)) == 120 and np.all(ids >> 4 == mods + 1)
    bpy.context.view_layer.objects.active = ob
    assert bpy.ops.vtskin.remove_module(module=3) == {"FINISHED"}
    mods = attr(ob, "module_id")
    assert len(mods) == 110 and 3 not in mods
    before = np.empty(3 * 110, np.float32)
    ob.data.vertices.foreach_get("co", before)
    bpy.context.scene.cursor.location = centre - m[:3, 1] * 0.03
    assert bpy.ops.vtskin.move_module(module=5) == {"FINISHED"}
    after = np.empty(3 * 110, np.float32)
    ob.data.vertices.foreach_get("co", after)
    moved = attr(ob, "module_id") == 5
    assert moved.sum() == 10
    # Only module 5 moved; the others kept their positions (order: others first, then the moved module).
    old_mods = np.delete(mods, np.flatnonzero(mods == 5))
    np.testing.assert_array_equal(attr(ob, "module_id")[~moved], old_mods)
    b = before.reshape(-1, 3)
    np.testing.assert_allclose(after.reshape(-1, 3)[~moved], b[mods != 5], atol=1e-7)
    target = np.linalg.inv(M(ob)) @ np.append(centre - m[:3, 1] * 0.03, 1)
    assert np.linalg.norm(after.reshape(-1, 3)[moved].mean(0) - target[:3]) < 8e-3


def test_fill_selected_faces(skinned):
    ee, _, centre, ob = skinned
    me = ee.data
    centres = np.empty(3 * len(me.polygons), np.float32)
    me.polygons.foreach_get("center", centres)
    local = np.linalg.inv(M(ee)) @ np.append(centre, 1)
    sel = np.linalg.norm(centres.reshape(-1, 3) - local[:3], axis=1) < 0.045
    me.polygons.foreach_set("select", sel)
    bpy.ops.object.select_all(action="DESELECT")
    bpy.data.objects.remove(ob)
    bpy.context.view_layer.objects.active = ee
    assert bpy.ops.vtskin.lay_patch(fill=True) == {"FINISHED"}
    ob = next(o for o in bpy.data.objects if o.vtskin.role == "TAXELS")
    n = len(ob.data.vertices)
    assert n > 0 and n % 10 == 0
    assert ob.vtskin.overlaps == 0


def test_fill_curved_selection_anchors_on_it():
    """A selection over the top AND the curved flank: its area-weighted mean lies inside the
    body and snapped to a face outside the selection, so filling found no room (cancelled).
    The fill must anchor on a selected face and tile only selected faces."""
    ee, _, _ = build_scene()
    me = ee.data
    nf = len(me.polygons)
    c = np.empty(3 * nf, np.float32)
    me.polygons.foreach_get("center", c)
    nrm = np.empty(3 * nf, np.float32)
    me.polygons.foreach_get("normal", nrm)
    c, nrm = c.reshape(-1, 3), nrm.reshape(-1, 3)
    region = (c[:, 0] > -0.04) & (nrm[:, 2] > -0.2)
    assert (nrm[region, 2] < 0.5).any() and (nrm[region, 2] > 0.99).any()  # top and flank
    me.polygons.foreach_set("select", region)
    bpy.context.scene.vtskin.place_at = "SELECTED"
    bpy.context.view_layer.objects.active = ee
    assert bpy.ops.vtskin.lay_patch(fill=True) == {"FINISHED"}
    ob = next(o for o in bpy.data.objects if o.vtskin.role == "TAXELS")
    assert len(ob.data.vertices) >= 50 and ob.vtskin.overlaps == 0
    # every taxel sits over a selected face (nearest face centre is selected)
    co = np.empty(3 * len(ob.data.vertices), np.float32)
    ob.data.vertices.foreach_get("co", co)
    world = co.reshape(-1, 3) @ M(ob)[:3, :3].T + M(ob)[:3, 3]
    inv = np.linalg.inv(M(ee))
    local = world @ inv[:3, :3].T + inv[:3, 3]
    nearest = np.argmin(((local[:, None, :] - c[None]) ** 2).sum(-1), axis=1)
    assert region[nearest].mean() > 0.95


def test_simulate_bake_playback_and_reload(skinned, tmp_path):
    from addon import skin
    from vtcore.scene import interactive

    ee, ind, centre, ob = skinned
    s = bpy.context.scene.vtskin
    s.indenter = ind
    s.thickness = 0.003
    s.force = 1.5
    bpy.context.view_layer.objects.active = ob
    assert bpy.ops.vtskin.simulate() == {"FINISHED"}
    layout, tri = skin.read_layout(ob), skin.triangles(ob)
    from addon import bridge

    m_ind = bridge.rigid(bridge.matrix(ind))
    world, ftri = bridge.read_mesh(ind)
    inv = np.linalg.inv(m_ind)
    ref = interactive.simulate(layout, tri, world @ inv[:3, :3].T + inv[:3, 3], ftri,
                               np.linalg.inv(bridge.matrix(ob)) @ m_ind, thickness=0.003, force=1.5)
    assert ref.force == pytest.approx(1.5, rel=1e-3)
    np.testing.assert_allclose(attr(ob, "pressure"), ref.pressure, rtol=1e-5, atol=1e-3)
    np.testing.assert_allclose(attr(ob, "response"), ref.response, rtol=1e-5, atol=1e-3)
    np.testing.assert_array_equal(attr(ob, "edge"), ref.edge)
    assert ref.edge.any() and ref.response.max() > 0

    # Edges from the response with another threshold.
    s.edge_fraction = 0.6
    assert bpy.ops.vtskin.edges() == {"FINISHED"}
    er, edge = interactive.edges(layout, tri, attr(ob, "response").astype(float), 0.6)
    np.testing.assert_array_equal(attr(ob, "edge"), edge)
    assert ob.vtskin.color_by == "edge"

    # Bake 4 frames with an animated target force (0 = no contact on frame 1).
    scene = bpy.context.scene
    for f, force in ((1, 0.0), (4, 1.5)):
        s.force = force
        s.keyframe_insert("force", frame=f)
    s.frame_start, s.frame_end = 1, 4
    scene.frame_set(1)
    assert bpy.ops.vtskin.bake() == {"FINISHED"}
    assert scene.frame_current == 1
    forces = []
    for f in range(1, 5):
        scene.frame_set(f)
        forces.append(s.force)
    poses = np.stack([np.linalg.inv(bridge.matrix(ob)) @ m_ind] * 4)
    baked = interactive.bake(layout, tri, world @ inv[:3, :3].T + inv[:3, 3], ftri, poses, thickness=0.003,
                             forces=forces, edge_fraction=0.6)
    for f in (1, 3, 4):
        scene.frame_set(f)
        np.testing.assert_allclose(attr(ob, "response"), baked["response"][f - 1], rtol=1e-5, atol=1e-3)
        np.testing.assert_array_equal(attr(ob, "edge"), baked["edge"][f - 1])
    scene.frame_set(1)
    assert not attr(ob, "pressure").any()  # no contact asked on frame 1

    blend = str(tmp_path / "skin.blend")
    scene.frame_set(3)
    name = ob.name
    bpy.ops.wm.save_as_mainfile(filepath=blend)
    bpy.ops.wm.open_mainfile(filepath=blend)
    ob = bpy.data.objects[name]
    scene = bpy.context.scene
    assert ob.vtskin.cache is not None and (ob.vtskin.bake_start, ob.vtskin.bake_end) == (1, 4)
    assert scene.vtskin.indenter.name == "indenter" and scene.vtskin.thickness == pytest.approx(0.003)
    np.testing.assert_allclose(attr(ob, "response"), baked["response"][2], rtol=1e-5, atol=1e-3)
    scene.frame_set(4)  # playback after reload, from the cache in the .blend
    np.testing.assert_allclose(attr(ob, "response"), baked["response"][3], rtol=1e-5, atol=1e-3)
    np.testing.assert_array_equal(attr(ob, "taxel_id"), layout.taxel_ids)


def test_augment_point_cloud():
    from addon import bridge
    from vtcore.scene import interactive

    rng = np.random.default_rng(0)
    pts = rng.uniform(-0.05, 0.05, (300, 3))
    me = bpy.data.meshes.new("cloud")
    bridge.write_mesh(me, pts)
    cloud = bpy.data.objects.new("cloud", me)
    bpy.context.scene.collection.objects.link(cloud)
    comp = pts[:, 0] * 100 + 5
    bridge.set_attribute(me, "compliance", comp, "FLOAT")
    sel = np.zeros(300, bool)
    sel[:12] = True
    me.vertices.foreach_set("select", sel)
    s = bpy.context.scene.vtskin
    s.cloud = cloud
    for method in ("cluster", "smooth"):
        s.propagation = method
        assert bpy.ops.vtskin.augment() == {"FINISHED"}
        vals, rgb = interactive.augment(pts, pts[:12], comp[:12], method=method, beta=-300.0)
        np.testing.assert_allclose(attr(cloud, "tactile_value"), vals, rtol=1e-5)
        np.testing.assert_allclose(attr(cloud, "tactile_color")[:, :3], rgb, atol=1e-6)
    assert cloud.vtskin.role == "CLOUD"


def test_export_in_other_frame(skinned, tmp_path):
    from vtcore.layout import load

    ee, ind, _, ob = skinned
    s = bpy.context.scene.vtskin
    bpy.context.view_layer.objects.active = ob
    s.export_format = "json"
    assert bpy.ops.vtskin.export(filepath=str(tmp_path / "own.json")) == {"FINISHED"}
    s.export_frame = ind
    assert bpy.ops.vtskin.export(filepath=str(tmp_path / "ind.json")) == {"FINISHED"}
    own, other = load(tmp_path / "own.json"), load(tmp_path / "ind.json")
    co = np.empty(3 * len(ob.data.vertices), np.float32)
    ob.data.vertices.foreach_get("co", co)
    np.testing.assert_allclose(own.positions, co.reshape(-1, 3), atol=1e-6)
    t = np.linalg.inv(M(ind)) @ M(ob)
    np.testing.assert_allclose(other.positions, own.positions @ t[:3, :3].T + t[:3, 3], atol=1e-6)
    np.testing.assert_array_equal(own.taxel_ids, attr(ob, "taxel_id"))


# ---------------------------------------------------------------------------
# Bad input: an error report, {'CANCELLED'} (RuntimeError from bpy.ops), scene unchanged


def _refused(op, **kw):
    before = scene_state()
    with pytest.raises(RuntimeError, match="Error"):
        op(**kw)
    assert scene_state() == before


def test_bad_input_nothing_selected():
    build_scene()
    bpy.context.view_layer.objects.active = None
    _refused(bpy.ops.vtskin.lay_patch)
    _refused(bpy.ops.vtskin.simulate)
    _refused(bpy.ops.vtskin.edges)
    _refused(bpy.ops.vtskin.export, filepath="/tmp/never.json")
    _refused(bpy.ops.vtskin.remove_module)


def test_bad_input_no_faces_zero_layer_unreadable(skinned, tmp_path):
    from addon import bridge

    ee, ind, centre, ob = skinned
    # An end-effector without faces.
    me = bpy.data.meshes.new("points")
    bridge.write_mesh(me, np.random.default_rng(1).normal(size=(20, 3)) * 0.01)
    pts = bpy.data.objects.new("points", me)
    bpy.context.scene.collection.objects.link(pts)
    bpy.context.view_layer.objects.active = pts
    _refused(bpy.ops.vtskin.lay_patch)
    # Selected-faces placement with no face selected.
    bpy.context.scene.vtskin.place_at = "SELECTED"
    ee.data.polygons.foreach_set("select", np.zeros(len(ee.data.polygons), bool))
    bpy.context.view_layer.objects.active = ee
    _refused(bpy.ops.vtskin.lay_patch)
    _refused(bpy.ops.vtskin.lay_patch, fill=True)
    # An indenter without faces, then a zero-thickness layer.
    s = bpy.context.scene.vtskin
    bpy.context.view_layer.objects.active = ob
    s.indenter = pts
    _refused(bpy.ops.vtskin.simulate)
    s.indenter = ind
    s.thickness = 0.0
    _refused(bpy.ops.vtskin.simulate)
    _refused(bpy.ops.vtskin.bake)
    # A force the layer cannot carry.
    s.thickness = 0.003
    s.force = 500.0
    _refused(bpy.ops.vtskin.simulate)
    # Unreadable files.
    bad = tmp_path / "probes.csv"
    bad.write_text("this,is\nnot,probes\n")
    s.cloud = ob
    s.probe_source = "FILE"
    s.probe_file = str(bad)
    _refused(bpy.ops.vtskin.augment)
    s.probe_file = str(tmp_path / "missing.csv")
    _refused(bpy.ops.vtskin.augment)
    _refused(bpy.ops.vtskin.run_scene, filepath=str(tmp_path / "missing.toml"))
    (tmp_path / "a_dir.json").mkdir()
    _refused(bpy.ops.vtskin.export, filepath=str(tmp_path / "a_dir.json"))
