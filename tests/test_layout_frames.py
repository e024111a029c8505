"""One frame model (issue 25): a layout's positions are in its ``frame``; ``transform`` is the pose of
that frame in ``parent`` (p_parent = R p + t). Exports into a robot honour a transform the user gives,
``layout reframe`` says where a frame is or re-expresses the taxels, and merged names never clash
silently."""

from __future__ import annotations

import json
import warnings

import numpy as np
import pytest

from vtcore.cli import main
from vtcore.errors import InputError
from vtcore.layout import Layout, LayoutWarning, load, place, save
from vtcore.layout.cadmeshes import cad_link
from vtcore.layout.io import in_link
from vtcore.robot import mjcf_tree, urdf_tree

# the visual origin of the forearm's CAD mesh in its link (a rotation about an oblique axis and 0.2 m)
RPY, XYZ = (0.3, -1.1, 0.7), (0.02, -0.05, 0.2)


def origin_matrix(rpy=RPY, xyz=XYZ):
    from scipy.spatial.transform import Rotation

    t = np.eye(4)
    t[:3, :3] = Rotation.from_euler("xyz", rpy).as_matrix()
    t[:3, 3] = xyz
    return t


@pytest.fixture(scope="module")
def cad_forearm(tmp_path_factory):
    """A CAD forearm in millimetres (STL), a URDF placing it by a visual origin with scale 0.001 (and
    24 skin frames of its own, as iCub's has), and a hexagon laid on the loose mesh in its CAD frame."""
    d = tmp_path_factory.mktemp("forearm")
    mm = cad_link(radius=0.036, length=0.2, mm=True)
    mm.export(d / "forearm_cad.stl")
    frames = "".join(f'<link name="l_forearm_skin_{i}"/><joint name="l_forearm_skin_{i}_joint" type="fixed">'
                     f'<parent link="l_forearm"/><child link="l_forearm_skin_{i}"/>'
                     f'<origin xyz="0 0 {0.01 * i}"/></joint>' for i in range(24))
    (d / "robot.urdf").write_text(f"""<?xml version="1.0"?>
<robot name="arm">
  <link name="l_upper_arm"/>
  <joint name="l_elbow" type="revolute">
    <parent link="l_upper_arm"/><child link="l_forearm"/>
    <origin xyz="0 0 0.3" rpy="0 0 0"/><axis xyz="0 1 0"/><limit lower="-2" upper="2" effort="1" velocity="1"/>
  </joint>
  <link name="l_forearm">
    <visual>
      <origin xyz="{' '.join(map(str, XYZ))}" rpy="{' '.join(map(str, RPY))}"/>
      <geometry><mesh filename="forearm_cad.stl" scale="0.001 0.001 0.001"/></geometry>
    </visual>
  </link>
  {frames}
</robot>
""")
    metres = mm.copy()
    metres.apply_scale(1e-3)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        lay, _ = place(metres, "hexagon", (0.036, 0.0, 0.0), (0, 0, 1))
    lay.frame = "forearm_cad"
    save(lay, d / "hexagon.json")
    on_link = metres.copy()
    on_link.apply_transform(origin_matrix())
    return d, lay, on_link


def urdf_taxels(path, link, prefix):
    import yourdfpy

    robot = yourdfpy.URDF.load(str(path), load_meshes=False, build_scene_graph=True)
    names = sorted((n for n in robot.link_map if n.startswith(prefix)), key=lambda n: int(n[len(prefix):]))
    frames = np.array([robot.get_transform(n, link) for n in names])
    return names, frames


def off_mesh_mm(points, mesh):
    import trimesh

    _, dist, _ = trimesh.proximity.closest_point(mesh, points)
    return dist * 1e3


def test_urdf_export_honours_the_transform(cad_forearm, tmp_path):
    """The issue's first report: --transform (the link's visual origin) was undone by the writer."""
    d, lay, on_link = cad_forearm
    t = origin_matrix()
    np.savetxt(tmp_path / "origin.txt", t.reshape(1, 16))
    assert main(["layout", "export", str(d / "hexagon.json"), "--format", "urdf", "--parent", "l_forearm",
                 "--model", str(d / "robot.urdf"), "--transform", str(tmp_path / "origin.txt"),
                 "--out", str(tmp_path / "skinned.urdf")]) == 0
    names, frames = urdf_taxels(tmp_path / "skinned.urdf", "l_forearm", "l_forearm_vtskin_")
    assert len(names) == len(lay) == 60
    assert off_mesh_mm(frames[:, :3, 3], on_link).max() < 0.5
    np.testing.assert_allclose(frames[:, :3, 2], lay.normals @ t[:3, :3].T, atol=1e-9)
    # the robot's own 24 skin frames are still there, unchanged
    _, own = urdf_taxels(tmp_path / "skinned.urdf", "l_forearm", "l_forearm_skin_")
    np.testing.assert_allclose(own[:, 2, 3], 0.01 * np.arange(24))


def test_mjcf_export_honours_the_transform(cad_forearm, tmp_path):
    import mujoco

    d, lay, on_link = cad_forearm
    t = origin_matrix()
    (tmp_path / "robot.xml").write_text('<mujoco><worldbody><body name="l_forearm" pos="0.1 0 0">'
                                        '<geom type="box" size="0.01 0.01 0.01"/></body></worldbody></mujoco>')
    mjcf_tree.write_skinned(in_link(lay, t), tmp_path / "skinned.xml", tmp_path / "robot.xml", body="l_forearm")
    m = mujoco.MjModel.from_xml_path(str(tmp_path / "skinned.xml"))
    data = mujoco.MjData(m)
    mujoco.mj_kinematics(m, data)
    sites = np.array([data.site(f"l_forearm_vtskin_{i}").xpos for i in lay.taxel_ids]) - [0.1, 0, 0]
    assert off_mesh_mm(sites, on_link).max() < 0.5


def test_reframe_pose_then_export_is_the_same_file(cad_forearm, tmp_path):
    """Saying where the frame is (reframe --pose) and exporting without --transform writes what
    exporting with --transform does; --into-parent then gives the same taxels in the link."""
    d, lay, on_link = cad_forearm
    t = origin_matrix()
    nums = [repr(float(v)) for v in t.ravel()]
    assert main(["layout", "reframe", str(d / "hexagon.json"), "--pose", *nums, "--parent", "l_forearm",
                 "--out", str(tmp_path / "posed.json")]) == 0
    posed = load(tmp_path / "posed.json")
    assert posed.parent == "l_forearm" and posed.frame == "forearm_cad"
    np.testing.assert_array_equal(posed.positions, lay.positions)
    np.testing.assert_allclose(posed.transform, t)
    assert main(["layout", "export", str(tmp_path / "posed.json"), "--format", "urdf", "--model",
                 str(d / "robot.urdf"), "--out", str(tmp_path / "a.urdf")]) == 0  # parent: the layout's own
    assert main(["layout", "export", str(d / "hexagon.json"), "--format", "urdf", "--parent", "l_forearm",
                 "--model", str(d / "robot.urdf"), "--transform", *nums, "--out", str(tmp_path / "b.urdf")]) == 0
    assert (tmp_path / "a.urdf").read_bytes() == (tmp_path / "b.urdf").read_bytes()
    assert main(["layout", "reframe", str(tmp_path / "posed.json"), "--into-parent",
                 "--out", str(tmp_path / "in_link.csv")]) == 0
    in_link = load(tmp_path / "in_link.csv")
    assert in_link.frame == "l_forearm" and in_link.parent is None
    np.testing.assert_array_equal(in_link.transform, np.eye(4))
    assert off_mesh_mm(in_link.positions, on_link).max() < 0.5
    np.testing.assert_allclose(in_link.positions, lay.positions @ t[:3, :3].T + t[:3, 3], atol=1e-12)


def test_reframe_errors(cad_forearm, tmp_path, capsys):
    d, _, _ = cad_forearm
    assert main(["layout", "reframe", str(d / "hexagon.json"), "--out", str(tmp_path / "x.json")]) == 2
    assert "--pose" in capsys.readouterr().err
    t = origin_matrix()
    lay = load(d / "hexagon.json").posed(t)  # placed in an unnamed parent
    with pytest.raises(InputError, match="name the parent"):
        lay.in_parent()
    with pytest.raises(InputError, match="rigid"):
        lay.posed(np.diag([2.0, 1, 1, 1]))


def test_a_given_transform_that_replaces_the_layouts_own_is_warned(cad_forearm, tmp_path):
    d, lay, _ = cad_forearm
    posed = lay.posed(origin_matrix(), "l_forearm")
    other = origin_matrix((0, 0, 0), (0, 0, 0.1))
    with pytest.warns(LayoutWarning, match="replaces the layout's own"):
        save(posed, tmp_path / "w.urdf", "urdf", transform=other)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        save(posed, tmp_path / "same.urdf", "urdf", transform=origin_matrix())  # the same pose: no warning
        save(posed, tmp_path / "own.urdf", "urdf")


def test_frame_parent_and_transform_survive_every_format_that_has_them(cad_forearm, tmp_path):
    _, lay, _ = cad_forearm
    posed = lay.posed(origin_matrix(), "l_forearm")
    for ext in ("json", "csv", "ply"):
        save(posed, tmp_path / f"p.{ext}")
        back = load(tmp_path / f"p.{ext}")
        assert (back.frame, back.parent) == ("forearm_cad", "l_forearm"), ext
        np.testing.assert_allclose(back.transform, posed.transform, atol=1e-15)
    save(posed, tmp_path / "c.json", "cyskin")  # CySkin: tf_matrix in the parent frame the file names
    doc = json.loads((tmp_path / "c.json").read_text())
    assert doc["skin"]["parent_frames"][0]["name"] == "l_forearm"
    np.testing.assert_allclose(np.reshape(doc["skin"]["parent_frames"][0]["tf_matrix"], (4, 4)).T,
                               origin_matrix(), atol=1e-12)
    assert load(tmp_path / "c.json", "cyskin").parent == "l_forearm"


def test_a_robot_with_skin_frames_takes_a_second_skin_and_a_clash_names_the_option(cad_forearm, tmp_path):
    d, lay, _ = cad_forearm
    posed = lay.posed(origin_matrix(), "l_forearm")
    urdf_tree.write_skinned(posed, tmp_path / "once.urdf", d / "robot.urdf")
    with pytest.raises(InputError, match=r"links or joints named l_forearm_vtskin_\d+.*--prefix"):
        urdf_tree.write_skinned(posed, tmp_path / "twice.urdf", tmp_path / "once.urdf")
    urdf_tree.write_skinned(posed, tmp_path / "twice.urdf", tmp_path / "once.urdf", prefix="l_forearm_palm_")
    with pytest.raises(InputError, match=r"l_forearm_skin_1[0-9]?, .*and \d+ more.*--prefix"):
        urdf_tree.write_skinned(posed, tmp_path / "x.urdf", d / "robot.urdf", prefix="l_forearm_skin_")
    with pytest.raises(InputError, match="not a valid name prefix"):
        urdf_tree.write_skinned(posed, tmp_path / "x.urdf", d / "robot.urdf", prefix="my skin/")
    assert not (tmp_path / "x.urdf").exists()


def test_names_with_spaces_and_slashes_become_identifiers(tmp_path):
    import yourdfpy

    lay = Layout(np.eye(3) * 0.01, np.tile([0, 0, 1.0], (3, 1)), [17, 18, 19], [0, 0, 0], frame="hand collision/1")
    save(lay, tmp_path / "f.urdf", "urdf")
    robot = yourdfpy.URDF.load(str(tmp_path / "f.urdf"), load_meshes=False)
    skin = [n for n in robot.link_map if "vtskin" in n]
    assert sorted(skin) == ["hand_collision_1_vtskin_17", "hand_collision_1_vtskin_18", "hand_collision_1_vtskin_19"]
    save(lay, tmp_path / "f.xml", "mjcf")
    import mujoco

    m = mujoco.MjModel.from_xml_path(str(tmp_path / "f.xml"))
    assert m.body(1).name == "hand_collision_1"
