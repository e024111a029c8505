"""A robot as vtcore sees it: links with their geometry, joints, and the pose of every link.

One neutral model that the URDF reader (:mod:`.urdf`, stdlib only, so it runs inside Blender)
and the MJCF reader (:mod:`.mjcf`, MuJoCo's own compiler) both fill. Poses are (4, 4) float64
rigid transforms, metres; ``origin`` of a joint or a geometry is its pose in the parent link
(``p_parent = R p + t``, the layout convention of docs/layout.md).
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..errors import FormatError, InputError, did_you_mean

GEOMETRY_KINDS = ("visual", "collision")
#: joint types that move (URDF names; MJCF hinge -> revolute, slide -> prismatic)
MOVING = ("revolute", "continuous", "prismatic")
#: m: the largest coordinate or size a robot file may give (the layout readers' bound: a unit error beyond)
MAX_EXTENT_M = 1e3
#: m (or a mesh scale): the smallest size other than 0 (below it a primitive's mesh has NaN normals)
MIN_SIZE_M = 1e-9
#: the encodings a robot file may declare: UTF-8 (MuJoCo's XML parser reads nothing else) and its subset
UTF8_NAMES = ("utf-8", "utf8", "us-ascii", "ascii")
_DECLARATION = re.compile(rb"""^(?:\xef\xbb\xbf)?<\?xml[^>]*?\bencoding\s*=\s*["']([^"']*)["']""")


@dataclass
class Geometry:
    """One visual or collision element of a link.

    kind : "visual" or "collision". origin : (4, 4) pose of the geometry in the link.
    mesh : absolute path of the mesh file (None for a primitive or an MJCF mesh held in ``vertices``).
    scale : (3,) the model's own scale of the mesh file (0.001 for a CAD file in millimetres).
    primitive : "box" | "cylinder" | "sphere" | "capsule" | None, with ``size``: box (3,) full
        extents, cylinder/capsule (radius, length), sphere (radius,); metres.
    vertices, faces : an MJCF mesh as MuJoCo compiled it (already scaled, in the geometry frame).
    name : the element's name in the file, if any.
    """

    kind: str
    origin: np.ndarray
    mesh: Path | None = None
    scale: np.ndarray = field(default_factory=lambda: np.ones(3))
    primitive: str | None = None
    size: tuple = ()
    vertices: np.ndarray | None = None
    faces: np.ndarray | None = None
    name: str | None = None
    filename: str | None = None  # as written in the file (package://..., relative)


@dataclass
class Link:
    name: str
    visuals: list = field(default_factory=list)
    collisions: list = field(default_factory=list)

    def geometry(self, kind: str) -> list:
        if kind not in GEOMETRY_KINDS:
            raise InputError(f"geometry must be one of {', '.join(GEOMETRY_KINDS)}, got {kind!r}", key="--geometry")
        return self.visuals if kind == "visual" else self.collisions


@dataclass
class Joint:
    """A joint: ``origin`` is the child link's frame in the parent's at q = 0; ``axis`` (3,) unit
    in the child frame; ``lower``/``upper`` radians or metres (None: unlimited)."""

    name: str
    type: str
    parent: str
    child: str
    origin: np.ndarray
    axis: np.ndarray = field(default_factory=lambda: np.array([1.0, 0.0, 0.0]))
    lower: float | None = None
    upper: float | None = None
    pivot: np.ndarray | None = None  # (3,) a point of the axis in the child frame (MJCF's joint pos); None: origin
    mimic: tuple | None = None  # (joint, multiplier, offset): value = multiplier * q[joint] + offset (URDF <mimic>)


@dataclass
class Robot:
    """Links (in file order), joints, the root link, where it came from."""

    name: str
    path: Path
    format: str
    links: dict
    joints: list
    root: str

    def link(self, name: str) -> Link:
        """The link ``name``, or an InputError with the closest name (``vtcore robot info`` lists them all)."""
        if name not in self.links:
            names = list(self.links)
            hint = did_you_mean(name, names) or (f"; links: {', '.join(names[:12])}" + (
                f" ... ({len(names)} in all: vtcore robot info lists them)" if len(names) > 12 else ""))
            raise InputError(f"no link named {name!r}{hint}", file=self.path, key="--link")
        return self.links[name]

    @property
    def moving_joints(self) -> list:
        """The joints a configuration sets (moving, not mimicking another)."""
        return [j for j in self.joints if j.type in MOVING and j.mimic is None]

    def joint_value(self, joint: Joint, q: dict) -> float:
        if joint.type not in MOVING:
            return 0.0
        if joint.mimic is not None:
            name, mult, off = joint.mimic
            return mult * float(q.get(name, 0.0)) + off
        return float(q.get(joint.name, 0.0))

    def link_poses(self, q: dict | None = None) -> dict:
        """Pose (4, 4) of every link in the root's frame at joint values ``q`` (name -> value;
        missing joints at 0). Forward kinematics over the tree, parents before children."""
        q = q or {}
        unknown = set(q) - {j.name for j in self.joints}  # a mimic joint's value is its rule's, whatever given
        if unknown:
            first = sorted(unknown)[0]
            moving = [j.name for j in self.moving_joints]
            raise InputError(f"no joint named {', '.join(sorted(unknown))}{did_you_mean(first, moving)}; the moving "
                             f"joints: {', '.join(moving) or 'none'}", file=self.path, key="joints")
        poses = {self.root: np.eye(4)}
        children: dict = {}
        for j in self.joints:
            children.setdefault(j.parent, []).append(j)
        stack = [self.root]
        while stack:
            parent = stack.pop()
            for j in children.get(parent, []):
                poses[j.child] = poses[parent] @ j.origin @ joint_motion(j, self.joint_value(j, q))
                stack.append(j.child)
        for name in self.links:  # links no joint reaches (a forest): at the origin
            poses.setdefault(name, np.eye(4))
        return poses

    def random_configuration(self, rng) -> dict:
        """Joint values drawn uniformly within the limits (+-pi where a revolute joint has none)."""
        q = {}
        for j in self.moving_joints:
            lo = j.lower if j.lower is not None else -np.pi
            hi = j.upper if j.upper is not None else np.pi
            q[j.name] = float(rng.uniform(lo, hi))
        return q


def joint_motion(joint: Joint, value: float) -> np.ndarray:
    """(4, 4) motion of ``joint`` at ``value`` in its own frame (rotation about / slide along the axis)."""
    m = np.eye(4)
    if joint.type in ("revolute", "continuous") and value:
        from scipy.spatial.transform import Rotation

        m[:3, :3] = Rotation.from_rotvec(joint.axis * value).as_matrix()
        if joint.pivot is not None:
            m[:3, 3] = joint.pivot - m[:3, :3] @ joint.pivot
    elif joint.type == "prismatic" and value:
        m[:3, 3] = joint.axis * value
    return m


def pose(xyz=(0.0, 0.0, 0.0), rpy=(0.0, 0.0, 0.0)) -> np.ndarray:
    """(4, 4) from a translation and URDF roll-pitch-yaw (fixed axes x, y, z: R = Rz Ry Rx)."""
    from scipy.spatial.transform import Rotation

    m = np.eye(4)
    m[:3, :3] = Rotation.from_euler("xyz", rpy).as_matrix()
    m[:3, 3] = xyz
    return m


def read_xml(path, what: str = "robot file", comments: bool = False):
    """The robot file at ``path`` as an ``xml.etree.ElementTree.ElementTree``, read under the layout
    readers' discipline (:mod:`vtcore.inputs`): a regular file, UTF-8 text (a byte-order mark
    accepted), an XML declaration naming UTF-8 or none. One FormatError otherwise, naming the file
    and the byte offset, the declared encoding or the XML line; never a LookupError from an unknown
    encoding or a UnicodeDecodeError later, from a name MuJoCo copied byte for byte.
    comments : keep comments in the tree (the exporters write them back)."""
    import xml.etree.ElementTree as ET

    from ..inputs import clean, decode, read_bytes

    data = read_bytes(path, what)
    m = _DECLARATION.match(data)
    if m is not None and m.group(1).decode("ascii", "replace").strip().lower() not in UTF8_NAMES:
        raise FormatError(f"the XML declaration names the encoding {clean(m.group(1).decode('latin-1'), 40)!r}; "
                          "robot files are read as UTF-8: save it as UTF-8 (encoding=\"UTF-8\" or none)",
                          file=clean(path, 300), key="encoding", line=1)
    decode(data, path)  # the byte offset of the first byte that is not UTF-8, or a NUL
    parser = ET.XMLParser(target=ET.TreeBuilder(insert_comments=comments))
    try:
        parser.feed(data)
        return ET.ElementTree(parser.close())
    except ET.ParseError as exc:
        raise FormatError(f"not valid XML: {clean(exc, 200)}", file=clean(path, 300), line=exc.position[0]) from None


def check_extent(values, what: str, *, file=None, key=None, size: bool = False) -> np.ndarray:
    """``values`` as a float64 array, checked finite and within +-:data:`MAX_EXTENT_M` (``size``:
    within 0 .. MAX_EXTENT_M): a robot's coordinate or size beyond that is a unit error, and its
    products (a link's extent in mm, a pose) would overflow. FormatError naming ``what`` otherwise."""
    a = np.asarray(values, dtype=np.float64)
    if not np.isfinite(a).all():
        raise FormatError(f"{what} is not finite: {clean_numbers(a)}", file=file, key=key)
    lo = 0.0 if size else -MAX_EXTENT_M
    if a.size and (a.min() < lo or a.max() > MAX_EXTENT_M):
        raise FormatError(f"{what} must be within {lo:g} .. {MAX_EXTENT_M:g} m, got {clean_numbers(a)}",
                          file=file, key=key)
    if size and ((a != 0) & (np.abs(a) < MIN_SIZE_M)).any():  # a 1e-320 m sphere meshes to NaN normals
        raise FormatError(f"{what} must be 0 or at least {MIN_SIZE_M:g} m, got {clean_numbers(a)}", file=file, key=key)
    return a


def clean_numbers(a) -> str:
    """A short text of the numbers of ``a`` for a message."""
    return " ".join(f"{v:g}" for v in np.asarray(a, dtype=np.float64).ravel()[:6])
