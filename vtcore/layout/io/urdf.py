"""URDF (export only): one fixed child link per taxel, the way the iCub model carries its skin.

The iCub robot model gives each skin patch's taxel frames as fixed links
``<parent>_skin_<n>`` under the link they sit on (origin at the taxel, z along its
normal); robot software finds taxels through those frames. We write the same:

- link ``{prefix}{n}`` (no geometry, no inertia: a frame) for every taxel, ``prefix``
  by default ``{parent}_vtskin_`` (``vtskin``: robot models such as iCub's already have
  ``{parent}_skin_{n}`` frames of their own; names are letters, digits and ``_``),
- joint ``{prefix}{n}_joint`` of type ``fixed``, parent ``parent``, child that link,
  ``origin xyz`` = the taxel position in ``parent`` (the layout's ``transform`` applied:
  it is the pose of the layout frame in the parent link), ``rpy`` = a rotation whose z
  axis is the taxel normal (x: the parent's x axis projected onto the taxel plane, or
  y when the normal is within ~25 degrees of x; URDF's fixed-axis roll-pitch-yaw,
  ``R = Rz(y) Ry(p) Rx(r)``).

``n`` is the taxel id when ids are unique and non-negative, else the taxel row.
The file is a small robot holding an empty ``parent`` link and the taxel links (valid URDF
on its own; copy its joints and links into a robot). The robot's own URDF with the taxel
links added under ``parent`` is :func:`vtcore.robot.export_skinned`'s (``vtcore robot export``,
``vtcore layout export --model``; :mod:`vtcore.robot.urdf_tree` merges them with
:func:`add_skin`'s elements).
"""

from __future__ import annotations

import xml.etree.ElementTree as ET

import numpy as np

from ..._io import write_xml
from ...errors import InputError
from ...tolerances import ZERO_NORMAL
from ..model import Layout
from .common import identifier, skin_prefix, taxel_labels

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


def add_skin(layout: Layout, robot: ET.Element, parent: str, prefix: str | None = None) -> list[str]:
    """Append the taxel links and fixed joints to the ``<robot>`` element; returns the link names.

    Positions go in as ``layout.transform`` places them in ``parent``. prefix : the names'
    start (default :func:`~vtcore.layout.io.common.skin_prefix` of ``parent``)."""
    from scipy.spatial.transform import Rotation

    origins, rots = taxel_poses(layout)
    rpy = Rotation.from_matrix(rots).as_euler("xyz")  # extrinsic x, y, z: URDF's rpy
    prefix = skin_prefix(parent, prefix)
    names = [f"{prefix}{lab}" for lab in taxel_labels(layout)]
    for name, o, a in zip(names, origins, rpy):
        ET.SubElement(robot, "link", name=name)
        j = ET.SubElement(robot, "joint", name=f"{name}_joint", type="fixed")
        ET.SubElement(j, "parent", link=parent)
        ET.SubElement(j, "child", link=name)
        ET.SubElement(j, "origin", xyz=" ".join(map(_fmt, o)), rpy=" ".join(map(_fmt, a)))
    return names


def write(layout: Layout, path, *, parent: str | None = None, prefix: str | None = None) -> None:
    """Write the taxel frames as a URDF of their own: a robot holding an empty ``parent`` link and
    the taxel links (a skin merged into a robot's URDF: :func:`vtcore.robot.export_skinned`).

    parent : the link the taxel frames hang from (default: the layout's ``parent``, else its
        ``frame``); the layout's ``transform`` is the pose of its frame in that link.
    prefix : start of the taxel frame names (default ``<parent>_vtskin_``).
    """
    parent = parent or layout.parent or layout.frame
    prefix = skin_prefix(parent, prefix)
    names = [f"{prefix}{lab}" for lab in taxel_labels(layout)]
    if parent in names + [f"{n}_joint" for n in names]:
        raise InputError(f"the skin's names start with {prefix!r}: one would be the link {parent!r}; "
                         "pass another --prefix", key="--prefix")
    robot = ET.Element("robot", name=identifier(layout.meta.get("name") or f"{parent}_skin"))
    robot.append(ET.Comment(f" written by vtcore (metres, radians): one fixed link per taxel under "
                            f"{parent!r}, origin at the taxel, z along its normal "))
    ET.SubElement(robot, "link", name=parent)
    add_skin(layout, robot, parent, prefix)
    ET.indent(robot, space="  ")
    write_xml(ET.ElementTree(robot), path, '<?xml version="1.0"?>\n')
