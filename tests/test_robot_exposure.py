"""The exposed surface of a link within its robot (issue 33): faces another link covers, faces no
fingertip reaches, and placement that keeps to the rest. Small synthetic robots written the way
makers publish them (meshes in millimetres with scale="0.001 ...", a continuous joint, a collision
box round a visual mesh, an MJCF robot with primitive geoms); the placements are checked with
trimesh's own proximity queries on meshes built here, not with the code that computed the exposure."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import trimesh

from vtcore.errors import InputError
from vtcore.robot import lay_on_link, link_mesh, load_robot
from vtcore.robot.exposure import ALWAYS_COVERED, COVERED, EXPOSED, UNREACHABLE, exposed_faces, modules_room

pytestmark = pytest.mark.filterwarnings("ignore::UserWarning")

MM = 1e-3
POSES = 6  # a few sampled poses keep the tests quick; the benchmark samples 32


def world_meshes():
    """name -> the synthetic arm's link surfaces (visual) in the world at the zero pose, metres,
    built from the same numbers as the URDF (not through vtcore's kinematics)."""
    elbow = trimesh.creation.cylinder(radius=0.030, height=0.080, sections=64)
    elbow.apply_translation([0, 0, -0.040])  # top face at z = 0: the wrist sits on it
    wrist = trimesh.creation.cylinder(radius=0.025, height=0.060, sections=64)
    wrist.apply_translation([0, 0, 0.030])  # z 0 .. 60 mm: its end faces mate with the elbow and the hand
    hand = trimesh.creation.box(extents=(0.080, 0.060, 0.030))
    hand.apply_translation([0, 0, 0.075])  # z 60 .. 90 mm
    slot = trimesh.creation.box(extents=(0.040, 0.040, 0.010))  # a pocket 10 mm wide, 20 mm deep into +y
    slot.apply_translation([0, 0.030 - 0.010, 0.075])
    hand = hand.difference(slot, engine="manifold")
    phalanx = trimesh.creation.cylinder(radius=0.010, height=0.040, sections=64)
    phalanx.apply_translation([0.025, 0, 0.110])  # on the hand's top, z 90 .. 130 mm
    tip = trimesh.creation.icosphere(subdivisions=4, radius=0.012)
    tip.apply_translation([0.025, 0, 0.130])  # centred on the phalanx's end: half inside it
    cap = trimesh.creation.box(extents=(0.010, 0.010, 0.010))
    cap.apply_translation([-0.020, -0.015, 0.075])  # wholly inside the hand (away from its pocket)
    return {"elbow": elbow, "wrist": wrist, "hand": hand, "phalanx": phalanx, "tip": tip, "cap": cap}


@pytest.fixture(scope="module")
def arm(tmp_path_factory):
    """A URDF arm: elbow - wrist (continuous, no limits) - hand (with a pocket) - phalanx - tip, and a
    cap inside the hand; meshes as STL in millimetres placed by scale 0.001 and their link frames;
    the wrist's collision a box round its visual cylinder."""
    folder = tmp_path_factory.mktemp("arm")
    world = world_meshes()
    frames = {"elbow": (0, 0, 0), "wrist": (0, 0, 0), "hand": (0, 0, 0.060), "phalanx": (0.025, 0, 0.090),
              "tip": (0.025, 0, 0.130), "cap": (0, 0, 0.060)}  # link frames in the world
    for name, m in world.items():
        local = m.copy()
        local.apply_translation(-np.asarray(frames[name]))
        local.apply_scale(1e3)  # millimetres in the file
        local.export(folder / f"{name}.stl")
    box = trimesh.creation.box(extents=(0.052, 0.052, 0.060))
    box.apply_translation([0, 0, 0.030])
    box.export(folder / "wrist_box.stl")

    def link(name, collision=None):
        vis = f'<geometry><mesh filename="{name}.stl" scale="0.001 0.001 0.001"/></geometry>'
        col = collision or vis
        return f'<link name="{name}"><visual>{vis}</visual><collision>{col}</collision></link>'

    def joint(name, parent, child, xyz, kind="fixed", extra=""):
        return (f'<joint name="{name}" type="{kind}"><parent link="{parent}"/><child link="{child}"/>'
                f'<origin xyz="{xyz}"/>{extra}</joint>')

    urdf = folder / "arm.urdf"
    urdf.write_text(f"""<?xml version="1.0"?>
<robot name="arm">
  {link("elbow")}
  {link("wrist", '<geometry><mesh filename="wrist_box.stl"/></geometry>')}
  {link("hand")}{link("phalanx")}{link("tip")}{link("cap")}
  {joint("wrist_roll", "elbow", "wrist", "0 0 0", "continuous", '<axis xyz="0 0 1"/>')}
  {joint("wrist_pitch", "wrist", "hand", "0 0 0.06", "revolute",
         '<axis xyz="1 0 0"/><limit lower="-0.3" upper="0.3" effort="1" velocity="1"/>')}
  {joint("finger", "hand", "phalanx", "0.025 0 0.03", "revolute",
         '<axis xyz="0 1 0"/><limit lower="-0.5" upper="0.5" effort="1" velocity="1"/>')}
  {joint("tip_joint", "phalanx", "tip", "0 0 0.04")}
  {joint("cap_joint", "hand", "cap", "0 0 0")}
</robot>
""")
    return urdf


def clearance_to_others(link, layout, world):
    """(N,) metres: each taxel's signed distance to the nearest other link (trimesh: positive outside)."""
    p = layout.positions + {"wrist": 0, "hand": [0, 0, 0.060], "tip": [0.025, 0, 0.130]}.get(link, 0)
    d = np.full(len(p), np.inf)
    for name, m in world.items():
        if name != link:
            d = np.minimum(d, -trimesh.proximity.signed_distance(m, p))  # trimesh: positive inside
    return d


def test_wrist_end_faces_mating_with_two_neighbours_are_covered_at_every_pose(arm):
    """The wrist's end faces touch the elbow and the hand (two neighbours at once, through a
    continuous joint without limits): covered, the elbow side at every sampled pose; the tube exposed."""
    robot = load_robot(arm)
    assert next(j for j in robot.joints if j.name == "wrist_roll").lower is None
    exp = exposed_faces(robot, "wrist", poses=POSES)
    n = link_mesh(robot, "wrist").face_normals
    bottom, top, side = n[:, 2] < -0.9, n[:, 2] > 0.9, np.abs(n[:, 2]) < 0.1
    assert (exp.reason[bottom] == ALWAYS_COVERED).all()  # rolls on the elbow: covered whatever the angle
    assert np.isin(exp.reason[top], (COVERED, ALWAYS_COVERED)).all()
    assert (exp.reason[side] == EXPOSED).mean() > 0.9
    assert set(exp.neighbours) == {"elbow", "hand"}
    assert modules_room(exp) >= 3 and "within 2 mm of or inside" in exp.excluded_text()


def test_fill_keeps_taxels_off_the_neighbours_and_anywhere_does_not(arm):
    world = world_meshes()
    robot = load_robot(arm)
    lay, rep = lay_on_link(robot, "wrist", "fill")
    assert len(lay) >= 30 and clearance_to_others("wrist", lay, world).min() > 2 * MM
    assert any("exposure of 'wrist'" in n for n in rep.notes) and lay.meta["exposure"]["covered_by"]
    old, _ = lay_on_link(robot, "wrist", "fill", exposure=False)  # the behaviour before: the end faces too
    assert clearance_to_others("wrist", old, world).min() < 2 * MM and old.meta["exposure"] is None


def test_collision_box_round_the_visual_mesh_is_split_to_follow_its_neighbours(arm):
    """The wrist's collision box (4 long faces a side) touches the elbow and the hand: its faces are
    split before the exposure, so the side keeps modules and none comes near the neighbours."""
    world = world_meshes()
    box = trimesh.creation.box(extents=(0.052, 0.052, 0.060))
    box.apply_translation([0, 0, 0.030])
    world["wrist"] = box
    lay, _ = lay_on_link(load_robot(arm), "wrist", "fill", geometry="collision")
    assert lay.n_modules >= 4 and clearance_to_others("wrist", lay, world).min() > 2 * MM


def test_fingertip_half_inside_the_phalanx_takes_its_patch_on_the_free_half(arm):
    world = world_meshes()
    lay, _ = lay_on_link(load_robot(arm), "tip", "triangle")  # no --at: the default start is on the free half
    assert clearance_to_others("tip", lay, world).min() > 2 * MM
    with pytest.raises(InputError, match="would lie on covered or unreachable surface"):
        lay_on_link(load_robot(arm), "tip", "triangle", at=(0.0, 0.0, -0.012))  # the half inside the phalanx
    lay, _ = lay_on_link(load_robot(arm), "tip", "triangle", at=(0.0, 0.0, -0.012), force=True)
    assert clearance_to_others("tip", lay, world).min() < 0  # forced: kept where it was asked


def test_pocket_deeper_than_the_probe_is_unreachable(arm):
    robot = load_robot(arm)
    exp = exposed_faces(robot, "hand", poses=0)
    m = link_mesh(robot, "hand")
    c, n = m.triangles_center, m.face_normals
    floor = (n[:, 1] > 0.9) & (c[:, 1] < 0.015)  # the pocket's floor, 20 mm down a 10 mm slot
    outer = (n[:, 1] > 0.9) & (c[:, 1] > 0.029) & (np.abs(c[:, 0]) > 0.03)
    assert floor.any() and (exp.reason[floor] == UNREACHABLE).all()
    assert (exp.reason[outer] == EXPOSED).all()
    wide = exposed_faces(robot, "hand", poses=0, probe_radius=0.003, tolerance=0.0005)  # a probe that fits
    assert (wide.reason[floor] == EXPOSED).all()


def test_a_link_covered_all_over_is_one_line_not_an_empty_layout(arm, tmp_path, capsys):
    from vtcore.cli import main

    with pytest.raises(InputError, match="link 'cap' .* has no exposed surface"):
        lay_on_link(load_robot(arm), "cap", "fill")
    out = tmp_path / "cap.json"
    assert main(["layout", "place", str(arm), "--link", "cap", "--patch", "fill", "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "inside hand" in err[0] and "--anywhere" in err[0] and not out.exists()


def test_mjcf_robot_with_primitive_geoms_and_a_mesh(tmp_path):
    """An MJCF arm: a capsule upper arm, a forearm mesh (STL, millimetres scaled by its asset) and a
    box hand: the forearm's ends, against the capsule and the box, are covered."""
    fore = trimesh.creation.cylinder(radius=25.0, height=100.0, sections=48)  # millimetres
    fore.apply_translation([0, 0, 50.0])
    fore.export(tmp_path / "fore.stl")
    (tmp_path / "arm.xml").write_text("""<mujoco model="arm">
  <asset><mesh name="fore" file="fore.stl" scale="0.001 0.001 0.001"/></asset>
  <worldbody>
    <body name="upper">
      <geom type="capsule" fromto="0 0 -0.12 0 0 -0.03" size="0.03"/>
      <body name="fore">
        <joint name="elbow" type="hinge" axis="0 1 0" range="-1 1"/>
        <geom type="mesh" mesh="fore"/>
        <body name="hand" pos="0 0 0.1">
          <joint name="wrist" type="hinge" axis="0 0 1"/>
          <geom type="box" size="0.04 0.03 0.015" pos="0 0 0.015"/>
        </body>
      </body>
    </body>
  </worldbody>
</mujoco>
""")
    robot = load_robot(tmp_path / "arm.xml")
    exp = exposed_faces(robot, "fore", "collision", poses=POSES)
    m = link_mesh(robot, "fore", "collision")
    n = m.face_normals
    assert set(exp.neighbours) == {"upper", "hand"}
    assert not exp.mask[n[:, 2] < -0.9].any() and not exp.mask[n[:, 2] > 0.9].any()
    assert exp.mask[np.abs(n[:, 2]) < 0.1].mean() > 0.8


def test_robot_info_shows_exposed_area_and_room_for_modules(arm, capsys):
    from vtcore.cli import main

    assert main(["robot", "info", str(arm)]) == 0
    out = capsys.readouterr().out
    wrist = out[out.index("  wrist:"):out.index("  hand:")]
    assert "exposed (visual): " in wrist and "cyskin10 modules; covered by elbow, hand" in wrist
    assert main(["robot", "info", str(arm), "--json"]) == 0
    import json

    info = json.loads(capsys.readouterr().out)
    assert info["exposure"]["cap"]["exposed_m2"] == 0 and info["exposure"]["wrist"]["modules"] >= 3


def test_small_mistakes_get_one_useful_line(arm, tmp_path, capsys):
    """A --link typo gets the closest name, a joint typo (Import Robot's joint values) the joints, a
    missing relative mesh says where it was looked for (not --package), a --package folder that does
    not exist says so, a millimetre mesh without its scale warns in robot info, --scale with --link
    says why it is refused."""
    from vtcore.cli import main
    from vtcore.scene.interactive import import_robot

    assert main(["layout", "place", str(arm), "--link", "wirst", "--out", str(tmp_path / "x.json")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "no link named 'wirst' (did you mean 'wrist'?)" in err[0]
    with pytest.raises(InputError, match=r"no joint named wrist_rol \(did you mean 'wrist_roll'\?\); the moving "
                                         r"joints: wrist_roll, wrist_pitch, finger"):
        import_robot(arm, joints={"wrist_rol": 0.3})
    bad = tmp_path / "bad.urdf"
    bad.write_text('<robot name="b"><link name="a"><visual><geometry><mesh filename="meshes/gone.stl"/></geometry>'
                   '</visual></link></robot>')
    with pytest.raises(InputError, match="not found .looked for .*meshes/gone.stl: paths are relative") as e:
        link_mesh(load_robot(bad), "a")
    assert "--package" not in str(e.value)
    assert main(["robot", "info", str(arm), "--package", "arm=/nonexistent/folder"]) == 2
    assert "the folder /nonexistent/folder does not exist" in capsys.readouterr().err
    mm = tmp_path / "mm.urdf"
    trimesh.creation.box(extents=(40.0, 30.0, 20.0)).export(tmp_path / "plate.stl")  # millimetres, no scale
    mm.write_text('<robot name="m"><link name="plate"><visual><geometry><mesh filename="plate.stl"/></geometry>'
                  '</visual></link></robot>')
    assert main(["robot", "info", str(mm), "--no-exposure"]) == 0
    assert "vtcore: warning: " in (err := capsys.readouterr().err) and "40 m across: a mesh in millimetres" in err
    assert main(["layout", "place", str(arm), "--link", "wrist", "--scale", "0.001",
                 "--out", str(tmp_path / "x.json")]) == 2
    assert "scaled by the robot file" in capsys.readouterr().err


def test_help_and_docs_say_the_same_default_start():
    import argparse
    from pathlib import Path

    from vtcore.cli import build_parser

    parser = build_parser()
    sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction)).choices["layout"]
    place = next(a for a in sub._actions if isinstance(a, argparse._SubParsersAction)).choices["place"]
    at = next(a for a in place._actions if "--at" in a.option_strings).help
    phrase = "a flat point of the link's exposed surface near its middle"
    assert phrase in at
    docs = (Path(__file__).parents[1] / "docs" / "layout.md").read_text()
    assert phrase in " ".join(docs.split())


@pytest.mark.slow
def test_g1_wrist_fill_clears_the_elbow_in_its_exported_urdf(tmp_path):
    """Done when (issue 33), on the link the issue found: the G1's left wrist roll link filled on its
    exposed surface, exported into the G1's URDF and loaded back by yourdfpy: no taxel within 2 mm of,
    or inside, another link at the zero pose (trimesh's distances, not the exposure's); filled anywhere,
    the same link puts taxels on the face mating with the elbow."""
    from vtcore.robot import export_skinned
    from vtcore.robot.samples import example_robot_data
    from vtcore.robot.verify import clearance_urdf

    erd = example_robot_data()
    path = erd / "g1_description/urdf/g1_29dof_with_hand_rev_1_0.urdf"
    robot = load_robot(path)
    link = "left_wrist_roll_link"
    mesh = link_mesh(robot, link)
    for exposure in (True, False):
        lay, _ = lay_on_link(robot, link, "fill", mesh=mesh, exposure=exposure)
        export_skinned(path, [lay], tmp_path / f"g1_{exposure}.urdf")
        stats = clearance_urdf(tmp_path / f"g1_{exposure}.urdf", packages={"example-robot-data": erd.parent})[link]
        if exposure:
            assert stats["taxels"] >= 30 and stats["near"] == 0 and stats["min_mm"] > 2.0, stats
        else:
            assert stats["near"] >= 10 and stats["nearest"] == "left_elbow_link", stats


def test_import_robot_without_open3d_imports_the_robot_and_says_why_no_exposure(tmp_path, monkeypatch):
    """The Blender extension bundles no open3d: Import Robot still imports every link (its meshes
    and poses), without exposure colours, and its notes say what is missing (the bundle check of
    scripts/build_extension.py imports the UR10 so)."""
    import importlib.util

    from vtcore.robot.samples import humanoid_arm
    from vtcore.scene.interactive import import_robot

    path = humanoid_arm(tmp_path)
    find_spec = importlib.util.find_spec
    monkeypatch.setattr(importlib.util, "find_spec", lambda name, *a: None if name == "open3d" else find_spec(name, *a))
    rob = import_robot(path)
    assert rob.links and all(p.exposure is None for p in rob.links)
    assert any(len(p.faces) for p in rob.links)
    assert len(rob.notes) == 1 and "open3d" in rob.notes[0]
    monkeypatch.setattr(importlib.util, "find_spec", find_spec)
    with_o3d = import_robot(path)
    assert not with_o3d.notes and any(p.exposure is not None for p in with_o3d.links)


# --- sampled poses the robot can hold: a bar swinging round a post, past a wall on the base ----------------

#: radians: the bar's centreline (radius 0.2 .. 0.4 m, pointing along angle phi) runs through the wall
#: (x 0.29 .. 0.31 m, |y| <= 0.1 m) wherever |phi| < atan(0.1 / 0.3)
WALL_PHI = float(np.arctan2(0.1, 0.3))


def swing_urdf(folder):
    """base (a hub and a wall at x = 0.3 m) - swing (revolute about z, +-pi, no geometry) - bar (fixed to
    swing, pointing along -x at the zero pose): the bar and the base are not jointed to each other, and
    half of a turn takes the bar through the wall."""
    urdf = folder / "swing.urdf"
    urdf.write_text("""<?xml version="1.0"?>
<robot name="swing">
  <link name="base">
    <visual><geometry><box size="0.05 0.05 0.05"/></geometry></visual>
    <visual><origin xyz="0.3 0 0"/><geometry><box size="0.02 0.2 0.1"/></geometry></visual>
  </link>
  <link name="swing"/>
  <link name="bar"><visual><origin xyz="-0.3 0 0"/><geometry><box size="0.2 0.04 0.04"/></geometry></visual></link>
  <joint name="turn" type="revolute"><parent link="base"/><child link="swing"/><axis xyz="0 0 1"/>
    <limit lower="-3.14159" upper="3.14159" effort="1" velocity="1"/></joint>
  <joint name="mount" type="fixed"><parent link="swing"/><child link="bar"/></joint>
</robot>
""")
    return urdf


def bar_phi(direction) -> float:
    """radians: the angle about z of the bar's pointing direction (3,) in the base frame."""
    return float(np.arctan2(direction[1], direction[0]))


def test_sampled_poses_put_no_link_through_another(tmp_path):
    """The exposure's sampled configurations are ones the robot can hold: uniform in the joint limits,
    the bar drawn through the wall at some of them; kept, none does (checked by the bar's angle, not by
    the exposure's own distance queries)."""
    from vtcore.robot.exposure import configurations

    robot = load_robot(swing_urdf(tmp_path))
    phis = lambda configs: np.array([bar_phi(c["bar"][:3, :3] @ [-1.0, 0, 0]) for c in configs[1:]])  # noqa: E731
    anywhere = phis(configurations(robot, 24, seed=3, free=False))
    assert (np.abs(anywhere) < WALL_PHI).any()  # uniform draws do cross the wall: the check below can fail
    free = configurations(robot, 24, seed=3)
    assert len(free) == 25
    assert (np.abs(phis(free)) >= WALL_PHI).all()


def test_mujoco_probe_poses_put_no_body_through_another():
    """The export's probe configurations (MuJoCo's own collision): the same swing as an MJCF."""
    import mujoco

    from vtcore.robot.reach import free_qpos

    m = mujoco.MjModel.from_xml_string("""<mujoco><compiler angle="radian"/><worldbody>
  <body name="base"><geom type="box" size=".025 .025 .025"/><geom type="box" pos=".3 0 0" size=".01 .1 .05"/></body>
  <body name="swing"><joint name="turn" type="hinge" axis="0 0 1" range="-3.14159 3.14159"/>
    <geom type="sphere" size=".01" contype="0" conaffinity="0"/>
    <body name="bar"><geom type="box" pos="-.3 0 0" size=".1 .02 .02"/></body></body>
</worldbody></mujoco>""")
    phis = lambda qs: np.abs(np.angle(np.exp(1j * (np.array(qs)[:, 0] + np.pi))))  # noqa: E731 (bar along -x at 0)
    assert (phis(free_qpos(m, 16, seed=3, depth=np.inf)) < WALL_PHI).any()  # nothing refused: some cross the wall
    qs = free_qpos(m, 16, seed=3)
    assert len(qs) == 16
    assert (phis(qs) >= WALL_PHI).all()


def test_a_neighbour_whose_hull_arches_over_a_skin_collides_by_parts(tmp_path):
    """An arch standing over a plate: its mesh leaves a ball on the plate's taxels free (the roof 30 mm
    up), its convex hull, which MuJoCo would collide, swallows the ball; the export gives the arch convex
    parts (``crowding_links``). The same arch moved aside is left as it is."""
    from vtcore.robot.export import crowding_links

    posts = [trimesh.creation.box(extents=(0.01, 0.04, 0.06)) for _ in range(2)]
    posts[0].apply_translation([-0.06, 0, 0.02])
    posts[1].apply_translation([0.06, 0, 0.02])
    roof = trimesh.creation.box(extents=(0.13, 0.04, 0.01))
    roof.apply_translation([0, 0, 0.045])
    trimesh.util.concatenate(posts + [roof]).export(tmp_path / "arch.stl")
    trimesh.creation.box(extents=(0.1, 0.1, 0.02)).export(tmp_path / "plate.stl")
    for shift, expect in ((0.0, {"arch"}), (0.5, set())):
        urdf = tmp_path / f"arch_{shift}.urdf"
        urdf.write_text(f"""<?xml version="1.0"?>
<robot name="arch">
  <link name="plate"><collision><geometry><mesh filename="plate.stl"/></geometry></collision>
    <visual><geometry><mesh filename="plate.stl"/></geometry></visual></link>
  <link name="arch"><collision><geometry><mesh filename="arch.stl"/></geometry></collision></link>
  <joint name="j" type="fixed"><parent link="plate"/><child link="arch"/><origin xyz="{shift} 0 0"/></joint>
</robot>
""")
        robot = load_robot(urdf)
        lay, _ = lay_on_link(robot, "plate", "triangle", at=(0, 0, 0.01), exposure=False)
        assert crowding_links(robot, [lay], ["plate"]) == expect


def test_convex_parts_are_cut_to_the_hull_mujoco_collided():
    """A decomposition's part poking out of the link's hull is cut back to it (it would cover the next
    link's skin at a mating face); a part wholly inside stays as it is."""
    from vtcore.robot.export import within_hulls

    hull = trimesh.creation.box(extents=(0.1, 0.1, 0.1))
    out = trimesh.creation.box(extents=(0.1, 0.04, 0.04))
    out.apply_translation([0.04, 0, 0])  # 40 mm of it beyond x = 0.05
    inner = trimesh.creation.box(extents=(0.02, 0.02, 0.02))
    cut = within_hulls([out, inner], [hull])
    assert len(cut) == 2
    assert cut[0].bounds[1][0] == pytest.approx(0.05, abs=1e-9) and cut[0].volume == pytest.approx(0.06 * 0.04 * 0.04)
    assert cut[1].volume == pytest.approx(inner.volume)


def test_fill_of_a_covered_link_in_blender_names_the_fill_box_option(arm):
    """The add-on's Fill on a link covered all over: the same one-line refusal, naming the Fill box's
    'Anywhere on the link' (the way round it there), not the CLI's --anywhere."""
    from vtcore.robot.meshes import link_mesh
    from vtcore.scene.interactive import lay_patch
    from vtcore.scene.interactive.link import ANYWHERE_OPTION

    m = link_mesh(load_robot(arm), "cap")
    with pytest.raises(InputError, match="link 'cap' .* has no exposed surface") as err:
        lay_patch(m.vertices, m.faces, m.triangles_center[0], fill_region=np.ones(len(m.faces), bool),
                  link={"robot": str(arm), "link": "cap", "geometry": "visual"})
    msg = str(err.value)
    assert f"'{ANYWHERE_OPTION}' lays it there anyway" in msg and "--anywhere" not in msg and "\n" not in msg
    props = (Path(__file__).parents[1] / "addon" / "props.py").read_text(encoding="utf-8")
    assert f'fill_anywhere: BoolProperty(name="{ANYWHERE_OPTION}"' in props  # the box shows that name
