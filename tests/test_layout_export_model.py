"""``vtcore layout export --model ROBOT`` and ``vtcore robot export`` are one export (vtcore.robot's):
the same inputs write the same bytes, for a URDF and an MJCF robot whose meshes sit in another
folder than the output (their relative paths rebased alike, and still resolving from the output)."""

from __future__ import annotations

import os
import xml.etree.ElementTree as ET

import numpy as np
import pytest

from vtcore.cli import main
from vtcore.layout import make_patch, save

URDF = """<?xml version="1.0"?>
<robot name="arm">
  <!-- the robot's own comment stays -->
  <link name="base"/>
  <link name="plate">
    <visual><geometry><mesh filename="meshes/plate.stl"/></geometry></visual>
    <collision><geometry><mesh filename="meshes/plate.stl"/></geometry></collision>
  </link>
  <joint name="lift" type="prismatic"><parent link="base"/><child link="plate"/>
    <axis xyz="0 0 1"/><limit lower="0" upper="0.1" effort="1" velocity="1"/></joint>
</robot>
"""

MJCF = """<mujoco model="arm">
  <!-- the robot's own comment stays -->
  <compiler meshdir="meshes"/>
  <asset><mesh name="plate" file="plate.stl"/></asset>
  <worldbody>
    <body name="plate" pos="0 0 0.5"><geom type="mesh" mesh="plate"/></body>
  </worldbody>
</mujoco>
"""


@pytest.fixture
def robots(tmp_path):
    """A URDF and an MJCF robot in ``robot/`` with their mesh in ``robot/meshes/``, and a 10 mm thick
    plate's skin (a triangle patch on its top face) in the frame ``patch``, 3 cm off the link's origin."""
    import trimesh

    (tmp_path / "robot" / "meshes").mkdir(parents=True)
    trimesh.creation.box((0.12, 0.12, 0.01)).export(tmp_path / "robot" / "meshes" / "plate.stl")
    (tmp_path / "robot" / "arm.urdf").write_text(URDF)
    (tmp_path / "robot" / "arm.xml").write_text(MJCF)
    lay = make_patch("triangle").flat_layout()
    lay.frame = "patch"
    pose = np.eye(4)
    pose[:3, 3] = [0.0, 0.0, 0.005 - 0.03]
    lay.positions[:, 2] += 0.03  # the patch's frame sits 3 cm under the plate's top face
    return tmp_path, lay, pose


def export_both(tmp_path, robot, layout_args, robot_layout, name):
    """(layout export's bytes, robot export's bytes), each written to a folder of its own beside ``robot/``."""
    save(robot_layout, tmp_path / "in_link.json")
    a, b = tmp_path / "by_layout" / name, tmp_path / "by_robot" / name
    assert main(["layout", "export", *layout_args, "--model", str(robot), "--out", str(a)]) == 0
    assert main(["robot", "export", str(robot), str(tmp_path / "in_link.json"), "--out", str(b)]) == 0
    return a, b


def test_urdf_robot_same_file_from_both_commands(robots):
    tmp_path, lay, pose = robots
    save(lay, tmp_path / "patch.json")
    np.savetxt(tmp_path / "pose.txt", pose.reshape(1, 16))
    a, b = export_both(tmp_path, tmp_path / "robot" / "arm.urdf",
                       [str(tmp_path / "patch.json"), "--format", "urdf", "--parent", "plate",
                        "--transform", str(tmp_path / "pose.txt")],
                       lay.posed(pose, "plate"), "skinned.urdf")
    assert a.read_bytes() == b.read_bytes()
    root = ET.parse(a).getroot()
    meshes = {m.get("filename") for m in root.iter("mesh")}
    assert meshes == {os.path.join("..", "robot", "meshes", "plate.stl")}  # rebased, resolving from the output
    assert all((a.parent / f).is_file() for f in meshes)
    assert sum(1 for j in root.iter("joint") if j.get("name").startswith("plate_vtskin_")) == len(lay)
    assert "the robot's own comment stays" in a.read_text()


def test_mjcf_robot_same_file_from_both_commands(robots):
    import mujoco

    tmp_path, lay, pose = robots
    in_link = lay.posed(pose, "plate")
    save(in_link, tmp_path / "posed.json")
    a, b = export_both(tmp_path, tmp_path / "robot" / "arm.xml",
                       [str(tmp_path / "posed.json"), "--format", "mjcf", "--body", "plate"],
                       in_link, "skinned.xml")
    assert a.read_bytes() == b.read_bytes()
    root = ET.parse(a).getroot()
    assert root.find("compiler").get("meshdir") == os.path.join("..", "robot", "meshes")
    m = mujoco.MjModel.from_xml_path(str(a))  # its mesh found from the output's folder
    assert m.nsensor == len(lay) and m.nmesh >= 1
    d = mujoco.MjData(m)
    mujoco.mj_kinematics(m, d)
    ids = [m.site(f"plate_vtskin_{i}").id for i in lay.taxel_ids]
    np.testing.assert_allclose(d.site_xpos[ids][:, 2], 0.5 + 0.005, atol=1e-6)  # on the plate's top face


def test_robot_options_without_a_robot_are_refused(robots, capsys):
    tmp_path, lay, _ = robots
    save(lay, tmp_path / "patch.json")
    for flags in (["--format", "mjcf", "--body", "plate"], ["--format", "urdf", "--package", f"arm={tmp_path}"]):
        assert main(["layout", "export", str(tmp_path / "patch.json"), *flags, "--out", str(tmp_path / "x.xml")]) == 2
        assert "goes with --model ROBOT" in capsys.readouterr().err
    assert not (tmp_path / "x.xml").exists()
