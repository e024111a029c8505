"""Exported sensors that can sense (issue 33): in the merged MJCF of the G1 and the Allegro hand
(example-robot-data), frozen at the zero pose and a random configuration, a 20 g ball dropped on a
taxel along its normal (a slide joint) makes the skinned link's touch sensors read m g; the export
names the taxels another link covers (the G1 wrist's face that mates with the elbow).
``scripts/robot_drops.py`` runs the issue's 20+ drops per robot."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from vtcore.robot import export_skinned, lay_on_link, load_robot
from vtcore.robot.drops import BALL_KG, G, drop_many
from vtcore.robot.samples import example_robot_data

pytestmark = [pytest.mark.filterwarnings("ignore::UserWarning"), pytest.mark.slow]
coacd = pytest.importorskip("coacd")


def skinned(rel, links, out, exposure=True):
    erd = example_robot_data()
    robot = load_robot(erd / rel, {"example-robot-data": erd.parent})
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        layouts = [lay_on_link(robot, link, "fill", geometry=geometry, exposure=exposure)[0]
                   for link, geometry in links]
    records = export_skinned(robot.path, layouts, out, packages={"example-robot-data": erd.parent})
    q = robot.random_configuration(np.random.default_rng(1))
    return robot, records, [{}, {j.name: robot.joint_value(j, q) for j in robot.moving_joints}]


def test_balls_on_readable_g1_taxels_read_mg_and_covered_ones_are_named(tmp_path):
    """Filled anywhere (``exposure=False``: the behaviour before the exposed surface), the wrist's
    taxels on the face that mates with the elbow are named by the export as covered; the readable
    ones read m g. Filled on the exposed surface (the default), the export names none."""
    robot, records, configs = skinned("g1_description/urdf/g1_29dof_with_hand_rev_1_0.urdf",
                                      [("left_wrist_roll_link", "visual"), ("left_elbow_link", "visual")],
                                      tmp_path / "g1.xml", exposure=False)
    wrist = records[0]
    assert wrist["unreadable"] and all(wrist["unreadable_why"][n] == "covered by left_elbow_link"
                                       for n in wrist["unreadable"])  # the face that mates with the elbow
    bad = {n for r in records for n in r["unreadable"]}
    import mujoco

    m = mujoco.MjModel.from_xml_path(str(tmp_path / "g1.xml"))
    readable = {m.site(k).name for k in range(m.nsite)} - bad
    # the check is the zero pose's: at other poses a neighbour may cover a taxel (elbow_89 at some)
    rows = drop_many(tmp_path / "g1.xml", ["left_wrist_roll_link", "left_elbow_link"], 4, configurations=configs[:1],
                     readable=readable)
    assert all(abs(r["ratio"] - 1) <= 0.05 for r in rows), rows
    _, exposed, _ = skinned("g1_description/urdf/g1_29dof_with_hand_rev_1_0.urdf",
                            [("left_wrist_roll_link", "visual")], tmp_path / "g1_exposed.xml")
    # none covered by another link (the mating face's taxels were); a ball 17 mm wide may rest on the wrist
    # pitch beside one (the exposure's 8 mm probe may cut 2 mm into a neighbour), which MuJoCo's rays now see:
    # the pitch link collides by convex parts, no longer by a hull that mj_ray does not see (it hits the mesh)
    why = exposed[0]["unreadable_why"]
    assert exposed[0]["taxels"] > 0 and len(why) <= 1 and not any(w.startswith("covered") for w in why.values()), why


def test_balls_on_the_allegro_palm_read_mg(tmp_path):
    """The palm's collision box encloses its visual mesh: a skin laid on the visual mesh lay inside
    MuJoCo's contact surface (0 of 3 drops read); the export rebuilds the palm's contact surface."""
    robot, records, configs = skinned("allegro_hand_description/urdf/allegro_right_hand.urdf",
                                      [("palm_link", "visual")], tmp_path / "allegro.xml")
    rows = drop_many(tmp_path / "allegro.xml", ["palm_link"], 4, configurations=configs)
    assert all(abs(r["force_n"] - BALL_KG * G) <= 0.05 * BALL_KG * G for r in rows), rows
    assert records[0]["unreadable"] == [], records[0]["unreadable_why"]
