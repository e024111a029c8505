"""A robot's own file (URDF or MJCF) as an XML tree that a skin is added to: read it with its
comments, refuse names it already has, indent only what was added. Shared by :mod:`.urdf_tree`
and :mod:`.mjcf_tree`."""

from __future__ import annotations

from ..errors import FormatError, InputError


def read_robot_xml(model, root_tag: str):
    """The robot file ``model`` (MJCF or URDF) as an ElementTree with its comments, checked to
    exist, to be XML and to have the root element ``root_tag``."""
    import xml.etree.ElementTree as ET
    from pathlib import Path

    model = Path(model)
    if not model.is_file():
        raise InputError("robot model not found", file=model, key="--model")
    try:
        tree = ET.parse(model, parser=ET.XMLParser(target=ET.TreeBuilder(insert_comments=True)))
    except ET.ParseError as exc:
        raise FormatError(f"not valid XML: {exc}", file=model, line=exc.position[0]) from None
    if tree.getroot().tag != root_tag:
        raise FormatError(f"the root element is <{tree.getroot().tag}>, not <{root_tag}>", file=model)
    return tree


def refuse_clash(taken, names, model, what: str, prefix: str) -> None:
    """An InputError naming the ``names`` the model already ``taken`` (and the option to change)."""
    clash = sorted(set(taken) & set(names))
    if clash:
        more = f" and {len(clash) - 5} more" if len(clash) > 5 else ""
        raise InputError(f"the robot already has {what} named {', '.join(clash[:5])}{more}: the skin's names "
                         f"start with {prefix!r}; pass another --prefix", file=model, key="--prefix")


def indent_added(root, added, space: str = "  ") -> None:
    """Indent the elements ``added`` to the tree under ``root`` like the file's own, touching
    none of the file's other text (``ET.indent`` of the whole tree would rewrite the robot's
    own whitespace). Each added element's parent decides its depth."""
    import xml.etree.ElementTree as ET

    parent_of = {c: p for p in root.iter() for c in p}
    added = set(map(id, added))
    for parent in {parent_of[e] for e in parent_of if id(e) in added}.union(
            [root] if any(id(c) in added for c in root) else []):
        depth, el = 0, parent
        while el in parent_of:
            el, depth = parent_of[el], depth + 1
        kids = list(parent)
        inner, outer = "\n" + space * (depth + 1), "\n" + space * depth
        if not (parent.text or "").strip():
            parent.text = inner
        for k, e in enumerate(kids):
            if id(e) in added:
                ET.indent(e, space=space, level=depth + 1)
                if k:
                    kids[k - 1].tail = inner
                e.tail = outer if k == len(kids) - 1 else inner
