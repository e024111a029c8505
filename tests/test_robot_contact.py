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
    placed = [r for r in rows if r["blocked"] is None]
    assert len(placed) == 4 and all(abs(r["ratio"] - 1) <= 0.05 for r in placed), rows
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
    placed = [r for r in rows if r["blocked"] is None]
    assert len(placed) == 4 and all(abs(r["force_n"] - BALL_KG * G) <= 0.05 * BALL_KG * G for r in placed), rows
    assert records[0]["unreadable"] == [], records[0]["unreadable_why"]


PLATE = """<mujoco model="plate">
  <worldbody>
    <body name="plate" pos="0 0 0.5">
      <geom name="plate_geom" type="box" size="0.03 0.03 0.004"/>{overhang}
    </body>
    <body name="roof" pos="{roof} 0 0.52">
      <geom name="roof_geom" type="box" size="0.01 0.01 0.002"/>
    </body>
  </worldbody>
</mujoco>
"""


#: a ledge of the same link 40 mm over the plate, its underside facing the plate's top
OVERHANG = '\n      <geom name="ledge" type="box" pos="0 0 0.044" size="0.03 0.03 0.004"/>'


def test_a_ball_on_one_taxel_is_not_counted_by_a_site_its_contact_ray_crosses(tmp_path):
    """MuJoCo's touch sensor counts a contact of its site's body whose normal ray (from the contact, out of
    the body) crosses the site, and the ray does not end: with every pad and site in the link's own body, a
    ball resting on the plate's top taxel was counted again by the site on the underside of a ledge of the
    same link 40 mm above it, and the other way round (2 m g; the G1's torso in the drop check). Each
    module's pads and sites in a body of their own: m g, once."""
    from vtcore.layout import Layout
    from vtcore.robot import mjcf_tree

    (tmp_path / "plate.xml").write_text(PLATE.format(roof=0.5, overhang=OVERHANG))  # the roof far away
    lay = Layout(positions=[[0, 0, 0.004], [0, 0, 0.040]], normals=[[0, 0, 1], [0, 0, -1]],
                 taxel_ids=[0, 1], module_ids=[0, 1], frame="plate")
    mjcf_tree.write_skinned(lay, tmp_path / "skinned.xml", tmp_path / "plate.xml", body="plate", pad=True,
                            pad_radius=0.003)
    rows = drop_many(tmp_path / "skinned.xml", ["plate"], 2, seed=3)
    assert {r["site"] for r in rows} == {"plate_vtskin_0", "plate_vtskin_1"}  # seed 3: each face once
    for r in rows:
        assert r["blocked"] is None and abs(r["ratio"] - 1) <= 0.05, rows


def test_a_ball_that_would_start_inside_another_link_is_no_drop(tmp_path):
    """A link standing within a ball's width over the taxel (here a roof 16 mm over the plate's top
    taxel): no ball can be placed there; the draw is named blocked and another is drawn, not counted as
    a reading of 20 or 50 m g (the ball squeezed between the two links)."""
    from vtcore.layout import Layout
    from vtcore.robot import mjcf_tree

    (tmp_path / "plate.xml").write_text(PLATE.format(roof=0.0, overhang=""))
    lay = Layout(positions=[[0, 0, 0.004], [0, 0, -0.004]], normals=[[0, 0, 1], [0, 0, -1]],
                 taxel_ids=[0, 1], module_ids=[0, 1], frame="plate")
    mjcf_tree.write_skinned(lay, tmp_path / "skinned.xml", tmp_path / "plate.xml", body="plate", pad=True,
                            pad_radius=0.003)
    rows = drop_many(tmp_path / "skinned.xml", ["plate"], 3, seed=1)  # draws the top taxel first
    blocked = [r for r in rows if r["blocked"] is not None]
    placed = [r for r in rows if r["blocked"] is None]
    assert blocked and all(r["blocked"] == "roof" and r["site"] == "plate_vtskin_0" and r["ratio"] is None
                           for r in blocked), rows
    assert len(placed) == 3 and all(r["site"] == "plate_vtskin_1" and abs(r["ratio"] - 1) <= 0.05
                                    for r in placed), rows
