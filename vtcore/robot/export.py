"""Export a skinned robot: the robot's own file with the skin's taxel frames or sensors added.

- URDF robot -> URDF: one fixed link per taxel under the layout's link (``vtcore.layout.io.urdf``).
- MJCF robot -> MJCF: sites and touch sensors in the link's body (``vtcore.layout.io.mjcf``),
  pads as the layout export has them; a body defined in an ``<include>``d file is written inline.
- In MJCF, each site reaches the link's contact surface as MuJoCo collides it, a mesh geom's
  convex hull, up to 8 mm over a UR10 link's mesh (:mod:`.reach`): a ball resting on the hull
  above a taxel is counted by that taxel.
- URDF robot -> MJCF: the robot converted by MuJoCo's own URDF import (``MjSpec``: every link a
  body of the same name, joints with their limits, collision meshes; COLLADA collision meshes, which
  MuJoCo does not read, converted to STL beside the output), then the skin added as above.

Every layout must be in a link's frame: ``layout.parent`` (or, with an identity transform and no
parent, ``layout.frame``) names the link and ``layout.transform`` is its pose there. The robot's own
elements are written back as they were (only the added ones are indented); relative mesh paths are
rebased when the output is in another folder.
"""

from __future__ import annotations

import os
import shutil
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np

from ..errors import FormatError, InputError
from ..layout import Layout
from ..layout.io import mjcf as mjcf_io
from ..layout.io import urdf as urdf_io
from ..layout.io.common import read_robot_xml
from .model import Robot
from .reach import contact_reach

FORMATS = ("urdf", "mjcf")


def robot_format(path) -> str:
    """``"urdf"`` or ``"mjcf"``: the root element of the robot file at ``path``."""
    path = Path(path)
    if not path.is_file():
        raise InputError("robot file not found", file=path)
    try:
        for _, el in ET.iterparse(path, events=("start",)):
            if el.tag == "robot":
                return "urdf"
            if el.tag == "mujoco":
                return "mjcf"
            break
    except ET.ParseError as exc:
        raise FormatError(f"not valid XML: {exc}", file=path, line=exc.position[0]) from None
    raise FormatError("not a robot file: the root element is neither <robot> (URDF) nor <mujoco> (MJCF)", file=path)


def load_robot(path, packages: dict | None = None) -> Robot:
    """The robot of a URDF or MJCF file (:mod:`.urdf`, :mod:`.mjcf`). packages : URDF package -> folder."""
    from . import mjcf, urdf

    return (urdf if robot_format(path) == "urdf" else mjcf).read(path, packages)


def skin_link(layout: Layout, links) -> str:
    """The link a layout hangs from: its ``parent``, else (no transform) its ``frame``."""
    link = layout.parent or layout.frame
    if link not in links:
        raise InputError(f"the layout is in frame {layout.frame!r}"
                         + (f" placed in {layout.parent!r}" if layout.parent else "")
                         + f", not a link of the robot (links: {', '.join(list(links)[:40])}); lay it on a link "
                         "(vtcore layout place ROBOT --link NAME) or say where its frame sits "
                         "(vtcore layout reframe --pose T --parent LINK)", key="layout")
    return link


def _rebase_urdf(root: ET.Element, src_dir: Path, out_dir: Path) -> None:
    if src_dir.resolve() == out_dir.resolve():
        return
    for mesh in root.iter("mesh"):
        f = mesh.get("filename") or ""
        if f and "://" not in f and not os.path.isabs(f):
            mesh.set("filename", os.path.relpath(src_dir / f, out_dir))


def urdf_as_mjcf(robot_path, out, packages: dict | None = None) -> ET.ElementTree:
    """The URDF robot at ``robot_path`` as an MJCF tree (MuJoCo's URDF import through ``MjSpec``):
    links become bodies of the same name (``fusestatic`` off), visual geometry is left out (MuJoCo's
    URDF default), collision meshes are copied (COLLADA converted to STL) to ``<out stem>_meshes/``
    beside ``out`` and referenced relative to it."""
    import tempfile

    import mujoco
    import trimesh

    from .urdf import resolve

    robot_path, out = Path(robot_path), Path(out)
    tree = read_robot_xml(robot_path, "robot")
    root = tree.getroot()
    assets = out.parent / f"{out.stem}_meshes"
    copies: dict = {}
    for link in root.findall("link"):
        for vis in link.findall("visual"):
            link.remove(vis)
        for mesh in link.iter("mesh"):
            f = mesh.get("filename") or ""
            src = resolve(f, robot_path, packages)
            if src is None:
                raise InputError(f"collision mesh {f!r} not found (map its package with --package NAME=FOLDER)",
                                 file=robot_path, key="mesh")
            if src not in copies:
                assets.mkdir(parents=True, exist_ok=True)
                ext = src.suffix.lower() if src.suffix.lower() in (".stl", ".obj", ".msh") else ".stl"
                dst = assets / f"{len(copies):02d}_{src.stem}{ext}"
                if ext == src.suffix.lower():
                    shutil.copyfile(src, dst)
                else:  # MuJoCo reads STL, OBJ and MSH only
                    trimesh.load(src, force="mesh", process=False).export(dst)
                copies[src] = dst
            mesh.set("filename", str(copies[src].resolve()))
    ext = ET.SubElement(root, "mujoco")
    ET.SubElement(ext, "compiler", fusestatic="false", discardvisual="true", balanceinertia="true")
    with tempfile.TemporaryDirectory() as tmp:
        p = Path(tmp) / "robot.urdf"
        tree.write(p, encoding="unicode")
        try:
            spec = mujoco.MjSpec.from_file(str(p))
        except ValueError as exc:
            raise FormatError(f"MuJoCo cannot import it: {str(exc).strip().splitlines()[0]}", file=robot_path) from None
        xml = spec.to_xml()  # compiles: the copied meshes are referenced by absolute paths until here
    root = ET.fromstring(xml)
    compiler = root.find("compiler")
    if compiler is not None:
        for key in ("meshdir", "assetdir"):
            compiler.attrib.pop(key, None)
    for mesh in root.iter("mesh"):  # relative to the output's folder, where the model is written
        if mesh.get("file"):
            mesh.set("file", os.path.relpath(mesh.get("file"), out.parent))
    return ET.ElementTree(root)


def export_skinned(robot_path, layouts, out, *, format: str | None = None, prefixes=None,
                   packages: dict | None = None, **mjcf_options) -> list[dict]:
    """Write the robot at ``robot_path`` with the skins ``layouts`` added, to ``out``.

    format : "urdf" or "mjcf" (default: from ``out``'s suffix, ``.urdf`` or ``.xml``/``.mjcf``).
    prefixes : one name prefix per layout (None: ``<link>_vtskin_``). mjcf_options : ``footprint``,
    ``pad``, ``site_radius``, ``pad_thickness`` of :func:`vtcore.layout.io.mjcf.write`.
    Returns one record per layout: ``link``, ``taxels``, ``names`` (first and last).
    """
    from .._io import atomic_write  # noqa: F401  (the writers below write atomically)

    robot_path, out = Path(robot_path), Path(out)
    layouts = [layouts] if isinstance(layouts, Layout) else list(layouts)
    if not layouts:
        raise InputError("give at least one layout", key="layouts")
    prefixes = list(prefixes) if prefixes is not None else [None] * len(layouts)
    if len(prefixes) != len(layouts):
        raise InputError(f"{len(prefixes)} prefixes for {len(layouts)} layouts", key="--prefix")
    fmt = format or {".urdf": "urdf", ".xml": "mjcf", ".mjcf": "mjcf"}.get(out.suffix.lower())
    if fmt not in FORMATS:
        raise InputError(f"cannot tell the format from {out.name!r}; pass --format urdf or mjcf", key="--format")
    source = robot_format(robot_path)
    if fmt == "urdf" and source == "mjcf":
        raise InputError("an MJCF robot is exported as MJCF (--format mjcf)", file=robot_path, key="--format")
    if fmt == "urdf" and mjcf_options:
        raise InputError(f"{', '.join('--' + k.replace('_', '-') for k in mjcf_options)}: MJCF options",
                         key="--format")
    records = []
    if fmt == "urdf":
        tree = read_robot_xml(robot_path, "robot")
        links = [e.get("name") for e in tree.getroot().findall("link")]
        for lay, prefix in zip(layouts, prefixes):
            link = skin_link(lay, links)
            names = urdf_io.merge_into_tree(lay, tree, link, prefix=prefix, model=robot_path)
            records.append({"link": link, "taxels": len(lay), "names": [names[0], names[-1]] if names else []})
        _rebase_urdf(tree.getroot(), robot_path.parent, out.parent)
        urdf_io.write_tree(tree, out)
        return records
    if source == "urdf":
        tree = urdf_as_mjcf(robot_path, out, packages)
        model_dir = out.parent
    else:
        tree, model_dir = read_robot_xml(robot_path, "mujoco"), robot_path.parent
    links = [b.get("name") for b in tree.getroot().iter("body")]
    if source == "mjcf" and tree.getroot().find(".//include") is not None:
        mjcf_io.inline_includes(tree.getroot(), robot_path.parent, robot_path)
        links = [b.get("name") for b in tree.getroot().iter("body")]
    robot = load_robot(robot_path, packages)
    for lay, prefix in zip(layouts, prefixes):
        link = skin_link(lay, links)
        # each site reaches the link's contact surface as MuJoCo collides it (a mesh's convex hull)
        reach = contact_reach(robot, link, *taxel_frames(lay)) if link in robot.links else None
        names = mjcf_io.merge_into_tree(lay, tree, link, robot_path, prefix=prefix, reach=reach,
                                        **{"pad": False, **mjcf_options})
        records.append({"link": link, "taxels": len(lay), "names": [names[0], names[-1]] if names else []})
    mjcf_io.rebase(tree.getroot(), model_dir, out.parent)
    mjcf_io.write_tree(tree, out)
    return records


def taxel_frames(layout: Layout) -> tuple[np.ndarray, np.ndarray]:
    """(N, 3) taxel positions and (N, 3) normals in the layout's link (its transform applied)."""
    t = layout.transform
    return layout.positions @ t[:3, :3].T + t[:3, 3], layout.normals @ t[:3, :3].T
