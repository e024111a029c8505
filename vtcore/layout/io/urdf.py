"""URDF (export only): one fixed child link per taxel, the way the iCub model carries its skin.

The iCub robot model gives each skin patch's taxel frames as fixed links
``<parent>_skin_<n>`` under the link they sit on (origin at the taxel, z along its
normal); robot software finds taxels through those frames. We write the same:

- link ``{parent}_skin_{n}`` (no geometry, no inertia: a frame) for every taxel,
- joint ``{parent}_skin_{n}_joint`` of type ``fixed``, parent ``parent``, child that link,
  ``origin xyz`` = the taxel position in ``parent`` (the layout's ``transform`` applied:
  it is the pose of the layout frame in the parent link), ``rpy`` = a rotation whose z
  axis is the taxel normal (x: the parent's x axis projected onto the taxel plane, or
  y when the normal is within ~25 degrees of x; URDF's fixed-axis roll-pitch-yaw,
  ``R = Rz(y) Ry(p) Rx(r)``).

``n`` is the taxel id when ids are unique and non-negative, else the taxel row.
Without ``model`` the file is a small robot holding an empty ``parent`` link and the
taxel links (valid URDF on its own; copy its joints and links into a robot, or use
``model``). With ``model=ROBOT.urdf`` the robot's URDF comes back with the taxel links
added under ``parent``.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET

import numpy as np

from ..._io import atomic_write
from ...errors import InputError
from ...tolerances import ZERO_NORMAL
from ..model import Layout
from .common import read_robot_xml, taxel_labels

NAME = "urdf"
SUFFIXES = (".urdf",)
read = None  # export only


def _fmt(v) -> str:
    return format(float(v), ".12g")


def taxel_rotations(normals: np.ndarray) -> np.ndarray:
    """(N, 3, 3) rotations whose third column is each normal (N, 3): columns ``t1, t2, n``
    from :func:`vtcore.geometry.tangent_frames` (x = the parent's x axis projected onto
    the taxel plane, y where x is near the normal), so frames are reproducible."""
    from ...geometry import tangent_frames

    n = normals / np.linalg.norm(normals, axis=1, keepdims=True)
    t1, t2 = tangent_frames(n)
    return np.stack([t1, t2, n], axis=2)


def taxel_poses(layout: Layout) -> tuple[np.ndarray, np.ndarray]:
    """Taxel frames in the parent link: origins (N, 3) m and rotations (N, 3, 3)."""
    nz = np.linalg.norm(layout.normals, axis=1)
    if np.any(nz < ZERO_NORMAL):
        raise InputError(f"{int((nz < ZERO_NORMAL).sum())} taxels have a zero normal; a taxel frame needs a z axis "
                         "(estimate the normals first)", key="normals")
    t = layout.transform
    return layout.positions @ t[:3, :3].T + t[:3, 3], taxel_rotations(layout.normals @ t[:3, :3].T)


def add_skin(layout: Layout, robot: ET.Element, parent: str) -> list[str]:
    """Append the taxel links and fixed joints to the ``<robot>`` element; returns the link names."""
    from scipy.spatial.transform import Rotation

    origins, rots = taxel_poses(layout)
    rpy = Rotation.from_matrix(rots).as_euler("xyz")  # extrinsic x, y, z: URDF's rpy
    names = [f"{parent}_skin_{lab}" for lab in taxel_labels(layout)]
    for name, o, a in zip(names, origins, rpy):
        ET.SubElement(robot, "link", name=name)
        j = ET.SubElement(robot, "joint", name=f"{name}_joint", type="fixed")
        ET.SubElement(j, "parent", link=parent)
        ET.SubElement(j, "child", link=name)
        ET.SubElement(j, "origin", xyz=" ".join(map(_fmt, o)), rpy=" ".join(map(_fmt, a)))
    return names


def write(layout: Layout, path, *, parent: str | None = None, model=None) -> None:
    """Write the taxel frames as URDF.

    parent : the link the layout's frame is expressed in (default: the layout's frame name).
    model : path of the robot's URDF to merge into (it must have the link ``parent``).
    """
    parent = parent or layout.frame
    if model is not None:
        tree = read_robot_xml(model, "robot")
        robot = tree.getroot()
        links = [e.get("name") for e in robot.findall("link")]
        if parent not in links:
            raise InputError(f"no link named {parent!r}; links: {', '.join(links[:20]) or 'none'}",
                             file=model, key="--parent")
        taken = set(links) | {e.get("name") for e in robot.findall("joint")}
    else:
        robot = ET.Element("robot", name=str(layout.meta.get("name") or f"{parent}_skin"))
        robot.append(ET.Comment(f" written by vtcore (metres, radians): one fixed link per taxel under "
                                f"{parent!r}, origin at the taxel, z along its normal "))
        ET.SubElement(robot, "link", name=parent)
        tree, taken = ET.ElementTree(robot), {parent}
    names = add_skin(layout, robot, parent)
    clash = sorted(taken & (set(names) | {f"{n}_joint" for n in names}))
    if clash:
        raise InputError(f"the robot already has links or joints named {', '.join(clash[:5])}",
                         file=model, key="--parent")
    ET.indent(tree, space="  ")
    with atomic_write(path, "w", encoding="utf-8", newline="\n") as fh:
        fh.write('<?xml version="1.0"?>\n')
        tree.write(fh, encoding="unicode", xml_declaration=False)
        fh.write("\n")
