"""Skin Whole Robot from the add-on's robot panel (issue 36): the operator calls
``vtcore.robot.skin_robot`` and writes the same files as ``vtcore robot skin``; a robot file or folder
not given cancels with one line. Headless, both bpy lanes."""

from __future__ import annotations

import json
import sys
from pathlib import Path

import pytest

bpy = pytest.importorskip("bpy")
sys.path.insert(0, str(Path(__file__).parent / "blender"))
from bl_helpers import addon_fixtures  # noqa: E402

pytestmark = [pytest.mark.blender, pytest.mark.filterwarnings("ignore::UserWarning")]

addon, factory = addon_fixtures()


def test_skin_whole_robot_writes_layouts_robot_and_report(tmp_path):
    urdf = tmp_path / "bot.urdf"
    urdf.write_text('<?xml version="1.0"?>\n<robot name="bot"><link name="base"/><link name="plate"><collision>'
                    '<geometry><box size="0.09 0.06 0.05"/></geometry></collision></link>'
                    '<joint name="j" type="fixed"><parent link="base"/><child link="plate"/></joint></robot>\n')
    s = bpy.context.scene.vtskin
    s.robot_file, s.robot_geometry = str(urdf), "collision"
    with pytest.raises(RuntimeError, match="Choose the folder"):  # no folder chosen: nothing written
        bpy.ops.vtskin.skin_robot()
    s.skin_robot_dir = str(tmp_path / "out")
    assert bpy.ops.vtskin.skin_robot() == {"FINISHED"}
    rep = json.loads((tmp_path / "out" / "skin_report.json").read_text())
    plate = next(r for r in rep["links"] if r["link"] == "plate")
    assert plate["status"] == "ok" and plate["modules"] >= 4
    assert (tmp_path / "out" / "layouts" / "plate.json").is_file()
    assert "vtskin" in (tmp_path / "out" / "bot_skinned.urdf").read_text()
