"""Exported layouts in the hands of their consumers: MuJoCo (a ball dropped on a skinned link)
and a URDF parser from PyPI (every taxel frame's pose)."""

import warnings
import xml.etree.ElementTree as ET

import numpy as np
import pytest

from vtcore.errors import InputError
from vtcore.layout import make_patch, place, save
from vtcore.robot import mjcf_tree, urdf_tree

G = 9.81
BALL_MASS = 0.1  # kg
R_LINK, L_LINK = 0.04, 0.2  # m, a forearm-like cylinder along x


@pytest.fixture(scope="module")
def forearm_skin():
    """A 60-taxel CySkin hexagon conformed to the top of a cylinder (link frame), then
    expressed in a patch frame whose pose in the link is ``transform`` (like a CySkin tf_matrix)."""
    import trimesh

    mesh = trimesh.creation.cylinder(radius=R_LINK, height=L_LINK, sections=256)
    mesh.apply_transform(trimesh.transformations.rotation_matrix(np.pi / 2, [0, 1, 0]))  # axis along x
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        on_link, _ = place(mesh, "hexagon", [0.01, 0, R_LINK], [1, 0, 0])
    t = np.eye(4)
    c, s = np.cos(0.4), np.sin(0.4)
    t[:3, :3] = [[c, -s, 0], [s, c, 0], [0, 0, 1]]
    t[:3, 3] = [0.02, -0.01, R_LINK]
    patch = on_link.transformed(np.linalg.inv(t), frame="forearm_patch")
    np.testing.assert_allclose(patch.transform, t, atol=1e-12)
    return on_link, patch


def robot_xml(path, link_geom: str, ball_joint: str):
    path.write_text(f"""<mujoco model="arm">
  <!-- a test robot: one link, and a ball above it -->
  <option timestep="0.001"/>
  <worldbody>
    <body name="forearm" pos="0 0 0.5">
      {link_geom}
    </body>
    <body name="ball" pos="0 0 1">
      {ball_joint}
      <geom name="ball" type="sphere" size="0.01" mass="{BALL_MASS}"/>
    </body>
  </worldbody>
</mujoco>
""")
    return path


CYLINDER = f'<geom name="forearm_geom" type="cylinder" size="{R_LINK} {L_LINK / 2}" quat="0.70710678 0 0.70710678 0"/>'
# the ball falls straight down (a ball on top of a cylinder is an unstable equilibrium)
SLIDE = '<joint name="drop" type="slide" axis="0 0 1" damping="0.5"/>'


def settle(model_path, ball_at, seconds=2.0):
    import mujoco

    m = mujoco.MjModel.from_xml_path(str(model_path))
    free = m.jnt_type[m.body("ball").jntadr[0]] == mujoco.mjtJoint.mjJNT_FREE
    if not free:
        m.body_pos[m.body("ball").id] = ball_at
    d = mujoco.MjData(m)
    if free:
        d.qpos[:3] = ball_at
    mujoco.mj_forward(m, d)
    for _ in range(int(seconds / m.opt.timestep)):
        mujoco.mj_step(m, d)
    return m, d


def world(on_link, k, lift):
    """World point ``lift`` metres above taxel ``k`` of the link-frame layout (link at z = 0.5)."""
    return on_link.positions[k] + [0, 0, 0.5] + lift * on_link.normals[k]


def test_model_sites_exact_and_frame_applied(tmp_path, forearm_skin):
    import mujoco

    on_link, patch = forearm_skin
    robot = robot_xml(tmp_path / "robot.xml", CYLINDER, SLIDE)
    mjcf_tree.write_skinned(patch, tmp_path / "skinned.xml", robot, body="forearm")
    m = mujoco.MjModel.from_xml_path(str(tmp_path / "skinned.xml"))
    d = mujoco.MjData(m)
    mujoco.mj_forward(m, d)
    assert m.nsensor == len(patch)
    ids = [m.site(f"forearm_vtskin_{i}").id for i in patch.taxel_ids]
    assert all(m.site_bodyid[i] == m.body("forearm").id for i in ids)  # in the link itself: it senses
    np.testing.assert_allclose(d.site_xpos[ids], on_link.positions + [0, 0, 0.5], atol=1e-8)
    z = d.site_xmat[ids].reshape(-1, 3, 3)[:, :, 2]
    # MuJoCo's compiler gives a site whose quaternion is within 1e-6 of its body's the body's own frame
    # (site_sameframe): a taxel on the facet crease at the top of the cylinder, tilted < 2e-6 rad from
    # the link's z, senses along z itself. That, and no more, is the tolerance on the frames.
    tilted = np.linalg.norm(on_link.normals[:, :2], axis=1) > 2.1e-6
    np.testing.assert_allclose(z[tilted], on_link.normals[tilted], atol=1e-9)
    np.testing.assert_allclose(z, on_link.normals, atol=2.1e-6)
    # taxel order: sensor k is taxel row k
    assert [m.sensor(k).name for k in range(3)] == [f"forearm_vtskin_{i}_touch" for i in patch.taxel_ids[:3]]
    np.testing.assert_allclose(m.site_size[ids[0]][0], 2e-3)  # the CySkin 4 mm disc
    # the robot's own content is kept (comment, option, the ball)
    text = (tmp_path / "skinned.xml").read_text()
    assert "a test robot" in text and m.body("ball").id > 0


@pytest.mark.parametrize("which", ["first", "middle", "last"])
def test_ball_on_a_taxel_reads_its_weight(tmp_path, forearm_skin, which):
    on_link, patch = forearm_skin
    # taxels within 6 mm of the cylinder's top line (the normal force is mg / cos(phi), phi < 9 deg)
    near_top = np.flatnonzero(np.abs(on_link.positions[:, 1]) < 6e-3)
    near_top = near_top[np.argsort(on_link.positions[near_top, 0])]
    k = near_top[{"first": 0, "middle": len(near_top) // 2, "last": -1}[which]]
    robot = robot_xml(tmp_path / "robot.xml", CYLINDER, SLIDE)
    mjcf_tree.write_skinned(patch, tmp_path / "skinned.xml", robot, body="forearm")
    # the ball falls along z and touches the cylinder on the radial line through its centre:
    # put that line through the taxel
    x, y = on_link.positions[k, :2]
    top = np.array([x, y * (R_LINK + 0.01) / R_LINK, 0.5 + R_LINK + 0.03])
    m, d = settle(tmp_path / "skinned.xml", top)
    s = d.sensordata.copy()
    under = np.flatnonzero(s > 0)
    assert len(under) >= 1
    assert abs(s.sum() - BALL_MASS * G) < 0.05 * BALL_MASS * G, (s.sum(), under)
    # the sensors that read are the ones under the ball, every other reads exactly 0
    contact = d.contact[0].pos - [0, 0, 0.5]
    dist = np.linalg.norm(on_link.positions - contact, axis=1)
    assert np.all(dist[under] < 2.5e-3)
    assert np.all(s[dist > 2.5e-3] == 0)


def test_between_taxels_reads_nothing_unless_tiled(tmp_path, forearm_skin):
    """Taxel fidelity: a ball between taxels reads 0; the tiling footprint reads its weight anywhere."""
    import mujoco

    on_link, patch = forearm_skin
    robot = robot_xml(tmp_path / "robot.xml", CYLINDER, SLIDE)
    mid = (on_link.positions[30] + on_link.positions[31]) / 2
    start = np.array([mid[0], mid[1], 0.5 + R_LINK + 0.03])
    mjcf_tree.write_skinned(patch, tmp_path / "taxel.xml", robot, body="forearm")
    _, d = settle(tmp_path / "taxel.xml", start)
    assert d.ncon >= 1 and np.all(d.sensordata == 0)
    mjcf_tree.write_skinned(patch, tmp_path / "tile.xml", robot, body="forearm", footprint="tile")
    m, d = settle(tmp_path / "tile.xml", start)
    s = d.sensordata
    # The point sits on the border of two tiles; on the curved link the neighbouring pads are tilted
    # and, a micrometre either way in the placement, the ball rests on flat pad tops or on two pad
    # rims 20 degrees off vertical, whose normal forces sum to mg / cos(20 deg). "Reads its weight"
    # is therefore: every contact holding the ball is sensed, and those forces balance gravity.
    normal, up, steepest = 0.0, 0.0, 1.0
    for i in range(d.ncon):
        f = np.zeros(6)
        mujoco.mj_contactForce(m, d, i, f)
        frame = d.contact[i].frame.reshape(3, 3)  # rows: normal, two tangents (world)
        normal += f[0]
        up -= (frame.T @ f[:3])[2]
        steepest = min(steepest, abs(frame[0, 2]))
    assert d.ncon >= 1 and abs(up - BALL_MASS * G) < 1e-3 * BALL_MASS * G  # settled on the pads
    np.testing.assert_allclose(s.sum(), normal, rtol=1e-9)  # no force goes unsensed
    assert steepest > np.cos(np.radians(25))  # held from below, not wedged between pads
    assert BALL_MASS * G * 0.99 < s.sum() < BALL_MASS * G / steepest * 1.01, s.sum()
    far = np.linalg.norm(on_link.positions - mid, axis=1) > 0.02
    assert np.all(s[far] == 0)


def test_free_ball_on_a_tiled_flat_link_anywhere(tmp_path):
    """A free ball (no joint constraint) dropped at random places on a tiled flat skin."""
    lay = make_patch("hexagon").flat_layout()
    link = '<geom name="plate" type="box" size="0.05 0.05 0.005" pos="0 0 -0.005"/>'
    robot = robot_xml(tmp_path / "robot.xml", link, "<freejoint/>")
    mjcf_tree.write_skinned(lay, tmp_path / "tile.xml", robot, body="forearm", footprint="tile")
    rng = np.random.default_rng(3)
    for xy in rng.uniform(-0.02, 0.02, (3, 2)):
        m, d = settle(tmp_path / "tile.xml", [xy[0], xy[1], 0.53], seconds=1.5)
        assert abs(d.sensordata.sum() - BALL_MASS * G) < 0.05 * BALL_MASS * G, (xy, d.sensordata.sum())


def grid_skin(n, pitch=0.005):
    """An ``n``-taxel flat skin on a square grid (rows offset by half a pitch), 10 taxels a module."""
    from vtcore.layout import Layout

    side = int(np.ceil(np.sqrt(n)))
    ij = np.stack(np.divmod(np.arange(n), side), axis=1).astype(float)
    xy = (ij - (side - 1) / 2) * pitch
    xy[:, 0] += pitch / 2 * (ij[:, 1] % 2)
    return Layout(positions=np.column_stack([xy, np.zeros(n)]), normals=np.tile([0.0, 0, 1], (n, 1)),
                  taxel_ids=np.arange(n), module_ids=np.arange(n) // 10, frame="forearm"), side * pitch


def test_a_2000_taxel_tiled_skin_loads_and_steps(tmp_path):
    """The tile footprint's body per taxel: MuJoCo's collision step takes two lists of all body pairs from
    the arena's stack, and its default arena (15 MiB here) does not grow with them: a 2,000-taxel tile skin
    stopped at the first step (mj_stackAlloc: out of memory). The export sizes the arena; a ball resting
    on the skin reads its weight."""
    import mujoco

    lay, width = grid_skin(2000)
    link = f'<geom name="plate" type="box" size="{width / 2 + 0.01} {width / 2 + 0.01} 0.005" pos="0 0 -0.005"/>'
    robot = robot_xml(tmp_path / "robot.xml", link, "<freejoint/>")
    mjcf_tree.write_skinned(lay, tmp_path / "tile.xml", robot, body="forearm", footprint="tile")
    m = mujoco.MjModel.from_xml_path(str(tmp_path / "tile.xml"))
    d = mujoco.MjData(m)
    d.qpos[:3] = [0.0011, 0.0007, 0.5 + 1e-3 + 0.01]  # at rest on the pads (1 mm thick), off-centre
    for _ in range(300):
        mujoco.mj_step(m, d)
    assert abs(d.sensordata.sum() - BALL_MASS * G) < 0.05 * BALL_MASS * G, d.sensordata.sum()
    tree = ET.parse(tmp_path / "tile.xml")
    tree.getroot().remove(tree.getroot().find("size"))  # what MuJoCo gives the same model by itself
    tree.write(tmp_path / "default.xml")
    default = mujoco.MjModel.from_xml_path(str(tmp_path / "default.xml")).narena
    assert m.narena >= default + 8 * m.nbody * (m.nbody - 1) // 2  # its own guess, and the two pair lists


def test_a_drop_on_a_tiled_link_is_no_other_links(tmp_path):
    """The drop check (vtcore.robot.drops) on a tile export: each tile's welded body belongs to its link
    (reach.body_links), so a ball over a taxel, touching its neighbours' pads, is dropped, not refused
    as starting inside another link ('<site>_cell'), and reads its weight."""
    from vtcore.robot.drops import drop_many
    from vtcore.robot.reach import body_links

    lay, width = grid_skin(100)
    link = f'<geom name="plate" type="box" size="{width / 2 + 0.01} {width / 2 + 0.01} 0.005" pos="0 0 -0.005"/>'
    robot = robot_xml(tmp_path / "robot.xml", link, "<freejoint/>")
    mjcf_tree.write_skinned(lay, tmp_path / "tile.xml", robot, body="forearm", footprint="tile")
    import mujoco

    m = mujoco.MjModel.from_xml_path(str(tmp_path / "tile.xml"))
    cells = [b for b in range(m.nbody) if m.body(b).name.endswith("_cell")]
    assert len(cells) == 100 and np.all(body_links(m)[cells] == m.body("forearm").id)
    rows = drop_many(tmp_path / "tile.xml", ["forearm"], 3)
    assert [r["blocked"] for r in rows] == [None] * 3
    assert all(abs(r["ratio"] - 1) < 0.05 for r in rows), [r["ratio"] for r in rows]


def test_the_arena_is_merged_with_the_robots_own_size(tmp_path):
    """A robot's own ``<size memory>`` is raised by what the tiles add, never lowered; a legacy
    ``njmax``/``nstack`` (MuJoCo refuses ``memory`` beside it) is left as it is, with a warning."""
    from vtcore.layout import LayoutWarning
    from vtcore.layout.io.mjcf import PAIR_BYTES, TILE_CONTACT_BYTES, default_arena, size_arena

    lay = make_patch("hexagon").flat_layout()
    link = '<geom name="plate" type="box" size="0.05 0.05 0.005" pos="0 0 -0.005"/>'
    robot = robot_xml(tmp_path / "robot.xml", link, "<freejoint/>")
    text = robot.read_text()
    robot.write_text(text.replace("<worldbody>", '<size memory="300M" nkey="2"/>\n  <worldbody>'))
    mjcf_tree.write_skinned(lay, tmp_path / "tile.xml", robot, body="forearm", footprint="tile")
    sizes = ET.parse(tmp_path / "tile.xml").getroot().findall("size")
    assert len(sizes) == 1 and sizes[0].get("nkey") == "2"
    nbody = 3 + len(lay)  # world, link, ball and a cell per taxel
    want = (300 << 20) + PAIR_BYTES * nbody * (nbody - 1) // 2 + TILE_CONTACT_BYTES * len(lay)
    assert sizes[0].get("memory") == f"{-(-want // (1 << 20))}M"
    robot.write_text(text.replace("<worldbody>", '<size njmax="500"/>\n  <worldbody>'))
    with pytest.warns(LayoutWarning, match="njmax"):
        mjcf_tree.write_skinned(lay, tmp_path / "legacy.xml", robot, body="forearm", footprint="tile")
    assert ET.parse(tmp_path / "legacy.xml").getroot().find("size").attrib == {"njmax": "500"}
    root = ET.fromstring('<mujoco><size memory="12k"/><worldbody/></mujoco>')
    with pytest.raises(InputError, match="memory"):
        size_arena(ET.fromstring('<mujoco><size memory="lots"/></mujoco>'), 10)
    assert size_arena(root, 1) == -(-((12 << 10) + TILE_CONTACT_BYTES) // (1 << 20)) << 20  # world only: no pair
    mjcf_tree.write_skinned(lay, tmp_path / "taxel.xml", tmp_path / "robot.xml", body="forearm")
    assert ET.parse(tmp_path / "taxel.xml").getroot().find("size").attrib == {"njmax": "500"}  # taxel: as it was
    save(lay, tmp_path / "frag.xml", "mjcf", footprint="tile")  # the fragment sizes its own arena
    nbody = 2 + len(lay)  # world, the frame's body, a cell per taxel
    want = default_arena(0, nbody) + PAIR_BYTES * nbody * (nbody - 1) // 2 + TILE_CONTACT_BYTES * len(lay)
    assert ET.parse(tmp_path / "frag.xml").getroot().find("size").get("memory") == f"{-(-want // (1 << 20))}M"
    save(lay, tmp_path / "frag_taxel.xml", "mjcf")
    assert ET.parse(tmp_path / "frag_taxel.xml").getroot().find("size") is None


def test_fragment_attached_to_a_link_senses_through_its_pads(tmp_path, forearm_skin):
    import mujoco

    on_link, patch = forearm_skin
    save(patch, tmp_path / "skin.xml", "mjcf")  # the fragment: body at the patch pose, pads on
    frag = ET.parse(tmp_path / "skin.xml").getroot()
    assert frag.find("worldbody/body").get("name") == "forearm_patch"
    robot = mujoco.MjSpec.from_file(str(robot_xml(tmp_path / "robot.xml", CYLINDER, SLIDE)))
    skin = mujoco.MjSpec.from_file(str(tmp_path / "skin.xml"))
    robot.body("forearm").add_frame().attach_body(skin.body("forearm_patch"), "skin/", "")
    m = robot.compile()
    d = mujoco.MjData(m)
    mujoco.mj_forward(m, d)
    sid = m.site("skin/taxel_" + str(patch.taxel_ids[30])).id
    np.testing.assert_allclose(d.site_xpos[sid], world(on_link, 30, 5e-4), atol=1e-8)  # tf applied, pad top
    x, y = on_link.positions[30, :2]
    m.body_pos[m.body("ball").id] = [x, y, 0.5 + R_LINK + 0.03]
    mujoco.mj_forward(m, d)
    for _ in range(2000):
        mujoco.mj_step(m, d)
    assert abs(d.sensordata.sum() - BALL_MASS * G) < 0.05 * BALL_MASS * G, d.sensordata.sum()
    # without pads the same fragment reads nothing: the contact is the link's, not the skin body's
    save(patch, tmp_path / "bare.xml", "mjcf", pad=False)
    robot = mujoco.MjSpec.from_file(str(tmp_path / "robot.xml"))
    robot.body("forearm").add_frame().attach_body(mujoco.MjSpec.from_file(str(tmp_path / "bare.xml"))
                                                  .body("forearm_patch"), "skin/", "")
    m = robot.compile()
    d = mujoco.MjData(m)
    m.body_pos[m.body("ball").id] = [x, y, 0.5 + R_LINK + 0.03]
    for _ in range(2000):
        mujoco.mj_step(m, d)
    assert d.ncon >= 1 and np.all(d.sensordata == 0)


def test_visual_only_link_is_told_and_padded(tmp_path, forearm_skin):
    """A link whose geoms are visual only (contype=conaffinity=0 through a default class): the
    export says the sensors would read 0, and --pad gives the skin its own contact surface."""
    from vtcore.layout import LayoutWarning

    on_link, patch = forearm_skin
    robot = tmp_path / "robot.xml"
    robot.write_text(f"""<mujoco><option timestep="0.001"/>
  <default><default class="visual"><geom contype="0" conaffinity="0" group="2"/></default></default>
  <worldbody><body name="forearm" pos="0 0 0.5" childclass="visual">
    <geom type="cylinder" size="{R_LINK} {L_LINK / 2}" quat="0.70710678 0 0.70710678 0"/></body>
  <body name="ball" pos="0 0 1">{SLIDE}<geom type="sphere" size="0.01" mass="{BALL_MASS}"/></body>
  </worldbody></mujoco>""")
    with pytest.warns(LayoutWarning, match="no colliding geom"):
        mjcf_tree.write_skinned(patch, tmp_path / "bare.xml", robot, body="forearm")
    with warnings.catch_warnings():
        warnings.simplefilter("error", LayoutWarning)
        mjcf_tree.write_skinned(patch, tmp_path / "padded.xml", robot, body="forearm", pad=True)
    x, y = on_link.positions[30, :2]
    start = [x, y * (R_LINK + 0.01) / R_LINK, 0.5 + R_LINK + 0.03]
    _, d = settle(tmp_path / "bare.xml", start)
    assert d.ncon == 0 and np.all(d.sensordata == 0)  # the ball fell through the visual link
    _, d = settle(tmp_path / "padded.xml", start)
    assert abs(d.sensordata.sum() - BALL_MASS * G) < 0.05 * BALL_MASS * G, d.sensordata.sum()


def test_model_errors(tmp_path, forearm_skin):
    _, patch = forearm_skin
    robot = robot_xml(tmp_path / "robot.xml", CYLINDER, SLIDE)
    with pytest.raises(InputError, match="no body named 'hand'.*forearm"):
        mjcf_tree.write_skinned(patch, tmp_path / "o.xml", robot, body="hand")
    with pytest.raises(InputError, match="--body"):
        mjcf_tree.write_skinned(patch, tmp_path / "o.xml", robot)
    assert not (tmp_path / "o.xml").exists()
    mjcf_tree.write_skinned(patch, tmp_path / "once.xml", robot, body="forearm")
    with pytest.raises(InputError, match="already has elements named forearm_vtskin_"):
        mjcf_tree.write_skinned(patch, tmp_path / "o.xml", tmp_path / "once.xml", body="forearm")
    assert not (tmp_path / "o.xml").exists()


def test_mesh_paths_still_resolve_from_another_folder(tmp_path):
    import mujoco
    import trimesh

    (tmp_path / "robot" / "meshes").mkdir(parents=True)
    trimesh.creation.box((0.1, 0.1, 0.01)).export(tmp_path / "robot" / "meshes" / "plate.stl")
    robot = tmp_path / "robot" / "robot.xml"
    robot.write_text('<mujoco><compiler meshdir="meshes"/><asset><mesh name="plate" file="plate.stl"/></asset>'
                     '<worldbody><body name="link"><geom type="mesh" mesh="plate"/></body></worldbody></mujoco>')
    lay = make_patch("triangle").flat_layout()
    lay.positions[:, 2] += 0.005
    mjcf_tree.write_skinned(lay, tmp_path / "out" / "skinned.xml", robot, body="link")
    m = mujoco.MjModel.from_xml_path(str(tmp_path / "out" / "skinned.xml"))
    assert m.nsensor == len(lay) and m.nmesh == 1


# --- URDF -------------------------------------------------------------------------------------------
def frames_of(urdf_path, parent):
    import yourdfpy

    robot = yourdfpy.URDF.load(str(urdf_path), load_meshes=False, build_scene_graph=True)
    return robot, {name: robot.get_transform(name, parent) for name in robot.link_map if "_vtskin_" in name}


def check_frames(frames, parent, on_parent):
    """Every taxel frame: origin at the taxel, z along its normal (in the parent link)."""
    assert len(frames) == len(on_parent)
    for k, i in enumerate(on_parent.taxel_ids):
        f = frames[f"{parent}_vtskin_{i}"]
        np.testing.assert_allclose(f[:3, 3], on_parent.positions[k], atol=1e-10)
        np.testing.assert_allclose(f[:3, 2], on_parent.normals[k], atol=1e-10)
        np.testing.assert_allclose(f[:3, :3] @ f[:3, :3].T, np.eye(3), atol=1e-10)


def test_urdf_fragment_frames(tmp_path, forearm_skin):
    on_link, patch = forearm_skin
    save(patch, tmp_path / "skin.urdf", "urdf", parent="l_forearm")
    robot, frames = frames_of(tmp_path / "skin.urdf", "l_forearm")
    assert robot.base_link == "l_forearm"
    check_frames(frames, "l_forearm", on_link)  # the patch frame's transform is applied


def test_urdf_merged_into_a_robot(tmp_path, forearm_skin):
    on_link, patch = forearm_skin
    robot = tmp_path / "arm.urdf"
    robot.write_text("""<?xml version="1.0"?>
<robot name="arm">
  <link name="base"/>
  <link name="l_forearm"><visual><geometry><cylinder radius="0.04" length="0.2"/></geometry></visual></link>
  <joint name="elbow" type="revolute"><parent link="base"/><child link="l_forearm"/>
    <origin xyz="0 0 0.3" rpy="0 0.3 0"/><axis xyz="0 1 0"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint>
</robot>
""")
    urdf_tree.write_skinned(patch, tmp_path / "arm_skin.urdf", robot, parent="l_forearm")
    urdf, frames = frames_of(tmp_path / "arm_skin.urdf", "l_forearm")
    assert "elbow" in urdf.joint_map and len(urdf.actuated_joints) == 1  # skin joints are fixed
    check_frames(frames, "l_forearm", on_link)
    with pytest.raises(InputError, match="no link named 'r_forearm'"):
        urdf_tree.write_skinned(patch, tmp_path / "x.urdf", robot, parent="r_forearm")
    with pytest.raises(InputError, match="already has"):
        urdf_tree.write_skinned(patch, tmp_path / "x.urdf", tmp_path / "arm_skin.urdf", parent="l_forearm")


def test_urdf_vertical_and_flipped_normals(tmp_path):
    """Normals along +-x (the tangent helper switches axis) and -z (a planar CySkin patch)."""
    lay = make_patch("triangle").flat_layout()
    n = len(lay)
    lay.normals = np.tile([0.0, 0.0, -1.0], (n, 1))
    lay.normals[:3] = [[1, 0, 0], [-1, 0, 0], [0.6, 0.8, 0]]
    save(lay, tmp_path / "s.urdf", "urdf", parent="hand")
    _, frames = frames_of(tmp_path / "s.urdf", "hand")
    check_frames(frames, "hand", lay)


def test_cli_export_mjcf_and_urdf(tmp_path, forearm_skin, capsys):
    from vtcore.cli import main

    _, patch = forearm_skin
    save(patch, tmp_path / "p.json")
    robot = robot_xml(tmp_path / "robot.xml", CYLINDER, SLIDE)
    assert main(["layout", "export", str(tmp_path / "p.json"), "--format", "mjcf", "--model", str(robot),
                 "--body", "forearm", "--footprint", "tile", "--out", str(tmp_path / "s.xml")]) == 0
    assert "forearm_vtskin_" in (tmp_path / "s.xml").read_text()
    assert main(["layout", "export", str(tmp_path / "p.json"), "--format", "urdf", "--parent", "l_forearm",
                 "--out", str(tmp_path / "s.urdf")]) == 0
    assert main(["layout", "export", str(tmp_path / "p.json"), "--format", "csv", "--body", "x",
                 "--out", str(tmp_path / "s.csv")]) == 2
    assert "--body: not an option of --format csv" in capsys.readouterr().err
    assert main(["layout", "export", str(tmp_path / "p.json"), "--format", "mjcf", "--no-pad",
                 "--out", str(tmp_path / "bare.xml")]) == 0
    assert "<geom" not in (tmp_path / "bare.xml").read_text()
    assert main(["layout", "export", str(tmp_path / "p.json"), "--format", "ply", "--mesh",
                 "--out", str(tmp_path / "m.ply")]) == 0
    assert "element face " in (tmp_path / "m.ply").read_text()
    assert not (tmp_path / "s.csv").exists()


# --- PLY and CSV ------------------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def messy_layout():
    """Coincident taxels (a taxel placed at its neighbour's place) and a taxel in no triangle."""
    lay = make_patch("hexagon").flat_layout()
    lay.positions[5] = lay.positions[4]
    lay.positions[59] += [0.05, 0, 0]  # far away: in no triangle of the skin mesh
    lay.frame = "r_hand"
    lay.transform[:3, 3] = [0.1, 0.2, 0.3]
    return lay


def test_ply_default_trimesh_load_keeps_every_taxel(tmp_path, messy_layout):
    import trimesh

    save(messy_layout, tmp_path / "s.ply")
    pc = trimesh.load(tmp_path / "s.ply")  # defaults, process=True
    assert len(pc.vertices) == len(messy_layout)
    np.testing.assert_array_equal(pc.vertices, messy_layout.positions)
    ids = np.asarray(pc.metadata["_ply_raw"]["vertex"]["data"]["taxel_id"]).ravel()
    np.testing.assert_array_equal(ids, messy_layout.taxel_ids)
    # mesh=True: a standard face element; trimesh then loses taxels (documented), which is why it is not the default
    save(messy_layout, tmp_path / "m.ply", mesh=True)
    assert len(trimesh.load(tmp_path / "m.ply").vertices) < len(messy_layout)
    assert len(trimesh.load(tmp_path / "m.ply", process=False).vertices) < len(messy_layout)
    for f in ("s.ply", "m.ply"):  # ours reads both, exactly
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            b = __import__("vtcore.layout", fromlist=["load"]).load(tmp_path / f)
        np.testing.assert_array_equal(b.positions, messy_layout.positions)
        assert b.frame == "r_hand" and len(b.meta["faces"]) > 80


def test_ply_open3d_reads_points_and_normals(tmp_path, messy_layout):
    import open3d as o3d

    save(messy_layout, tmp_path / "s.ply")
    pc = o3d.io.read_point_cloud(str(tmp_path / "s.ply"))
    np.testing.assert_allclose(np.asarray(pc.points), messy_layout.positions)
    np.testing.assert_allclose(np.asarray(pc.normals), messy_layout.normals)


def test_csv_header_states_units_and_frame_for_pandas(tmp_path, messy_layout):
    import pandas as pd

    from vtcore.layout import load

    save(messy_layout, tmp_path / "s.csv")
    head = [ln for ln in (tmp_path / "s.csv").read_text().splitlines() if ln.startswith("#")]
    assert "# units: m" in head and "# frame: r_hand" in head
    df = pd.read_csv(tmp_path / "s.csv", comment="#")
    assert len(df) == len(messy_layout)
    np.testing.assert_allclose(df[["x", "y", "z"]].to_numpy(), messy_layout.positions, rtol=0, atol=1e-15)
    exact = pd.read_csv(tmp_path / "s.csv", comment="#", float_precision="round_trip")
    np.testing.assert_array_equal(exact[["x", "y", "z"]].to_numpy(), messy_layout.positions)  # exact decimals
    np.testing.assert_array_equal(df["taxel_id"].to_numpy(), messy_layout.taxel_ids)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        b = load(tmp_path / "s.csv")
    assert b.frame == "r_hand"
    np.testing.assert_array_equal(b.transform, messy_layout.transform)


def test_site_size_follows_the_module_type(tmp_path):
    from vtcore.layout.io.mjcf import taxel_radius

    assert taxel_radius(make_patch("hexagon").flat_layout()) == pytest.approx(2e-3)  # CySkin 4 mm disc
    assert taxel_radius(make_patch("strip:2", "icub12").flat_layout()) == pytest.approx(1.5e-3)
    lay = make_patch("hexagon").flat_layout()
    lay.meta = {"id_scheme": "icub"}  # read from an iCub file: the current triangle's pad
    assert taxel_radius(lay) == pytest.approx(4.4704e-3 / 2)
    save(make_patch("strip:2", "icub12").flat_layout(), tmp_path / "s.xml", "mjcf", site_radius=1e-3)
    sizes = {s.get("size") for s in ET.parse(tmp_path / "s.xml").getroot().iter("site")}
    assert all(v.startswith("0.001 ") for v in sizes)
