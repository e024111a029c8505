"""A skin's taxel frames merged into a robot's URDF: one fixed link per taxel under the link it lies on
(the elements of :func:`vtcore.layout.io.urdf.add_skin`), the robot's own elements written back as
they were, relative mesh paths rebased to the output's folder."""

from __future__ import annotations

import os
import xml.etree.ElementTree as ET
from pathlib import Path

from .._io import write_xml
from ..errors import InputError
from ..layout import Layout
from ..layout.io.common import skin_prefix, taxel_labels
from ..layout.io.urdf import add_skin
from .robot_xml import indent_added, read_robot_xml, refuse_clash


def merge_into_tree(layout: Layout, tree: ET.ElementTree, parent: str, *, prefix: str | None = None,
                    model=None) -> list[str]:
    """Add the skin's taxel frames under link ``parent`` of the robot ``tree`` (the robot's own
    elements untouched); an unknown link or a name the robot already has is an InputError."""
    robot = tree.getroot()
    links = [e.get("name") for e in robot.findall("link")]
    if parent not in links:
        raise InputError(f"no link named {parent!r}; links: {', '.join(links[:40]) or 'none'}",
                         file=model, key="--parent")
    taken = set(links) | {e.get("name") for e in robot.findall("joint")}
    prefix = skin_prefix(parent, prefix)
    labels = taxel_labels(layout)
    names = [f"{prefix}{lab}" for lab in labels]
    refuse_clash(taken, names + [f"{n}_joint" for n in names], model, "links or joints", prefix)
    start = len(robot)
    out = add_skin(layout, robot, parent, prefix)
    indent_added(robot, list(robot)[start:])
    return out


def rebase(root: ET.Element, src_dir: Path, out_dir: Path) -> None:
    """Keep the robot's relative mesh paths valid from the output's folder (``package://`` and
    absolute paths are left as they are)."""
    if src_dir.resolve() == out_dir.resolve():
        return
    for mesh in root.iter("mesh"):
        f = mesh.get("filename") or ""
        if f and "://" not in f and not os.path.isabs(f):
            mesh.set("filename", os.path.relpath(src_dir / f, out_dir))


def write_tree(tree: ET.ElementTree, path) -> None:
    """Write a URDF tree (written to a temporary file, then renamed)."""
    write_xml(tree, path, '<?xml version="1.0"?>\n')


def write_skinned(layout: Layout, path, model, parent: str | None = None, *, prefix: str | None = None) -> None:
    """The robot URDF ``model`` with the skin's taxel frames under link ``parent`` (default: the layout's
    ``parent``, else its ``frame``; the layout's ``transform`` is its pose there), relative mesh paths
    rebased to ``path``'s folder, written to ``path``: the merge alone (:func:`vtcore.robot.export_skinned`
    also reads the robot and the written file back)."""
    tree = read_robot_xml(model, "robot")
    merge_into_tree(layout, tree, parent or layout.parent or layout.frame, prefix=prefix, model=model)
    rebase(tree.getroot(), Path(model).parent, Path(path).parent)
    write_tree(tree, path)
