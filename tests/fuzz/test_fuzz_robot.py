"""Fuzz of the robot files (issue 37): URDF and MJCF through ``robot info``, ``layout place ROBOT --link``
(a patch and a fill) and ``robot export``.

Seeds are small robots, so that an input takes well under a second: a URDF of primitives, the humanoid
arm of :mod:`vtcore.robot.samples` (a CAD mesh in millimetres placed by its visual origin, a convex
hull, ``package://`` paths), example-robot-data's double pendulum (STL meshes, ``package://`` paths);
an MJCF of primitives with a default class and a hinge, one with a mesh asset and an ``<include>``, and
the humanoid arm as MuJoCo's URDF import writes it. The place-and-fill driver has seeds of its own with
the same features on links a module just fits on (``URDF_SMALL``...: a placement on a 20 cm arm or a
humanoid forearm takes seconds, the reader a millisecond). Mutants (:func:`fuzzing.xml_mutation`: attribute
values, deleted, duplicated and renamed elements and attributes, declared encodings, names that are
not UTF-8, byte-level mutations) are written beside their seed's files, so relative and ``package://``
paths still resolve.

Every input must end in exit 2 with one ``vtcore: error:`` line, or exit 0 with an output read back
with finite numbers (``robot info --json`` valid JSON, its text no "nan mm"; a placed layout read by
``vtcore.layout.load``; an exported robot compiled by MuJoCo or read by yourdfpy); nothing printed at
the C level (MuJoCo's own warnings), no ``MUJOCO_LOG.TXT`` in the working folder, and after a refusal
no file or folder left where the output would have gone.
"""

from __future__ import annotations

import re
import shutil
from pathlib import Path

import numpy as np
import pytest
from hypothesis import strategies as st

from fuzzing import assert_clean_exit, finite_json_text, fuzz, listing, mutated_xml, run_cli_fd, warm_up

URDF_PRIMITIVES = """<?xml version="1.0"?>
<robot name="prims">
  <link name="base"><collision><geometry><box size="0.1 0.1 0.05"/></geometry></collision></link>
  <joint name="shoulder" type="revolute"><parent link="base"/><child link="arm"/>
    <origin xyz="0 0 0.05" rpy="0 0 0.3"/><axis xyz="0 1 0"/><limit lower="-1.5" upper="1.5" effort="1" velocity="1"/>
  </joint>
  <link name="arm">
    <visual><origin xyz="0 0 0.1"/><geometry><cylinder radius="0.03" length="0.2"/></geometry></visual>
    <collision><origin xyz="0 0 0.1"/><geometry><cylinder radius="0.03" length="0.2"/></geometry></collision>
    <inertial><mass value="0.5"/><inertia ixx="0.002" ixy="0" ixz="0" iyy="0.002" iyz="0" izz="0.0002"/></inertial>
  </link>
  <joint name="wrist" type="continuous"><parent link="arm"/><child link="hand"/><origin xyz="0 0 0.2"/>
    <axis xyz="0 0 1"/></joint>
  <joint name="finger" type="prismatic"><parent link="hand"/><child link="tip"/><origin xyz="0 0 0.03"/>
    <axis xyz="0 0 1"/><limit lower="0" upper="0.02" effort="1" velocity="1"/><mimic joint="wrist" multiplier="0.01"/></joint>
  <link name="hand"><visual><geometry><sphere radius="0.025"/></geometry></visual>
    <inertial><mass value="0.1"/><inertia ixx="0.00003" ixy="0" ixz="0" iyy="0.00003" iyz="0" izz="0.00003"/></inertial></link>
  <link name="tip"><inertial><mass value="0.01"/><inertia ixx="1e-6" ixy="0" ixz="0" iyy="1e-6" iyz="0" izz="1e-6"/></inertial></link>
</robot>
"""
MJCF_PRIMITIVES = """<mujoco model="prims">
  <compiler angle="radian"/>
  <default><default class="soft"><geom rgba="1 0 0 1" contype="1" conaffinity="1"/></default></default>
  <worldbody>
    <body name="base"><geom type="box" size="0.05 0.05 0.025"/>
      <body name="arm" pos="0 0 0.05" euler="0 0 0.3">
        <joint name="shoulder" type="hinge" axis="0 1 0" range="-1.5 1.5" limited="true"/>
        <geom name="shell" class="soft" type="cylinder" size="0.03 0.1" pos="0 0 0.1"/>
        <body name="hand" pos="0 0 0.2"><joint name="slide" type="slide" axis="0 0 1" range="0 0.02"/>
          <geom type="capsule" fromto="0 0 0 0 0 0.05" size="0.02"/></body>
      </body>
    </body>
  </worldbody>
</mujoco>
"""
MJCF_MESH = """<mujoco model="meshy">
  <compiler meshdir="meshes"/>
  <asset><mesh name="shell" file="tube.stl" scale="0.001 0.001 0.001"/></asset>
  <worldbody>
    <body name="arm" pos="0 0 0.1" quat="1 0 0 0"><joint name="j" axis="1 0 0"/>
      <geom type="mesh" mesh="shell" pos="0 0 0.02"/></body>
    <include file="part.xml"/>
  </worldbody>
</mujoco>
"""
MJCF_PART = """<mujoco><body name="plate" pos="0.2 0 0"><geom type="box" size="0.02 0.03 0.004"/></body></mujoco>
"""


@pytest.fixture(scope="module")
def robots(tmp_path_factory):
    """Seeds: {"urdf": [...], "mjcf": [...]}, each (folder, suffix, bytes, link to lay skin on)."""
    import mujoco
    import trimesh

    from vtcore.layout.cadmeshes import cad_link
    from vtcore.robot.samples import example_robot_data, humanoid_arm

    d = tmp_path_factory.mktemp("robot_seeds")
    (d / "prims").mkdir()
    seeds = {"urdf": [(d / "prims", ".urdf", URDF_PRIMITIVES.encode(), "arm")], "mjcf": []}
    arm = humanoid_arm(d / "humanoid")
    seeds["urdf"].append((arm.parent, ".urdf", arm.read_bytes(), "l_forearm"))
    # a real robot with package:// meshes (example-robot-data is pinned in both lanes: a missing one fails here)
    src = example_robot_data() / "double_pendulum_description"
    dst = d / "erd" / "example-robot-data" / "robots" / "double_pendulum_description"
    shutil.copytree(src, dst)
    seeds["urdf"].append((dst / "urdf", ".urdf", (dst / "urdf" / "double_pendulum.urdf").read_bytes(), "link1"))
    (d / "mprims").mkdir()
    seeds["mjcf"].append((d / "mprims", ".xml", MJCF_PRIMITIVES.encode(), "arm"))
    (d / "mmesh" / "meshes").mkdir(parents=True)
    cad_link(radius=0.03, length=0.12, mm=True).export(d / "mmesh" / "meshes" / "tube.stl")
    trimesh.creation.box((0.04, 0.06, 0.008))
    (d / "mmesh" / "part.xml").write_text(MJCF_PART)
    seeds["mjcf"].append((d / "mmesh", ".xml", MJCF_MESH.encode(), "arm"))
    # the humanoid arm as MuJoCo's URDF import writes it, its meshes beside it
    from vtcore.robot.export import urdf_as_mjcf
    from vtcore.robot.mjcf_tree import write_tree

    (d / "mjarm").mkdir()
    write_tree(urdf_as_mjcf(arm, d / "mjarm" / "arm.xml"), d / "mjarm" / "arm.xml")
    mujoco.MjModel.from_xml_path(str(d / "mjarm" / "arm.xml"))
    seeds["mjcf"].append((d / "mjarm", ".xml", (d / "mjarm" / "arm.xml").read_bytes(), "l_forearm"))
    return seeds


#: The place-and-fill seeds: the same features as the seeds above (a mimic, continuous and prismatic joint;
#: a default class, a hinge and a slide; a CAD mesh in millimetres, scaled, by a ``package://`` path or a
#: ``meshdir``; an ``<include>``) on links a module just fits on, so that the placement after the reader
#: (log map, exposure over 32 poses) takes a tenth of a second, not the seconds of a 20 cm arm or a
#: humanoid forearm (``robot info`` and ``robot export`` read those).
URDF_SMALL = """<?xml version="1.0"?>
<robot name="small">
  <link name="base"><collision><geometry><box size="0.05 0.05 0.02"/></geometry></collision></link>
  <joint name="shoulder" type="revolute"><parent link="base"/><child link="arm"/>
    <origin xyz="0 0 0.02" rpy="0 0 0.3"/><axis xyz="0 1 0"/><limit lower="-1.5" upper="1.5" effort="1" velocity="1"/>
  </joint>
  <link name="arm">
    <visual><origin xyz="0 0 0.025"/><geometry><box size="0.036 0.036 0.05"/></geometry></visual>
    <collision><origin xyz="0 0 0.025"/><geometry><box size="0.036 0.036 0.05"/></geometry></collision>
    <inertial><mass value="0.5"/><inertia ixx="0.002" ixy="0" ixz="0" iyy="0.002" iyz="0" izz="0.0002"/></inertial>
  </link>
  <joint name="wrist" type="continuous"><parent link="arm"/><child link="hand"/><origin xyz="0 0 0.05"/>
    <axis xyz="0 0 1"/></joint>
  <joint name="finger" type="prismatic"><parent link="hand"/><child link="tip"/><origin xyz="0 0 0.01"/>
    <axis xyz="0 0 1"/><limit lower="0" upper="0.02" effort="1" velocity="1"/><mimic joint="wrist" multiplier="0.01"/></joint>
  <link name="hand"><visual><geometry><sphere radius="0.01"/></geometry></visual>
    <inertial><mass value="0.1"/><inertia ixx="0.00003" ixy="0" ixz="0" iyy="0.00003" iyz="0" izz="0.00003"/></inertial></link>
  <link name="tip"><inertial><mass value="0.01"/><inertia ixx="1e-6" ixy="0" ixz="0" iyy="1e-6" iyz="0" izz="1e-6"/></inertial></link>
</robot>
"""
URDF_SMALL_MESH = """<?xml version="1.0"?>
<robot name="smallmesh">
  <link name="base"><collision><geometry><box size="0.05 0.05 0.02"/></geometry></collision></link>
  <joint name="elbow" type="revolute"><parent link="base"/><child link="forearm"/>
    <origin xyz="0 0 0.07" rpy="0.1 0 0"/><axis xyz="1 0 0"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint>
  <link name="forearm">
    <visual><origin xyz="0 0 0" rpy="0 0 0"/>
      <geometry><mesh filename="package://small_description/meshes/tube.stl" scale="0.001 0.001 0.001"/></geometry></visual>
    <collision><geometry><mesh filename="package://small_description/meshes/tube.stl" scale="0.001 0.001 0.001"/></geometry></collision>
  </link>
</robot>
"""
MJCF_SMALL = """<mujoco model="small">
  <compiler angle="radian"/>
  <default><default class="soft"><geom rgba="1 0 0 1" contype="1" conaffinity="1"/></default></default>
  <worldbody>
    <body name="base"><geom type="box" size="0.025 0.025 0.01"/>
      <body name="arm" pos="0 0 0.02" euler="0 0 0.3">
        <joint name="shoulder" type="hinge" axis="0 1 0" range="-1.5 1.5" limited="true"/>
        <geom name="shell" class="soft" type="box" size="0.018 0.018 0.025" pos="0 0 0.025"/>
        <body name="hand" pos="0 0 0.05"><joint name="slide" type="slide" axis="0 0 1" range="0 0.02"/>
          <geom type="capsule" fromto="0 0 0 0 0 0.02" size="0.008"/></body>
      </body>
    </body>
  </worldbody>
</mujoco>
"""
MJCF_SMALL_MESH = """<mujoco model="smallmesh">
  <compiler meshdir="meshes"/>
  <asset><mesh name="shell" file="tube.stl" scale="0.001 0.001 0.001"/></asset>
  <worldbody>
    <body name="arm" pos="0 0 0.1" quat="1 0 0 0"><joint name="j" axis="1 0 0"/>
      <geom type="mesh" mesh="shell" pos="0 0 0.02"/></body>
    <include file="part.xml"/>
  </worldbody>
</mujoco>
"""


@pytest.fixture(scope="module")
def small_robots(tmp_path_factory):
    """The place-and-fill seeds: {"urdf": [...], "mjcf": [...]}, as :func:`robots`."""
    from vtcore.layout.cadmeshes import cad_link

    d = tmp_path_factory.mktemp("small_robot_seeds")
    tube = cad_link(radius=0.016, length=0.05, sections=12, mm=True)  # fins and duplicate faces kept
    seeds = {"urdf": [], "mjcf": []}
    (d / "prims").mkdir()
    seeds["urdf"].append((d / "prims", ".urdf", URDF_SMALL.encode(), "arm"))
    (d / "small_description" / "meshes").mkdir(parents=True)
    (d / "small_description" / "urdf").mkdir()
    tube.export(d / "small_description" / "meshes" / "tube.stl")
    seeds["urdf"].append((d / "small_description" / "urdf", ".urdf", URDF_SMALL_MESH.encode(), "forearm"))
    (d / "mprims").mkdir()
    seeds["mjcf"].append((d / "mprims", ".xml", MJCF_SMALL.encode(), "arm"))
    (d / "mmesh" / "meshes").mkdir(parents=True)
    tube.export(d / "mmesh" / "meshes" / "tube.stl")
    (d / "mmesh" / "part.xml").write_text(MJCF_PART)
    seeds["mjcf"].append((d / "mmesh", ".xml", MJCF_SMALL_MESH.encode(), "arm"))
    return seeds


def _write(seed, data: bytes) -> Path:
    folder, suffix, _, _ = seed
    p = folder / f"mutant{suffix}"
    p.write_bytes(data)
    return p


def _no_mujoco_log(work: Path) -> None:
    assert not (work / "MUJOCO_LOG.TXT").exists(), "MuJoCo wrote its log into the working folder"


@pytest.mark.parametrize("fmt", ["urdf", "mjcf"])
def test_fuzz_robot_info(fmt, robots, tmp_path, monkeypatch, pytestconfig):
    """``robot info ROBOT --json`` prints finite JSON; ``robot info ROBOT`` no NaN size."""
    monkeypatch.chdir(tmp_path)
    seeds = robots[fmt]

    def check(example):
        i, data = example
        src = _write(seeds[i], data)
        rc, so, se = run_cli_fd(f"robot info {fmt}", ["robot", "info", src, "--json"])
        assert_clean_exit(rc, so, se)
        if rc == 0:
            doc = finite_json_text(so)
            assert doc["links"] is not None
        rc, so, se = run_cli_fd(f"robot info {fmt} (text)", ["robot", "info", src])
        assert_clean_exit(rc, so, se)
        assert not re.search(r"\b(nan|inf)\b mm", so, re.I), so
        _no_mujoco_log(tmp_path)

    fuzz(pytestconfig, mutated_xml([s[2] for s in seeds]), check)


@pytest.mark.parametrize("fmt", ["urdf", "mjcf"])
def test_fuzz_robot_place_and_fill(fmt, small_robots, tmp_path, monkeypatch, pytestconfig):
    """``layout place ROBOT --link LINK`` (a triangle) or ``--patch fill --radius 0.015`` through a
    mutated robot: a layout read back with finite numbers, or one error and no file."""
    from vtcore.layout import load

    monkeypatch.chdir(tmp_path)
    seeds = small_robots[fmt]
    out = tmp_path / "o" / "placed.json"
    warm_up(["layout", "place", _write(seeds[0], seeds[0][2]), "--link", seeds[0][3], "--patch", "fill", "--radius",
             "0.015", "--geometry", "collision", "--out", tmp_path / "warm.json"])

    def check(example):
        (i, data), fill = example
        src = _write(seeds[i], data)
        shutil.rmtree(out.parent, ignore_errors=True)
        patch = ["--patch", "fill", "--radius", "0.015"] if fill else ["--patch", "triangle"]
        if fmt == "mjcf":  # MuJoCo's URDF import keeps collision geometry only; the other seeds collide too
            patch += ["--geometry", "collision"]
        rc, so, se = run_cli_fd(f"layout place {fmt} robot", ["layout", "place", src, "--link", seeds[i][3], *patch,
                                                               "--out", out])
        assert_clean_exit(rc, so, se)
        if rc == 0:
            back = load(out)
            assert np.isfinite(back.positions).all() and np.isfinite(back.normals).all()
            assert np.isfinite(back.transform).all()
        else:
            assert listing(out.parent) == [], listing(out.parent)
        _no_mujoco_log(tmp_path)

    fuzz(pytestconfig, st.tuples(mutated_xml([s[2] for s in seeds]), st.booleans()), check)


@pytest.fixture(scope="module")
def skins(robots, tmp_path_factory):
    """A three-taxel layout on each seed's link (in its frame), as a file."""
    from vtcore.layout import Layout, save

    d = tmp_path_factory.mktemp("robot_skins")
    out = {}
    for seed in robots["urdf"] + robots["mjcf"]:
        link = seed[3]
        if link not in out:
            lay = Layout(positions=np.array([[0.03, 0.0, 0.05], [0.03, 0.005, 0.05], [0.03, 0.0, 0.055]]),
                         normals=np.tile([1.0, 0.0, 0.0], (3, 1)), taxel_ids=np.arange(3), module_ids=np.zeros(3, int),
                         frame=link)
            save(lay, d / f"{link}.json")
            out[link] = d / f"{link}.json"
    return out


def check_exported(to: str, out: Path, src: Path) -> None:
    """The exported robot: the skin's three taxels added with finite numbers, read back by our reader;
    MuJoCo compiles an MJCF; yourdfpy reads a URDF where it read the mutated robot (the robot's own
    elements are written back word for word, so what yourdfpy refuses in them it refuses in both)."""
    import xml.etree.ElementTree as ET

    from vtcore.robot import load_robot

    root = ET.parse(out).getroot()
    added = [e for e in root.iter() if "vtskin" in (e.get("name") or "") or "vtskin" in (e.get("site") or "")]
    assert added, "no taxel of the skin in the export"
    for e in added:
        for k in ("pos", "quat", "size", "xyz", "rpy", "zaxis"):
            if e.get(k) is not None:
                assert all(np.isfinite(float(v)) for v in e.get(k).split()), ET.tostring(e)
    robot = load_robot(out)
    for ln in robot.links.values():
        for g in ln.visuals + ln.collisions:
            assert np.isfinite(g.origin).all()
    if to == "mjcf":
        import mujoco

        from vtcore.robot.mjcf import mujoco_messages

        with mujoco_messages():
            assert mujoco.MjModel.from_xml_path(str(out)).nsensor >= 3
        return
    yourdfpy = pytest.importorskip("yourdfpy")
    try:
        yourdfpy.URDF.load(str(src), build_scene_graph=False, load_meshes=False)
    except Exception:  # noqa: BLE001  (yourdfpy refuses the mutated robot itself)
        return
    yourdfpy.URDF.load(str(out), build_scene_graph=False, load_meshes=False)


@pytest.mark.parametrize("fmt", ["urdf", "mjcf"])
def test_fuzz_robot_export_of_mutated_robots(fmt, robots, skins, tmp_path, monkeypatch, pytestconfig):
    """``robot export ROBOT LAYOUT --out X`` of a mutated robot (URDF to URDF or MJCF, MJCF to MJCF): the
    output compiled by MuJoCo or read by yourdfpy, or one error and nothing left where it would go
    (no ``X_meshes/``, no staging folder)."""
    monkeypatch.chdir(tmp_path)
    seeds = robots[fmt]
    out_dir = tmp_path / "o"
    warm_up(["robot", "export", _write(seeds[0], seeds[0][2]), skins[seeds[0][3]], "--out", tmp_path / "warm.xml"])

    def check(example):
        (i, data), to = example
        to = "mjcf" if fmt == "mjcf" else to
        src = _write(seeds[i], data)
        shutil.rmtree(out_dir, ignore_errors=True)
        out = out_dir / ("X.urdf" if to == "urdf" else "X.xml")
        rc, so, se = run_cli_fd(f"robot export {fmt} to {to}", ["robot", "export", src, skins[seeds[i][3]],
                                                                 "--out", out])
        assert_clean_exit(rc, so, se)
        if rc == 0:
            assert [p for p in listing(out_dir) if not p.startswith("X_meshes")] == [out.name], listing(out_dir)
            check_exported(to, out, src)
        else:
            assert listing(out_dir) == [] and not out_dir.exists(), listing(out_dir)
        _no_mujoco_log(tmp_path)

    fuzz(pytestconfig, st.tuples(mutated_xml([s[2] for s in seeds]), st.sampled_from(["urdf", "mjcf"])), check)
