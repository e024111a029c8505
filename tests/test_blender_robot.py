"""The robot loop through the add-on's operators (issue 25): Import Robot, lay/fill on a link object
that was moved, turned and scaled, Export Skinned Robot, Import Layout of a real CySkin calibration
onto a link and Load Recording of the real recording of that skin; compared with vtcore called
directly; save and reload keeps it. Headless, both bpy lanes."""

from __future__ import annotations

import sys
import warnings
from pathlib import Path

import numpy as np
import pytest

bpy = pytest.importorskip("bpy")
sys.path.insert(0, str(Path(__file__).parent / "blender"))
from bl_helpers import addon_fixtures, scene_state  # noqa: E402

pytestmark = [pytest.mark.blender, pytest.mark.filterwarnings("ignore::UserWarning")]

addon, factory = addon_fixtures()

GESTURE = Path("/work/shared/data/cyskin_gesture")
DATA = next((p for p in (GESTURE, Path(__file__).resolve().parents[2] / "shared" / "data" / "cyskin_gesture")
             if p.is_dir()), GESTURE)


def M(ob):
    return np.array([tuple(r) for r in ob.matrix_world])


def co(ob):
    c = np.empty(3 * len(ob.data.vertices), np.float32)
    ob.data.vertices.foreach_get("co", c)
    return c.reshape(-1, 3).astype(np.float64)


@pytest.fixture(scope="module")
def arm(tmp_path_factory):
    from vtcore.robot.samples import humanoid_arm

    return humanoid_arm(tmp_path_factory.mktemp("arm"))


def import_arm(arm, joints=""):
    s = bpy.context.scene.vtskin
    s.robot_file, s.robot_joints = str(arm), joints
    assert bpy.ops.vtskin.import_robot() == {"FINISHED"}
    return {ob.vtskin.link: ob for ob in bpy.data.objects if ob.vtskin.link}


def test_import_robot_builds_the_kinematic_tree(arm):
    from vtcore.robot import link_mesh, load_robot

    links = import_arm(arm, "l_shoulder_pitch=0.4, l_elbow=-0.7")
    robot = load_robot(arm)
    poses = robot.link_poses({"l_shoulder_pitch": 0.4, "l_elbow": -0.7})
    assert set(links) == set(robot.links)
    for name, ob in links.items():
        np.testing.assert_allclose(M(ob), poses[name], atol=1e-6)
        assert Path(ob.vtskin.robot_file) == arm and ob.vtskin.geometry == "visual"
    assert links["l_forearm"].parent == links["l_upper_arm"] and links["l_upper_arm"].parent == links["torso"]
    assert links["l_forearm_skin_3"].parent == links["l_forearm"]
    np.testing.assert_allclose(co(links["l_forearm"]), link_mesh(robot, "l_forearm").vertices, atol=1e-6)
    # issue 33: each link's faces coloured by its exposed surface, the legend on the link object
    from vtcore.robot.exposure import exposed_faces, face_colours

    me = links["l_forearm"].data
    attr = me.attributes["vtskin_exposure"]
    assert attr.domain == "FACE" and attr.data_type == "FLOAT_COLOR" and "VTSkin exposure" in me.materials
    got = np.empty(4 * len(me.polygons), np.float32)
    attr.data.foreach_get("color", got)
    want = face_colours(exposed_faces(robot, "l_forearm", poses=0).reason)
    np.testing.assert_allclose(got.reshape(-1, 4), want, atol=1e-6)
    assert links["l_forearm"].vtskin.exposure_legend.startswith("green: exposed, ")


def test_import_robot_bad_input_changes_nothing(arm, tmp_path):
    before = scene_state()
    s = bpy.context.scene.vtskin
    for file, joints in ((tmp_path / "none.urdf", ""), (arm, "l_elbow=abc"), (arm, "knee=1")):
        s.robot_file, s.robot_joints = str(file), joints
        with pytest.raises(RuntimeError, match="Cannot import the robot"):
            bpy.ops.vtskin.import_robot()
    assert scene_state() == before


def lay_on(ob, local_point, fill=False):
    """The 3D cursor at ``local_point`` of ``ob`` (in world), ``ob`` active, Lay Patch."""
    m = M(ob)
    bpy.context.scene.cursor.location = m[:3, :3] @ local_point + m[:3, 3]
    bpy.context.view_layer.objects.active = ob
    assert bpy.ops.vtskin.lay_patch(fill=fill) == {"FINISHED"}
    return next(o for o in bpy.data.objects if o.vtskin.role == "TAXELS" and o.vtskin.end_effector == ob)


def test_skin_on_a_moved_turned_scaled_link_is_in_the_link_frame_and_exports_into_the_robot(arm, tmp_path):
    from vtcore.robot import export_skinned, link_mesh, load_robot
    from vtcore.robot.model import pose
    from vtcore.robot.samples import FOREARM_VISUAL_ORIGIN
    from vtcore.robot.verify import check_mjcf, check_urdf
    from vtcore.scene import interactive

    from addon import bridge

    links = import_arm(arm, "l_elbow=0.5")
    fore = links["l_forearm"]
    turn = np.eye(4)
    turn[:3, :3] = [[0, -1, 0], [1, 0, 0], [0, 0, 1]]
    turn[:3, 3] = [0.3, -0.2, 0.1]
    fore.matrix_world = bridge.to_matrix(turn @ M(fore) @ np.diag([1.5, 1.5, 1.5, 1.0]))
    robot = load_robot(arm)
    mesh = link_mesh(robot, "l_forearm")
    at = (pose(*FOREARM_VISUAL_ORIGIN) @ [0.0, -0.036, -0.04, 1.0])[:3]  # the tube's side, in the link frame
    ob = lay_on(fore, at)
    assert ob.parent == fore
    # vtcore called directly on the link's geometry as the object holds it (float32) at the same point
    from addon import opbase

    verts, tri = opbase.mesh_in_frame(fore, opbase.skin_frame(fore))
    np.testing.assert_allclose(verts, mesh.vertices, atol=1e-6)  # the link's own coordinates, not the scene's
    cursor = np.array(bpy.context.scene.cursor.location, dtype=np.float64)
    local = np.linalg.inv(M(fore)) @ np.r_[cursor, 1.0]
    ref = interactive.lay_patch(verts, tri, local[:3], direction=[1.0, 0, 0])
    np.testing.assert_allclose(co(ob), ref.layout.positions, atol=1e-6)
    assert ob.vtskin.strain_max < 5.0  # percent
    np.testing.assert_array_equal(np.sort(bridge.get_attribute(ob.data, "taxel_id")), np.sort(ref.layout.taxel_ids))
    s = bpy.context.scene.vtskin
    bpy.context.view_layer.objects.active = fore
    for fmt, ext in (("urdf", "urdf"), ("mjcf", "xml")):
        s.skinned_format, s.skinned_path = fmt, str(tmp_path / f"blender.{ext}")
        assert bpy.ops.vtskin.export_robot() == {"FINISHED"}
    configs = [{}, {"l_shoulder_pitch": -0.8, "l_elbow": 1.1}]
    pk = {"humanoid_description": arm.parents[1]}
    st = check_urdf(tmp_path / "blender.urdf", configs, packages=pk)["l_forearm"]
    assert st["taxels"] == 60 and st["max_mm"] < 0.5 and st["max_deg"] < 5
    st = check_mjcf(tmp_path / "blender.xml", {"l_forearm": mesh}, configs)["l_forearm"]
    assert st["taxels"] == 60 and st["max_mm"] < 0.5 and st["max_deg"] < 5
    # the same robot as vtcore writes from vtcore's own placement, up to Blender's float32 coordinates
    direct = ref.layout
    direct.frame = "l_forearm"
    export_skinned(arm, [direct], tmp_path / "direct.urdf")
    import yourdfpy

    a = yourdfpy.URDF.load(str(tmp_path / "blender.urdf"), load_meshes=False)
    b = yourdfpy.URDF.load(str(tmp_path / "direct.urdf"), load_meshes=False)
    names = sorted(n for n in b.link_map if "_vtskin_" in n)
    assert names == sorted(n for n in a.link_map if "_vtskin_" in n)
    for n in names:
        np.testing.assert_allclose(a.get_transform(n, "l_forearm"), b.get_transform(n, "l_forearm"), atol=1e-5)


def test_fill_on_an_imported_link_is_vtcores_fill_and_the_skinned_robot_survives_reload(arm, tmp_path):
    """Import Robot at a joint configuration, the upper arm moved and turned in the scene (its
    children follow), Fill round the cursor through the operator: the same skin as vtcore's fill of
    the link's geometry (its exposed surface) in its own frame; Export Skinned Robot writes what vtcore's export writes,
    every taxel on the link in yourdfpy and MuJoCo; after save and reload the export is the same file."""
    from vtcore.robot import export_skinned, link_mesh, load_robot
    from vtcore.robot.verify import check_mjcf, check_urdf
    from vtcore.scene import interactive

    from addon import bridge, opbase

    links = import_arm(arm, "l_shoulder_pitch=0.3, l_elbow=0.5")
    upper = links["l_upper_arm"]
    turn = np.eye(4)
    turn[:3, :3] = [[0, 0, 1], [0, 1, 0], [-1, 0, 0]]
    turn[:3, 3] = [-0.2, 0.4, 0.3]
    upper.matrix_world = bridge.to_matrix(turn @ M(upper))
    s = bpy.context.scene.vtskin
    s.fill_region, s.fill_radius = "RADIUS", 0.035
    at = np.array([0.04, 0.0, 0.12])  # the side of the upper arm's cylinder, in the link frame
    ob = lay_on(upper, at, fill=True)
    robot = load_robot(arm)
    verts, tri = opbase.mesh_in_frame(upper, opbase.skin_frame(upper))
    np.testing.assert_allclose(verts, link_mesh(robot, "l_upper_arm").vertices, atol=1e-6)
    cursor = np.linalg.inv(M(upper)) @ np.r_[np.array(bpy.context.scene.cursor.location, dtype=np.float64), 1.0]
    # a Fill on a link is vtcore's fill of that link's exposed surface (issue 33; test_blender_fill_link.py)
    link = {"robot": str(arm), "link": "l_upper_arm", "geometry": "visual", "packages": {}, "anywhere": False}
    ref = interactive.lay_patch(verts, tri, cursor[:3], direction=[1.0, 0, 0], radius=0.035, max_faces=s.solve_faces,
                                crease_angle=float(np.degrees(s.crease_angle)), islands=s.islands, link=link)
    assert len(ref.layout) >= 40  # several modules: a fill, not a patch
    np.testing.assert_allclose(co(ob), ref.layout.positions, atol=1e-6)
    np.testing.assert_array_equal(bridge.get_attribute(ob.data, "taxel_id"), ref.layout.taxel_ids)
    bpy.context.view_layer.objects.active = upper
    for fmt, ext in (("urdf", "urdf"), ("mjcf", "xml")):
        s.skinned_format, s.skinned_path = fmt, str(tmp_path / f"blender.{ext}")
        assert bpy.ops.vtskin.export_robot() == {"FINISHED"}
    configs = [{}, {"l_shoulder_pitch": -0.8, "l_elbow": 1.1}, {"l_shoulder_pitch": 1.2, "l_elbow": -1.5}]
    pk = {"humanoid_description": arm.parents[1]}
    for st in (check_urdf(tmp_path / "blender.urdf", configs, packages=pk)["l_upper_arm"],
               check_mjcf(tmp_path / "blender.xml", {"l_upper_arm": link_mesh(robot, "l_upper_arm")},
                          configs)["l_upper_arm"]):
        assert st["taxels"] == len(ref.layout) and st["max_mm"] < 0.5 and st["max_deg"] < 5, st
    direct = ref.layout
    direct.frame = "l_upper_arm"
    export_skinned(arm, [direct], tmp_path / "direct.xml")
    import mujoco

    a, b = (mujoco.MjModel.from_xml_path(str(tmp_path / f)) for f in ("blender.xml", "direct.xml"))
    assert a.nsensor == b.nsensor == len(direct)
    np.testing.assert_allclose(a.site_pos, b.site_pos, atol=1e-6)
    np.testing.assert_allclose(a.site_quat, b.site_quat, atol=1e-5)
    before = (tmp_path / "blender.xml").read_text()
    path = tmp_path / "filled.blend"
    bpy.ops.wm.save_as_mainfile(filepath=str(path), compress=True)
    bpy.ops.wm.open_mainfile(filepath=str(path))
    s = bpy.context.scene.vtskin
    assert (s.fill_region, s.fill_radius, s.skinned_format) == ("RADIUS", pytest.approx(0.035), "mjcf")
    (tmp_path / "blender.xml").unlink()
    bpy.context.view_layer.objects.active = bpy.data.objects["l_upper_arm"]
    assert bpy.ops.vtskin.export_robot() == {"FINISHED"}  # the panel's path and options, as saved
    assert (tmp_path / "blender.xml").read_text() == before


def test_export_of_a_moved_hand_is_in_its_own_frame(tmp_path):
    """The issue's report: a hand moved to x = 0.3 exported URDF origins at 0.330; 'In frame of' the
    hand gave a byte-identical file. Now the skin is in the hand's frame, and In frame of says where."""
    import trimesh
    import yourdfpy

    from addon import bridge

    box = trimesh.creation.box(extents=(0.12, 0.12, 0.06))  # a hand's back: the hexagon lies on its top
    me = bpy.data.meshes.new("hand")
    bridge.write_mesh(me, box.vertices, box.faces)
    hand = bpy.data.objects.new("hand", me)
    bpy.context.scene.collection.objects.link(hand)
    hand.location = (0.3, 0.0, 0.0)
    bpy.context.view_layer.update()
    ob = lay_on(hand, np.array([0.0, 0.0, 0.03]))
    s = bpy.context.scene.vtskin
    bpy.context.view_layer.objects.active = ob
    s.export_format = "urdf"
    assert bpy.ops.vtskin.export(filepath=str(tmp_path / "own.urdf")) == {"FINISHED"}
    s.export_frame = hand
    assert bpy.ops.vtskin.export(filepath=str(tmp_path / "hand.urdf")) == {"FINISHED"}
    assert (tmp_path / "own.urdf").read_bytes() == (tmp_path / "hand.urdf").read_bytes()
    u = yourdfpy.URDF.load(str(tmp_path / "own.urdf"), load_meshes=False)
    assert u.base_link == "hand"
    origins = np.array([u.get_transform(n, "hand")[:3, 3] for n in u.link_map if "_vtskin_" in n])
    assert np.abs(origins[:, 0]).max() < 0.031 and np.allclose(origins[:, 2], 0.03, atol=1e-6)
    other = bpy.data.objects.new("base", None)
    bpy.context.scene.collection.objects.link(other)
    other.location = (0.1, 0.0, 0.0)
    bpy.context.view_layer.update()
    s.export_frame = other
    assert bpy.ops.vtskin.export(filepath=str(tmp_path / "base.urdf")) == {"FINISHED"}
    u = yourdfpy.URDF.load(str(tmp_path / "base.urdf"), load_meshes=False)
    assert u.base_link == "base"
    moved = np.array([u.get_transform(n, "base")[:3, 3] for n in u.link_map if "_vtskin_" in n])
    np.testing.assert_allclose(moved, origins + [0.2, 0, 0], atol=1e-6)


@pytest.mark.skipif(not DATA.is_dir(), reason="the shared CySkin recordings are not here")
def test_import_real_layout_on_a_link_replays_the_real_recording_and_survives_reload(arm, tmp_path):
    from vtcore.can.timeline import load_recording
    from vtcore.layout import load

    from addon import bridge

    links = import_arm(arm)
    fore = links["l_forearm"]
    s = bpy.context.scene.vtskin
    s.layout_file = str(DATA / "curved_gesture_patch_full_isomap.json")
    bpy.context.view_layer.objects.active = fore
    assert bpy.ops.vtskin.import_layout() == {"FINISHED"}
    ob = next(o for o in bpy.data.objects if o.vtskin.role == "TAXELS")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        ref = load(s.layout_file)
    assert ob.parent == fore and ob.vtskin.end_effector == fore
    np.testing.assert_array_equal(bridge.get_attribute(ob.data, "taxel_id"), ref.taxel_ids)  # ids intact
    t = ref.transform  # the file's tf_matrix: the patch's pose in the link it is put on
    np.testing.assert_allclose(co(ob), ref.positions @ t[:3, :3].T + t[:3, 3], atol=1e-6)
    rec = DATA / "1_finger" / "sample_01.txt"
    bpy.context.view_layer.objects.active = ob
    s.recording_codec, s.recording_file, s.replay_rate = "cyskin-txt", str(rec), "RECORDING"
    assert bpy.ops.vtskin.load_recording() == {"FINISHED"}
    rep = load_recording(rec, ref, np.asarray(ref.meta["faces"]), kind="cyskin-txt", fps=None)
    assert ob.vtskin.replay_report.splitlines()[:2] == rep.mismatch()  # the same taxels joined by UID
    assert len(rep.layout_only) <= 1  # every placed taxel recorded (id 0: the file's unassigned position)
    frame = bpy.context.scene.frame_start + int(np.argmax(rep.response.max(axis=1)))
    bpy.context.scene.frame_set(frame)
    got = bridge.get_attribute(ob.data, "response_compensated")
    np.testing.assert_allclose(got, rep.response[rep.rows[frame - bpy.context.scene.frame_start]], rtol=1e-5,
                               atol=1e-3)
    assert got.max() > 5000  # the finger press
    # save and reload: the links, the skin on its link, the replay and the panel's settings
    path, name = tmp_path / "skinned.blend", ob.name
    bpy.ops.wm.save_as_mainfile(filepath=str(path), compress=True)
    bpy.ops.wm.open_mainfile(filepath=str(path))
    ob = bpy.data.objects[name]
    fore = bpy.data.objects["l_forearm"]
    assert fore.vtskin.link == "l_forearm" and Path(fore.vtskin.robot_file) == arm
    assert ob.parent == fore and bpy.context.scene.vtskin.layout_file.endswith("isomap.json")
    bpy.context.scene.frame_set(frame)
    np.testing.assert_allclose(bridge.get_attribute(ob.data, "response_compensated"), got)
    s = bpy.context.scene.vtskin
    s.skinned_format, s.skinned_path = "urdf", str(tmp_path / "after_reload.urdf")
    bpy.context.view_layer.objects.active = fore
    assert bpy.ops.vtskin.export_robot() == {"FINISHED"}
    import yourdfpy

    u = yourdfpy.URDF.load(str(tmp_path / "after_reload.urdf"), load_meshes=False)
    assert len([n for n in u.link_map if n.startswith("l_forearm_vtskin_")]) == len(ref)
