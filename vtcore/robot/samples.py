"""Robots for tests, the benchmark and the docs.

- :func:`example_robot_data`: the folder of example-robot-data's robots (the PyPI package installs
  them under ``<site-packages>/cmeel.prefix/share/example-robot-data/robots``; a test dependency).
- :func:`humanoid_arm`: a humanoid-style arm written the way robot makers publish one: the forearm's
  visual mesh a CAD export in millimetres (slivers, non-manifold fins, duplicated faces) in the CAD
  root frame, placed in link ``l_forearm`` by a non-identity visual origin with
  ``scale="0.001 0.001 0.001"``; a second visual mesh (a cover plate) on the same link; a coarse
  convex collision hull in metres with an origin of its own; ``package://`` mesh paths; and 24
  ``l_forearm_skin_<n>`` frames of its own, as the iCub model has.
"""

from __future__ import annotations

import sysconfig
from pathlib import Path

import numpy as np

from ..errors import InputError
from .model import pose

#: the forearm CAD mesh's pose in link l_forearm (URDF visual origin: xyz, rpy)
FOREARM_VISUAL_ORIGIN = ((0.0, 0.0, 0.13), (0.0, 1.5707963267948966, 0.4))
FOREARM_COLLISION_ORIGIN = ((0.13, 0.0, 0.0), (0.0, 0.0, 0.4))


def example_robot_data() -> Path:
    """The ``robots`` folder of the installed example-robot-data, or an InputError saying how to get it."""
    for base in (sysconfig.get_paths()["purelib"], sysconfig.get_paths()["platlib"]):
        p = Path(base) / "cmeel.prefix" / "share" / "example-robot-data" / "robots"
        if p.is_dir():
            return p
    raise InputError("example-robot-data is not installed (pip install example-robot-data)", key="robots")


def humanoid_arm(folder) -> Path:
    """Write the humanoid arm (see the module doc) under ``folder``; returns the URDF's path
    (``folder/humanoid_description/urdf/arm.urdf``, meshes in ``.../meshes``)."""
    import trimesh

    from ..layout.cadmeshes import cad_link

    root = Path(folder) / "humanoid_description"
    (root / "meshes").mkdir(parents=True, exist_ok=True)
    (root / "urdf").mkdir(parents=True, exist_ok=True)
    cad = cad_link(radius=0.036, length=0.2, mm=True)  # millimetres, tube along the CAD z axis
    cad.export(root / "meshes" / "forearm_cad.stl")
    plate = trimesh.creation.box(extents=(20.0, 30.0, 3.0))  # a cover plate, millimetres too
    plate.apply_translation([0.0, 0.0, -100.0 - 1.5 - 10.0])
    plate.export(root / "meshes" / "cover_cad.stl")
    # the collision hull in metres, in a frame of its own: CAD z along its x
    hull = trimesh.Trimesh(cad.vertices * 1e-3, cad.faces, process=True).convex_hull
    vis = pose(FOREARM_VISUAL_ORIGIN[0], FOREARM_VISUAL_ORIGIN[1])
    col = pose(FOREARM_COLLISION_ORIGIN[0], FOREARM_COLLISION_ORIGIN[1])
    hull.apply_transform(np.linalg.inv(col) @ vis)
    hull.export(root / "meshes" / "forearm_hull.stl")
    frames = "\n".join(
        f'  <link name="l_forearm_skin_{i}"/>\n  <joint name="l_forearm_skin_{i}_joint" type="fixed"><parent '
        f'link="l_forearm"/><child link="l_forearm_skin_{i}"/><origin xyz="{0.005 * i:g} 0 0.05"/></joint>'
        for i in range(24))
    o = lambda xyz_rpy: (f'xyz="{" ".join(f"{v:.17g}" for v in xyz_rpy[0])}" '  # noqa: E731
                         f'rpy="{" ".join(f"{v:.17g}" for v in xyz_rpy[1])}"')
    pkg = "package://humanoid_description/meshes"
    urdf = root / "urdf" / "arm.urdf"
    urdf.write_text(f"""<?xml version="1.0"?>
<!-- a humanoid-style arm: the forearm as a CAD export in millimetres, placed by its visual origin -->
<robot name="humanoid_arm">
  <link name="torso">
    <collision><geometry><box size="0.2 0.3 0.4"/></geometry></collision>
  </link>
  <joint name="l_shoulder_pitch" type="revolute">
    <parent link="torso"/><child link="l_upper_arm"/>
    <origin xyz="0 0.2 0.15" rpy="-1.5707963267948966 0 0"/><axis xyz="0 0 1"/>
    <limit lower="-1.5" upper="1.5" effort="10" velocity="1"/>
  </joint>
  <link name="l_upper_arm">
    <visual><origin xyz="0 0 0.12"/><geometry><cylinder radius="0.04" length="0.24"/></geometry></visual>
    <collision><origin xyz="0 0 0.12"/><geometry><cylinder radius="0.04" length="0.24"/></geometry></collision>
  </link>
  <joint name="l_elbow" type="revolute">
    <parent link="l_upper_arm"/><child link="l_forearm"/>
    <origin xyz="0 0 0.26" rpy="0 0 0"/><axis xyz="0 1 0"/>
    <limit lower="-2.0" upper="2.0" effort="10" velocity="1"/>
  </joint>
  <link name="l_forearm">
    <visual name="forearm shell">
      <origin {o(FOREARM_VISUAL_ORIGIN)}/>
      <geometry><mesh filename="{pkg}/forearm_cad.stl" scale="0.001 0.001 0.001"/></geometry>
    </visual>
    <visual name="cover">
      <origin {o(FOREARM_VISUAL_ORIGIN)}/>
      <geometry><mesh filename="{pkg}/cover_cad.stl" scale="0.001 0.001 0.001"/></geometry>
    </visual>
    <collision>
      <origin {o(FOREARM_COLLISION_ORIGIN)}/>
      <geometry><mesh filename="{pkg}/forearm_hull.stl"/></geometry>
    </collision>
    <inertial><mass value="1.0"/><inertia ixx="0.01" ixy="0" ixz="0" iyy="0.01" iyz="0" izz="0.01"/></inertial>
  </link>
{frames}
</robot>
""")
    return urdf
