"""Bad robot files, sensor profiles and refused outputs never crash nor leave files (issue 37).

Each test rebuilds one failure of the mutation run of issue 37 on the surfaces added last: robot
files (URDF, MJCF) through ``robot info``, ``layout place ROBOT --link`` and ``robot export``;
sensor profiles; ``vtcore evaluate``'s output folder.
"""

from __future__ import annotations

import json
import os
import tomllib
from pathlib import Path

import pytest

from vtcore.cli import main

MJCF = """<mujoco model="m"><worldbody><body name="arm" pos="0 0 0.1">
<geom name="{name}" type="cylinder" size="0.04 0.1" pos="{pos}"/>
<body name="hand" pos="0 0 0.2"><joint name="j" type="hinge" axis="0 1 0" range="-1 1" limited="true"/>
<geom name="palm" type="box" size="0.03 0.03 0.03"/></body></body></worldbody></mujoco>
"""
URDF = """<robot name="r"><link name="base"><collision><geometry><box size="0.1 0.1 0.1"/></geometry></collision></link>
<joint name="j" type="revolute"><parent link="base"/><child link="arm"/><origin xyz="0 0 0.1"/><axis xyz="0 1 0"/>
<limit lower="-1" upper="1" effort="1" velocity="1"/></joint>
<link name="arm"><collision><origin xyz="0 0 0.1"/><geometry><cylinder radius="0.04" length="0.2"/></geometry></collision>
</link></robot>
"""


def run(argv, capfd=None):
    """(exit status, stdout, stderr) of ``vtcore ARGV`` in-process; C-level output included with ``capfd``."""
    import contextlib
    import io

    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        rc = main([str(a) for a in argv])
    so, se = out.getvalue(), err.getvalue()
    if capfd is not None:
        c = capfd.readouterr()
        so, se = so + c.out, se + c.err
    return rc, so, se


def one_error(rc, err, *words):
    assert rc == 2, err
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("vtcore: error: "), err
    for w in words:
        assert w in lines[0], err


def one_taxel(path: Path, frame: str = "end_effector") -> Path:
    """A one-taxel layout file in ``frame``."""
    import numpy as np

    from vtcore.layout import Layout, save

    save(Layout(positions=np.array([[0.0, 0.0, 0.05]]), normals=np.array([[0.0, 0.0, 1.0]]),
                taxel_ids=np.array([0]), module_ids=np.array([0]), frame=frame), path)
    return path


# ----------------------------------------------------------------------------- encodings
@pytest.mark.parametrize("suffix, text", [(".urdf", URDF), (".xml", MJCF.format(name="g", pos="0 0 0"))])
def test_an_unknown_xml_encoding_is_one_error_everywhere(tmp_path, suffix, text):
    """A declaration ``encoding="utf-nan"`` was a LookupError traceback in ``robot_format`` through
    robot info, layout place ROBOT --link, the fill and robot export (11 inputs of the mutation run)."""
    robot = tmp_path / f"r{suffix}"
    robot.write_bytes(b'<?xml version="1.0" encoding="utf-nan"?>\n' + text.encode())
    lay = tmp_path / "l.json"
    for argv in (["robot", "info", robot], ["robot", "info", robot, "--json"],
                 ["layout", "place", robot, "--link", "arm", "--out", lay],
                 ["layout", "place", robot, "--link", "arm", "--patch", "fill", "--radius", "0.03", "--out", lay],
                 ["robot", "export", robot, one_taxel(tmp_path / "t.json", "arm"), "--out", tmp_path / "o.xml"]):
        rc, _, err = run(argv)
        one_error(rc, err, "utf-nan", "UTF-8")
    assert not lay.exists() and not (tmp_path / "o.xml").exists()


@pytest.mark.parametrize("decl", [b"", b'<?xml version="1.0" encoding="UTF-8"?>\n', b"\xef\xbb\xbf"])
def test_utf8_robot_files_still_read(tmp_path, decl):
    robot = tmp_path / "r.urdf"
    robot.write_bytes(decl + URDF.encode())
    rc, out, err = run(["robot", "info", robot, "--json"])
    assert rc == 0, err
    assert [r["link"] for r in json.loads(out)["links"]] == ["base", "arm"]


def test_an_mjcf_name_that_is_not_utf8_is_one_error(tmp_path):
    """A geom name holding bytes that are not UTF-8 compiled in MuJoCo and was a UnicodeDecodeError
    traceback in ``mjcf._geometry`` (MuJoCo hands names back byte for byte)."""
    robot = tmp_path / "r.xml"
    robot.write_bytes(MJCF.format(name="g", pos="0 0 0").encode().replace(b'name="g"', b'name="g\xff\xfe"'))
    rc, _, err = run(["robot", "info", robot])
    one_error(rc, err, "byte offset", "0xff", "not UTF-8")


def test_an_included_name_that_is_not_utf8_is_one_error(tmp_path):
    """The same in an ``<include>``d file, which MuJoCo reads itself: the name is read safely."""
    (tmp_path / "part.xml").write_bytes(b'<mujoco><worldbody><body name="b\xe9"><geom type="sphere" size="0.1"/>'
                                        b"</body></worldbody></mujoco>")
    robot = tmp_path / "r.xml"
    robot.write_text('<mujoco><include file="part.xml"/></mujoco>')
    rc, _, err = run(["robot", "info", robot])
    one_error(rc, err, "body name is not UTF-8", "0xe9")


# ----------------------------------------------------------------------------- numbers
@pytest.mark.parametrize("pos", ["nan 0 0", "0 inf 0", "0 0 1e300"])
def test_an_mjcf_geom_pos_that_is_not_finite_is_one_error(tmp_path, capfd, monkeypatch, pos):
    """``pos="nan 0 0"`` compiled (MuJoCo only warns) and ``robot info --json`` printed
    ``"size_m": NaN`` (not JSON), the text mode "nan mm across"; MuJoCo's own ``WARNING: XML contains a
    'NaN'`` lines reached the terminal before the error line, and its MUJOCO_LOG.TXT the working folder."""
    monkeypatch.chdir(tmp_path)
    robot = tmp_path / "r.xml"
    robot.write_text(MJCF.format(name="shell", pos=pos))
    for argv in (["robot", "info", robot, "--json"], ["robot", "info", robot]):
        rc, out, err = run(argv, capfd)
        one_error(rc, err, "geom 'shell'", "pos", "not finite")
        assert out == "" and "nan mm" not in out
    if "nan" in pos:
        assert "MuJoCo said: XML contains a 'NaN'" in err
    assert not (tmp_path / "MUJOCO_LOG.TXT").exists()


def test_an_mjcf_quaternion_that_overflows_is_one_error(tmp_path):
    """Found by the robot info fuzz: ``quat="0.98 1e308 0 0.2"`` compiled (MuJoCo's normalisation made it
    all zeros) and scipy refused the zero quaternion in a traceback."""
    robot = tmp_path / "r.xml"
    robot.write_text(MJCF.format(name="shell", pos="0 0 0").replace('pos="0 0 0"/>', 'pos="0 0 0" quat="0.98 1e308 0 0.2"/>'))
    rc, _, err = run(["robot", "info", robot, "--json"])
    one_error(rc, err, "geom 'shell'", "quat", "not a rotation")


def test_an_mjcf_joint_axis_that_overflows_is_one_error(tmp_path):
    """Found by the robot info fuzz's long run: ``axis="1e308 0 0"`` compiled (normalised to zeros) and
    the reader divided by its zero norm (a RuntimeWarning, then NaN)."""
    robot = tmp_path / "r.xml"
    robot.write_text(MJCF.format(name="g", pos="0 0 0").replace('axis="0 1 0"', 'axis="1e308 0 0"'))
    rc, _, err = run(["robot", "info", robot, "--json"])
    one_error(rc, err, "joint 'j'", "axis", "not a direction")


def test_a_urdf_sphere_of_1e_320_is_one_error(tmp_path):
    """Found by the robot info fuzz's long run: ``<sphere radius="1e-320"/>`` meshed to NaN normals and
    ``robot info --json`` printed ``"size_m": NaN``."""
    robot = tmp_path / "r.urdf"
    robot.write_text(URDF.replace('<cylinder radius="0.04" length="0.2"/>', '<sphere radius="1e-320"/>'))
    rc, out, err = run(["robot", "info", robot, "--json"])
    one_error(rc, err, "radius", "at least 1e-09 m")


@pytest.mark.parametrize("edit", [('xyz="0 0 0.1"/><axis', 'xyz="0 0 1e5"/><axis'),
                                  ('radius="0.04"', 'radius="1e308"'), ('size="0.1 0.1 0.1"', 'size="0.1 -1 0.1"')])
def test_urdf_coordinates_and_sizes_beyond_a_km_are_one_error(tmp_path, edit):
    """Finite but absurd: a 1e308 m radius made ``robot info`` measure an infinite link."""
    robot = tmp_path / "r.urdf"
    robot.write_text(URDF.replace(*edit))
    rc, _, err = run(["robot", "info", robot, "--json"])
    one_error(rc, err, "1000 m")


# ----------------------------------------------------------------------------- robot export: nothing left
def test_a_refused_export_leaves_no_meshes_folder(tmp_path):
    """``robot export URDF ... --out X.xml`` copied the collision meshes to ``X_meshes/`` before
    vtcore refused the layout's link (28 inputs): the file and its folder are staged together now."""
    from vtcore.robot.samples import humanoid_arm

    robot = humanoid_arm(tmp_path / "robot")
    one_taxel(tmp_path / "l.json", "no_such_link")
    out = tmp_path / "out" / "X.xml"
    rc, _, err = run(["robot", "export", robot, tmp_path / "l.json", "--out", out])
    one_error(rc, err, "no_such_link")
    assert not (tmp_path / "out").exists(), list((tmp_path / "out").rglob("*"))
    # an existing folder keeps exactly what it had
    out.parent.mkdir()
    (out.parent / "keep.txt").write_text("x")
    rc, _, err = run(["robot", "export", robot, tmp_path / "l.json", "--out", out])
    assert rc == 2 and sorted(os.listdir(out.parent)) == ["keep.txt"], os.listdir(out.parent)
    # a good export lands both, and a second one replaces the mesh folder
    one_taxel(tmp_path / "l.json", "l_forearm")
    for _ in range(2):
        rc, _, err = run(["robot", "export", robot, tmp_path / "l.json", "--out", out])
        assert rc == 0, err
        assert sorted(os.listdir(out.parent)) == ["X.xml", "X_meshes", "keep.txt"]
    import mujoco

    assert mujoco.MjModel.from_xml_path(str(out)).nsensor == 1


def test_a_layout_on_no_link_of_an_mjcf_with_an_unnamed_body_is_one_error(tmp_path):
    """Found by the export fuzz: the refusal listed the links with ``', '.join`` and an MJCF body without
    a name was a TypeError (None among them)."""
    robot = tmp_path / "r.xml"
    robot.write_text(MJCF.format(name="g", pos="0 0 0").replace('<body name="hand" ', "<body "))
    rc, _, err = run(["robot", "export", robot, one_taxel(tmp_path / "t.json", "hand"), "--out", tmp_path / "o.xml"])
    one_error(rc, err, "'hand'", "links: arm")
    assert not (tmp_path / "o.xml").exists()


def test_a_blank_contype_exports_as_mujoco_reads_it(tmp_path):
    """Found by the export fuzz: ``contype=""`` (MuJoCo reads it as the default 1) was a ValueError
    traceback in the exporter's count of a body's colliding geoms."""
    robot = tmp_path / "r.xml"
    robot.write_text(MJCF.format(name="g", pos="0 0 0").replace('pos="0 0 0"/>', 'pos="0 0 0" contype=""/>'))
    rc, _, err = run(["robot", "export", robot, one_taxel(tmp_path / "t.json", "arm"), "--out", tmp_path / "o.xml"])
    assert rc == 0, err


@pytest.mark.parametrize("first", ['meshdir="nowhere"', 'meshdir="meshes"'])
def test_a_repeated_compiler_meshdir_is_read_as_mujoco_reads_it(tmp_path, first):
    """Found by the export fuzz (py313 lane): a second ``<compiler meshdir=...>`` overrides the first in
    MuJoCo, but the export rebased only the first, so MuJoCo's site probe of the written model raised
    "Error opening file 'meshes/tube.stl'" as a traceback. The export must land and load from another folder."""
    import mujoco
    import trimesh

    (tmp_path / "robot" / "meshes").mkdir(parents=True)
    trimesh.creation.cylinder(radius=0.04, height=0.2).export(tmp_path / "robot" / "meshes" / "tube.stl")
    robot = tmp_path / "robot" / "r.xml"
    robot.write_text(f"""<mujoco model="m"><compiler {first}/><compiler meshdir="meshes"/>
<asset><mesh name="tube" file="tube.stl"/></asset>
<worldbody><body name="arm" pos="0 0 0.1"><geom type="mesh" mesh="tube"/></body></worldbody></mujoco>
""")
    layout = one_taxel(tmp_path / "t.json", "arm")
    out = tmp_path / "elsewhere" / "o.xml"
    rc, _, err = run(["robot", "export", robot, layout, "--out", out])
    assert rc == 0, err
    assert mujoco.MjModel.from_xml_path(str(out)).nsensor == 1


# ----------------------------------------------------------------------------- sensor profiles
def _profile_doc():
    from vtcore.contact.profile import PROFILES_DIR

    return tomllib.loads((PROFILES_DIR / "cyskin.toml").read_text(encoding="utf-8"))


@pytest.mark.parametrize("table, key, value, words", [
    ("response", "held_out", 5, ("response.held_out", "list of strings")),
    ("response", "held_out", -0.0, ("response.held_out", "list of strings")),
    ("response", "held_out", [1, "a"], ("response.held_out[0]", "string")),
    ("response", "fitted", {"a": 1}, ("response.fitted",)),
    ("response", "wrap_ci", [1, 0], ("response.wrap_ci", "low <= high")),
    ("response", "frames", "many", ("response.frames",)),
    ("response", "bogus", 1, ("response.bogus", "unknown key")),
    (None, "taxels", [], ("taxels", "must be a table")),
    (None, "noise", 3, ("noise", "must be a table")),
    ("taxels", "uid", {"a": 1}, ("taxels.uid",)),
    ("taxels", "uid", 5, ("taxels.uid", "shape")),  # found by the profile fuzz: len() of a 0-d array
    ("taxels", "extra", [1], ("taxels.extra", "unknown key")),
])
def test_a_profile_value_of_the_wrong_type_is_one_error(tmp_path, table, key, value, words):
    """``[response] held_out`` holding a non-string was a TypeError in the validate task, ``held_out =
    -0.0`` a TypeError in its run, ``taxels = []`` an AttributeError in ``_taxels``: the profile is
    checked as a schema, every key of every table typed."""
    from vtcore.contact.profile import load_profile, profile_toml
    from vtcore.errors import InputError

    doc = _profile_doc()
    (doc[table] if table else doc)[key] = value
    p = tmp_path / "p.toml"
    lines = []
    for t, body in doc.items():
        if isinstance(body, dict):
            lines.append(profile_toml({t: body}))
        else:
            lines.insert(0, f"{t} = {json.dumps(body)}\n")
    p.write_text("\n".join(lines))
    with pytest.raises(InputError) as info:
        load_profile(p)
    for w in words:
        assert w in str(info.value)


def test_the_shipped_profile_keeps_its_report_fields():
    from vtcore.contact.profile import load_profile

    r = load_profile("cyskin").response
    assert r.fields["held_out"][0] == "1_finger/sample_12.txt" and r.fields["frames"] == 148


# ----------------------------------------------------------------------------- evaluate: nothing left
@pytest.mark.parametrize("exists", [False, True])
def test_a_refused_layout_leaves_no_evaluate_folder(tmp_path, exists):
    """``vtcore evaluate`` wrote ``evaluate.toml`` into ``--out`` before it read the layout, so every
    refused layout left a half-made output folder (144 of 144 refusals)."""
    import trimesh

    trimesh.creation.box(extents=(0.1, 0.1, 0.1)).export(tmp_path / "box.stl")
    bad = tmp_path / "bad.json"
    bad.write_text('{"taxels": {"positions": [[0, 0, "x"]]}}')
    good = one_taxel(tmp_path / "good.json")
    out = tmp_path / "out"
    if exists:
        out.mkdir()
    for layouts in ([bad], [good, bad]):
        rc, _, err = run(["evaluate", *layouts, "--mesh", tmp_path / "box.stl", "--out", out])
        one_error(rc, err, "bad.json")
        assert out.exists() == exists and (not exists or not os.listdir(out)), list(out.rglob("*"))


def test_a_link_scaled_to_metres_is_split_to_a_bounded_number_of_faces():
    """The place fuzz's long run: ``<mesh scale="0.001 -1 0.001"/>`` (a millimetre tube made 30 m wide)
    hung ``layout place ROBOT --link`` past the 240 s alarm, splitting the link to 10 mm edges for the
    exposure check. The split's edge grows with the link's area, so its faces stay bounded."""
    import numpy as np
    import trimesh

    from vtcore.robot.skin import EXPOSURE_EDGE, EXPOSURE_MAX_FACES, exposure_mesh

    big = trimesh.creation.box((0.5, 0.5, 0.5))
    fine, region = exposure_mesh(big, np.ones(len(big.faces), bool))
    assert len(big.faces) < len(fine.faces) <= EXPOSURE_MAX_FACES and region.all()
    np.testing.assert_allclose(fine.area, big.area, rtol=1e-9)  # split on its own faces
    small = trimesh.creation.box((0.05, 0.05, 0.05))  # a link of ordinary size: 10 mm edges, as before
    fine, _ = exposure_mesh(small)
    assert np.linalg.norm(np.diff(fine.vertices[fine.edges_unique], axis=1)[:, 0], axis=1).max() <= EXPOSURE_EDGE + 1e-12


def test_a_urdf_limit_lower_above_upper_is_one_error(tmp_path, capsys):
    """The place fuzz's long run: ``<limit lower="4294967296" upper="1"/>`` was a ValueError traceback
    (numpy's uniform draw of the exposure's poses); the reader refuses it, naming the joint."""
    from vtcore.robot.samples import humanoid_arm

    arm = humanoid_arm(tmp_path / "h")
    text = arm.read_text()
    assert 'lower="-1.5" upper="1.5"' in text
    arm.write_text(text.replace('lower="-1.5" upper="1.5"', 'lower="4294967296" upper="1"', 1))
    assert main(["robot", "info", str(arm)]) == 2
    err = capsys.readouterr().err
    assert err.startswith("vtcore: error: ") and len(err.strip().split("\n")) == 1, err
    assert "joint.limit" in err and "above upper" in err, err


def test_a_robot_placed_on_is_freed_with_its_scenes(tmp_path):
    """The place fuzz's long run: every robot placed on in one process stayed in memory with its open3d
    scenes (a module cache keyed by id(robot) whose surfaces held the robot), until open3d crashed the
    process with a segmentation fault after about a thousand robots. The cache now goes with its robot."""
    import gc
    import weakref

    from vtcore.robot import load_robot
    from vtcore.robot.exposure import exposed_faces, shared_surfaces
    from vtcore.robot.samples import humanoid_arm

    robot = load_robot(humanoid_arm(tmp_path / "h"))
    surfaces = shared_surfaces(robot)  # as layout place ROBOT --link and the add-on's lays use it
    exp = exposed_faces(robot, "l_forearm", poses=2, surfaces=surfaces)
    assert len(exp.reason) and shared_surfaces(robot) is surfaces
    alive = weakref.ref(robot)
    del robot, exp, surfaces
    gc.collect()
    assert alive() is None, "the robot (and its link scenes) outlived every reference to it"


@pytest.mark.parametrize("joints, words", [
    # the place fuzz's find: a duplicated <child> read as the parent itself; forward kinematics never ended
    ('<joint name="w" type="continuous"><parent link="arm"/><child link="arm"/><child link="hand"/></joint>',
     ("'w'", "same link 'arm'")),
    ('<joint name="w" type="fixed"><parent link="arm"/><child link="hand"/></joint>'
     '<joint name="v" type="fixed"><parent link="base"/><child link="hand"/></joint>', ("'hand'", "two joints")),
    ('<joint name="w" type="fixed"><parent link="hand"/><child link="tip"/></joint>'
     '<joint name="v" type="fixed"><parent link="tip"/><child link="hand"/></joint>', ("'hand', 'tip'", "loop")),
])
def test_joints_that_do_not_make_a_tree_are_one_error(tmp_path, joints, words):
    """Found by the place-and-fill fuzz on the merged code: ``layout place`` of a URDF whose joint named
    one link as both its parent and child hung in forward kinematics (the exposure's pose draw) until
    the 240 s alarm. A URDF is a tree: a self-loop, a link with two parent joints, and a loop no root
    reaches are each one error naming the joint or link."""
    robot = tmp_path / "r.urdf"
    robot.write_text('<robot name="r"><link name="base"/><link name="arm"><collision><geometry><box size="0.1 0.1 0.1"/>'
                     '</geometry></collision></link><link name="hand"/><link name="tip"/>'
                     '<joint name="s" type="revolute"><parent link="base"/><child link="arm"/><axis xyz="0 1 0"/>'
                     f'<limit lower="-1" upper="1" effort="1" velocity="1"/></joint>{joints}</robot>')
    for argv in (["robot", "info", robot], ["layout", "place", robot, "--link", "arm", "--geometry", "collision",
                                            "--patch", "triangle", "--out", tmp_path / "o.json"]):
        rc, _, err = run(argv)
        one_error(rc, err, *words)
    assert not (tmp_path / "o.json").exists()


def test_a_primitive_of_zero_size_has_no_surface_and_no_nan(tmp_path, capsys):
    """``<sphere radius="-0"/>`` (a placeholder; found by the robot fuzz): trimesh's icosphere of radius 0
    is NaN, which reached ``robot info`` as "nan mm across" and its exposure as a NaN area (a
    ValueError). Now the link's geometry is named as having no surface, and the rest is read."""
    (tmp_path / "r.urdf").write_text(
        '<robot name="r"><link name="base"><collision><geometry><box size="0.1 0.1 0.05"/></geometry>'
        '</collision></link><joint name="j" type="fixed"><parent link="base"/><child link="hand"/></joint>'
        '<link name="hand"><visual><geometry><sphere radius="-0"/></geometry></visual></link></robot>')
    rc = main(["robot", "info", str(tmp_path / "r.urdf")])
    out = capsys.readouterr()
    assert rc == 0, out.err
    assert "a sphere of size -0 has no surface" in out.out
    assert "nan" not in (out.out + out.err).lower()
