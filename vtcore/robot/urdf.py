"""Read a URDF robot: links with their visual and collision geometry, joints.

The standard library's ElementTree, not yourdfpy or urchin: Import Robot runs inside Blender,
where only the extension's bundled wheels exist, and yourdfpy needs lxml (a binary wheel per
platform) for what is ~150 lines of reading here. The tests check this reader against yourdfpy
(link poses at random joint values, geometry origins and scales, resolved mesh paths) on real
robots from example-robot-data.

Mesh paths: ``package://NAME/rest`` is resolved through ``packages`` (NAME -> folder), then the
folders of ``ROS_PACKAGE_PATH`` (a folder NAME inside one, or one named NAME), then the URDF's own
ancestors (one named NAME, one holding NAME/rest, or one holding rest: a package installed under
another folder name, as example-robot-data is); ``file://`` paths are absolute; anything else is
relative to the URDF's folder.

Bad input is one error (docs/inputs.md): the file is read as UTF-8 (:func:`.model.read_xml`: an
unknown declared encoding or a byte that is not UTF-8 is named), and every number is checked where
it is read: finite, coordinates and sizes within +-1 km.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from ..errors import FormatError, InputError
from .model import MIN_SIZE_M, Geometry, Joint, Link, Robot, check_extent, pose, read_xml

NAME = "urdf"
JOINT_TYPES = ("revolute", "continuous", "prismatic", "fixed", "floating", "planar")


def _numbers(el, attr: str, n: int, path, default=None, extent: str | None = None) -> tuple:
    """``n`` finite numbers of the attribute ``attr`` of ``el`` (``default`` when it is absent).
    extent : "coordinate" (within +-1 km), "size" (0 .. 1 km) or None (finite only)."""
    text = el.get(attr) if el is not None else None
    if text is None:
        if default is None:
            raise FormatError(f"<{el.tag if el is not None else '?'}> needs {attr}", file=path, key=attr)
        return default
    try:
        vals = tuple(float(v) for v in text.split())
    except ValueError:
        raise FormatError(f"{attr}={text!r} is not {n} numbers", file=path, key=f"{el.tag}.{attr}") from None
    if len(vals) == 1 and n == 3 and attr == "scale":
        vals = vals * 3  # some exporters write one uniform scale
    if len(vals) != n or not np.isfinite(vals).all():
        raise FormatError(f"{attr}={text!r} is not {n} finite numbers", file=path, key=f"{el.tag}.{attr}")
    if extent is not None:
        check_extent(vals, f"{attr}={text!r}", file=path, key=f"{el.tag}.{attr}", size=extent == "size")
    if attr == "scale" and ((np.asarray(vals) != 0) & (np.abs(vals) < MIN_SIZE_M)).any():
        raise FormatError(f"scale={text!r} must be 0 or at least {MIN_SIZE_M:g} in size", file=path, key="mesh.scale")
    return vals


def origin_of(parent, path) -> np.ndarray:
    """4x4 pose given by the ``<origin>`` child of the URDF element ``parent`` (identity without one)."""
    o = parent.find("origin")
    if o is None:
        return np.eye(4)
    return pose(_numbers(o, "xyz", 3, path, (0.0, 0.0, 0.0), "coordinate"), _numbers(o, "rpy", 3, path, (0.0, 0.0, 0.0)))


def resolve(filename: str, urdf: Path, packages: dict | None = None) -> Path | None:
    """The file a URDF mesh ``filename`` names, or None when it cannot be found (see the module doc)."""
    if filename.startswith("file://"):
        p = Path(filename[7:])
        return p if p.is_file() else None
    if not filename.startswith("package://"):
        p = Path(filename)
        p = p if p.is_absolute() else urdf.parent / p
        return p if p.is_file() else None
    pkg, _, rest = filename[len("package://"):].partition("/")
    candidates = []
    if packages and pkg in packages:
        candidates.append(Path(packages[pkg]) / rest)
    for d in filter(None, os.environ.get("ROS_PACKAGE_PATH", "").split(os.pathsep)):
        d = Path(d)
        candidates += [d / pkg / rest, d / rest] if d.name != pkg else [d / rest]
    for a in urdf.resolve().parents:
        candidates += [a / rest] if a.name == pkg else [a / pkg / rest, a / rest]
    return next((c for c in candidates if c.is_file()), None)


def _geometry(el, kind: str, path: Path, packages) -> Geometry | None:
    g = el.find("geometry")
    if g is None or len(g) == 0:
        return None
    shape = g[0]
    origin = origin_of(el, path)
    name = el.get("name")
    if shape.tag == "mesh":
        filename = shape.get("filename")
        if not filename:
            raise FormatError(f"a {kind} <mesh> without filename", file=path, key="mesh.filename")
        return Geometry(kind, origin, resolve(filename, path, packages),
                        np.asarray(_numbers(shape, "scale", 3, path, (1.0, 1.0, 1.0), "coordinate")), name=name, filename=filename)
    if shape.tag == "box":
        return Geometry(kind, origin, primitive="box", size=_numbers(shape, "size", 3, path, extent="size"), name=name)
    if shape.tag in ("cylinder", "capsule"):
        return Geometry(kind, origin, primitive=shape.tag, name=name,
                        size=_numbers(shape, "radius", 1, path, extent="size")
                        + _numbers(shape, "length", 1, path, extent="size"))
    if shape.tag == "sphere":
        return Geometry(kind, origin, primitive="sphere", size=_numbers(shape, "radius", 1, path, extent="size"),
                        name=name)
    return None  # an unknown shape (e.g. a plugin's): no surface to lay skin on


def read(path, packages: dict | None = None) -> Robot:
    """The robot of the URDF at ``path``. packages : package name -> folder for ``package://``."""
    path = Path(path)
    if not path.is_file():
        raise InputError("robot file not found", file=path)
    root = read_xml(path).getroot()
    if root.tag != "robot":
        raise FormatError(f"the root element is <{root.tag}>, not <robot>", file=path)
    links = {}
    for el in root.findall("link"):
        name = el.get("name")
        if not name:
            raise FormatError("a <link> without a name", file=path, key="link.name")
        if name in links:
            raise FormatError(f"two links named {name!r}", file=path, key="link.name")
        link = Link(name)
        for kind, tag, into in (("visual", "visual", link.visuals), ("collision", "collision", link.collisions)):
            for g in el.findall(tag):
                geom = _geometry(g, kind, path, packages)
                if geom is not None:
                    into.append(geom)
        links[name] = link
    if not links:
        raise FormatError("no <link> in the robot", file=path)
    joints = []
    for el in root.findall("joint"):
        jt = el.get("type")
        if jt not in JOINT_TYPES:
            raise FormatError(f"joint {el.get('name')!r} has type {jt!r}; URDF types: {', '.join(JOINT_TYPES)}",
                              file=path, key="joint.type")
        parent, child = el.find("parent"), el.find("child")
        names = (parent.get("link") if parent is not None else None, child.get("link") if child is not None else None)
        for role, n in zip(("parent", "child"), names):
            if n not in links:
                raise FormatError(f"joint {el.get('name')!r}: its {role} link {n!r} is not a link of the robot",
                                  file=path, key=f"joint.{role}")
        if names[0] == names[1]:  # a loop of one joint: forward kinematics would never end (found by the place fuzz)
            raise FormatError(f"joint {el.get('name')!r}: its parent and child are the same link {names[0]!r}",
                              file=path, key="joint.child")
        axis = np.asarray(_numbers(el.find("axis"), "xyz", 3, path, (1.0, 0.0, 0.0)) if el.find("axis") is not None
                          else (1.0, 0.0, 0.0))
        norm = np.linalg.norm(axis)
        if norm == 0 and jt in ("revolute", "continuous", "prismatic"):
            raise FormatError(f"joint {el.get('name')!r} has a zero axis", file=path, key="joint.axis")
        lim = el.find("limit")
        lower = upper = None
        if lim is not None and jt in ("revolute", "prismatic"):
            lower = _numbers(lim, "lower", 1, path, (0.0,))[0]
            upper = _numbers(lim, "upper", 1, path, (0.0,))[0]
            if lower == upper == 0.0 and jt == "revolute":
                lower = upper = None  # a limit without bounds: URDF readers treat it as unlimited
            elif lower > upper:  # no value lies within: the exposure's sampled poses cannot be drawn
                raise FormatError(f"joint {el.get('name')!r}: limit lower {lower:g} is above upper {upper:g}",
                                  file=path, key="joint.limit")
        mim = el.find("mimic")
        mimic = None if mim is None or not mim.get("joint") else (
            mim.get("joint"), _numbers(mim, "multiplier", 1, path, (1.0,))[0], _numbers(mim, "offset", 1, path, (0.0,))[0])
        joints.append(Joint(el.get("name") or f"joint_{len(joints)}", jt, *names, origin_of(el, path),
                            axis / (norm or 1.0), lower, upper, mimic=mimic))
    _check_tree(joints, links, path)
    children = {j.child for j in joints}
    roots = [n for n in links if n not in children]
    return Robot(root.get("name") or path.stem, path, NAME, links, joints, roots[0])


def _check_tree(joints: list, links, path) -> None:
    """Refuse joints that do not make a tree (URDF's kinematics is one): a link that is the child of two
    joints, or links that no root reaches (the joints among them form a loop), in one line each."""
    parent_joint: dict = {}
    for j in joints:
        if j.child in parent_joint:
            raise FormatError(f"link {j.child!r} is the child of two joints ({parent_joint[j.child]!r} and "
                              f"{j.name!r}); a URDF's links form a tree", file=path, key="joint.child")
        parent_joint[j.child] = j.name
    roots = [n for n in links if n not in parent_joint]
    if not roots:
        raise FormatError("every link is some joint's child: the joints form a loop", file=path, key="joint")
    children: dict = {}
    for j in joints:
        children.setdefault(j.parent, []).append(j.child)
    seen, stack = set(roots), list(roots)
    while stack:
        for c in children.get(stack.pop(), []):
            if c not in seen:
                seen.add(c)
                stack.append(c)
    looped = [n for n in links if n not in seen]
    if looped:
        raise FormatError(f"the joints of links {', '.join(map(repr, looped[:5]))} form a loop that no root "
                          "link reaches; a URDF's links form a tree", file=path, key="joint")
