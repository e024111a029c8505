"""A skin's sites, pads and touch sensors merged into a robot's MJCF (the elements of
:func:`vtcore.layout.io.mjcf.add_skin`), in the body the skin lies on: a body defined in an
``<include>``d file is written inline, the robot's own elements are written back as they were
(only the added ones indented), relative file references are rebased to the output's folder
(MuJoCo's ``<compiler>`` directories, read as MuJoCo reads them), and a link's contact surface
can be replaced by convex meshes (:func:`replace_contact`)."""

from __future__ import annotations

import os
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np

from .._io import write_xml
from ..errors import InputError
from ..layout import Layout
from ..layout.io.common import skin_prefix, taxel_labels
from ..layout.io.mjcf import add_skin, module_body, size_arena
from .robot_xml import indent_added, read_robot_xml, refuse_clash


def _body_frame(layout: Layout) -> tuple[np.ndarray, np.ndarray]:
    """Taxel positions and normals in the parent body (the layout's transform applied)."""
    t = layout.transform
    return layout.positions @ t[:3, :3].T + t[:3, 3], layout.normals @ t[:3, :3].T


def compiler_dirs(root: ET.Element) -> dict:
    """The ``meshdir``, ``texturedir`` and ``assetdir`` MuJoCo compiles ``root`` with (None where unset):
    ``<compiler>`` may repeat, and each one's attributes override the earlier ones' (a second
    ``<compiler meshdir=...>`` was read by MuJoCo but missed here: found by the robot export fuzz)."""
    dirs = dict.fromkeys(("meshdir", "texturedir", "assetdir"))
    for compiler in root.findall("compiler"):
        dirs.update({k: compiler.get(k) for k in dirs if compiler.get(k) is not None})
    return dirs


def rebase(root: ET.Element, src_dir: Path, out_dir: Path) -> None:
    """Keep the robot's relative file references valid from the output's folder."""
    if src_dir.resolve() == out_dir.resolve():
        return
    rel = lambda f: os.path.relpath(src_dir / f, out_dir)  # noqa: E731
    compilers = root.findall("compiler")
    if not compilers:
        compilers = [ET.Element("compiler")]
        root.insert(0, compilers[0])
        indent_added(root, compilers)
    unset_assetdir = compiler_dirs(root)["assetdir"] is None
    for compiler in compilers:  # every one: a later compiler's dirs override an earlier one's
        for key in ("meshdir", "texturedir", "assetdir"):
            v = compiler.get(key)
            if v is not None and not os.path.isabs(v):
                compiler.set(key, rel(v))
    if unset_assetdir:
        compilers[0].set("assetdir", rel("."))  # files without a dir were relative to the model
    for inc in root.iter("include"):
        f = inc.get("file")
        if f and not os.path.isabs(f):
            inc.set("file", rel(f))


def colliding_geoms(root: ET.Element, body: ET.Element) -> int:
    """How many of ``body``'s own geoms take part in collisions (``contype`` or ``conaffinity``
    non-zero after the default classes, ``childclass`` and the geom's own attributes)."""
    classes: dict[str, dict] = {}

    def visit(el, inherited):
        attrs = dict(inherited)
        g = el.find("geom")
        if g is not None:
            attrs.update({k: g.get(k) for k in ("contype", "conaffinity") if g.get(k) is not None})
        classes[el.get("class", "main")] = attrs
        for child in el.findall("default"):
            visit(child, attrs)

    for top in root.findall("default"):
        visit(top, {})
    parent = {c: p for p in root.iter() for c in p}
    child_class, el = None, body
    while el is not None and child_class is None:
        child_class = el.get("childclass")
        el = parent.get(el)
    n = 0
    for g in body.findall("geom"):
        attrs = dict(classes.get(g.get("class") or child_class or "main", {}))
        attrs.update({k: g.get(k) for k in ("contype", "conaffinity") if g.get(k) is not None})
        # MuJoCo reads a blank value as the default 1 (contype="": found by the robot export fuzz)
        n += any(int((attrs.get(k) or "1").strip() or "1") != 0 for k in ("contype", "conaffinity"))
    return n


def replace_contact(root: ET.Element, body: ET.Element, files, prefix: str) -> list[str]:
    """Make the convex meshes ``files`` (paths, in ``body``'s frame, metres) ``body``'s contact surface:
    its own colliding geoms stop colliding (``contype`` = ``conaffinity`` = 0; they stay, for their mass
    and looks), and one massless mesh geom per file is added (``<prefix><k>``, its asset too, file
    given as is; :func:`relative_contact_files` makes it relative later). Returns the geom names."""
    for g in body.findall("geom"):
        g.set("contype", "0")
        g.set("conaffinity", "0")
    asset = root.find("asset")
    if asset is None:
        asset = ET.Element("asset")
        root.insert(1 if root.find("compiler") is not None else 0, asset)
    added, names = [], []
    for k, f in enumerate(files):
        name = f"{prefix}{k}"
        added.append(ET.SubElement(asset, "mesh", name=name, file=str(f)))
        added.append(ET.SubElement(body, "geom", name=name, type="mesh", mesh=name, density="0",
                                   contype="1", conaffinity="1", group="3", rgba="0.6 0.6 0.9 0.3"))
        names.append(name)
    indent_added(root, added + ([asset] if len(asset) == len(files) else []))
    return names


def relative_contact_files(root: ET.Element, names, out_dir: Path) -> None:
    """Write the ``file`` of the mesh assets ``names`` relative to where MuJoCo looks for meshes of the
    model written in ``out_dir`` (the compiler's ``meshdir``, else ``assetdir``, else the model's folder)."""
    dirs = compiler_dirs(root)
    base = dirs["meshdir"] or dirs["assetdir"] or ""
    base_dir = Path(base) if os.path.isabs(base) else Path(out_dir) / base
    names = set(names)
    for mesh in root.iter("mesh"):
        if mesh.get("name") in names:
            mesh.set("file", os.path.relpath(Path(mesh.get("file")).resolve(), base_dir.resolve()))


def inline_includes(root: ET.Element, model_dir: Path, model) -> None:
    """Replace every ``<include file=...>`` under ``root`` by the children of the included
    file's ``<mujoco>`` (MuJoCo's own semantics: paths relative to the main model's folder,
    includes nested inside included files too), so a body an include defines can take sites."""
    seen = 0
    while True:
        parent_of = {c: p for p in root.iter() for c in p}
        inc = next((e for e in root.iter("include") if e in parent_of), None)
        if inc is None:
            return
        seen += 1
        if seen > 1000:
            raise InputError("more than 1000 <include>s: a file including itself?", file=model)
        f = inc.get("file") or ""
        sub = read_robot_xml(model_dir / f if not os.path.isabs(f) else Path(f), "mujoco").getroot()
        parent = parent_of[inc]
        k = list(parent).index(inc)
        parent.remove(inc)
        for j, child in enumerate(list(sub)):
            parent.insert(k + j, child)


def merge_into_model(layout: Layout, model, body: str | None = None, **options) -> ET.ElementTree:
    """The robot MJCF ``model`` (a path) with the skin added to its body ``body`` (default the
    layout's parent, else its frame). A body defined in an ``<include>``d file is found there:
    the includes are then written inline, every element as it was."""
    tree = read_robot_xml(model, "mujoco")
    merge_into_tree(layout, tree, body, model, **options)
    return tree


def merge_into_tree(layout: Layout, tree: ET.ElementTree, body: str | None, model, **options) -> list[str]:
    """Add the skin's sites (pads) and touch sensors to body ``body`` of the MJCF ``tree`` read from
    the file ``model``; returns the site names. See :func:`merge_into_model`."""
    body = body or layout.parent or layout.frame
    root = tree.getroot()
    find = lambda: next((b for b in root.iter("body") if b.get("name") == body), None)  # noqa: E731
    target = find()
    if target is None and root.find(".//include") is not None:
        inline_includes(root, Path(model).parent, model)
        target = find()
    if target is None:
        names = [b.get("name") for b in root.iter("body") if b.get("name")]
        raise InputError(f"no body named {body!r}; bodies: {', '.join(names[:40]) or 'none'}",
                         file=model, key="--body")
    if not options.get("pad") and options.get("footprint", "taxel") == "taxel" and not colliding_geoms(root, target):
        import warnings

        from ..layout import LayoutWarning

        warnings.warn(f"{model}: body {body!r} has no colliding geom (none, or only contype=conaffinity=0): its "
                      "touch sensors would read 0; export with pad=True (--pad) to give the skin a contact surface",
                      LayoutWarning, stacklevel=3)
    taken = {e.get("name") for e in root.iter() if e.get("name")}
    prefix = skin_prefix(body, options.pop("prefix", None))
    labels = taxel_labels(layout)
    names = [f"{prefix}{lab}" for lab in labels]
    suffixes = ("", "_touch", "_pad", "_cell")
    refuse_clash(taken, [n + s for n in names for s in suffixes]
                 + [module_body(prefix, m) for m in np.unique(layout.module_ids)], model, "elements", prefix)
    pos, nrm = _body_frame(layout)
    sensor = root.find("sensor")
    if sensor is None:
        sensor = ET.SubElement(root, "sensor")
    before = {id(e) for e in root.iter()}
    out = add_skin(layout, target, sensor, positions=pos, normals=nrm, prefix=prefix, **options)
    indent_added(root, [e for e in root.iter() if id(e) not in before])
    return out


def write_tree(tree: ET.ElementTree, path) -> None:
    """Write an MJCF tree (written to a temporary file, then renamed)."""
    write_xml(tree, path)


def write_skinned(layout: Layout, path, model, body: str | None = None, *, pad: bool | None = None,
                  prefix: str | None = None, **options) -> None:
    """The robot MJCF ``model`` with the skin merged into ``body`` (:func:`merge_into_model`), its relative
    file references rebased to ``path``'s folder, written to ``path``: the merge alone, the robot's
    collision geometry as it is (:func:`vtcore.robot.export_skinned` also rebuilds a contact surface
    that does not hug the skin, and checks that MuJoCo reads every site). pad : default False.
    options : ``footprint``, ``site_radius``, ``pad_thickness`` of :func:`vtcore.layout.io.mjcf.add_skin`."""
    tree = merge_into_model(layout, model, body, pad=bool(pad), prefix=prefix, **options)
    if options.get("footprint") == "tile":  # a body per taxel: MuJoCo's broadphase needs the room
        size_arena(tree.getroot(), len(layout), model)
    rebase(tree.getroot(), Path(model).parent, Path(path).parent)
    write_tree(tree, path)
