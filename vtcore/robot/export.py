"""Export a skinned robot: the robot's own file with the skin's taxel frames or sensors added.

- URDF robot -> URDF: one fixed link per taxel under the layout's link (:mod:`.urdf_tree`).
- MJCF robot -> MJCF: sites and touch sensors in the link's body (:mod:`.mjcf_tree`),
  pads as the layout export has them; a body defined in an ``<include>``d file is written inline.
- In MJCF, a skinned link whose colliding geometry does not hug its skin (a mesh's convex hull 8 mm
  over a UR10 forearm's, the Allegro palm's box around its visual mesh) collides by convex parts that
  follow the surface the skin lies on instead (:mod:`.contact_geometry`: CoACD, cut under the taxels,
  with taxel-sized pads); each site reaches that contact surface (:mod:`.reach`). MuJoCo's own rays
  then probe every site of the written model at the zero pose and 8 seeded configurations: each
  record names the taxels that cannot read (``unreadable``, ``unreadable_why``) and those a
  neighbour covers at some poses (``covered_at_some_poses``).
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
from ..layout.io.common import identifier
from ..layout.io.mjcf import size_arena, taxel_radius
from . import mjcf_tree, urdf_tree
from .model import Robot, read_xml
from .reach import POSES, ball_reach, contact_reach, unreadable_sites
from .robot_xml import read_robot_xml

FORMATS = ("urdf", "mjcf")
#: kg m^2: MuJoCo's compiler refuses an inertia with an eigenvalue under this (mjMINVAL; iCub's
#: ``r_ankle_1``: 0.75 kg, eigenvalues ~1e-20); such a link with mass gets a box's inertia in the MJCF
INERTIA_MIN = 1e-15
#: metres: a rebuilt link's pads reach this far beyond their taxel's disc (under it, not over its neighbours)
PAD_RIM = 1e-3


def robot_format(path) -> str:
    """``"urdf"`` or ``"mjcf"``: the root element of the robot file at ``path``."""
    path = Path(path)
    if not path.is_file():
        raise InputError("robot file not found", file=path)
    tag = read_xml(path).getroot().tag  # UTF-8 and its declaration checked (model.read_xml)
    if tag in ("robot", "mujoco"):
        return "urdf" if tag == "robot" else "mjcf"
    raise FormatError("not a robot file: the root element is neither <robot> (URDF) nor <mujoco> (MJCF)", file=path)


def load_robot(path, packages: dict | None = None) -> Robot:
    """The robot of a URDF or MJCF file (:mod:`.urdf`, :mod:`.mjcf`). packages : URDF package -> folder."""
    from . import mjcf, urdf

    return (urdf if robot_format(path) == "urdf" else mjcf).read(path, packages)


def skin_link(layout: Layout, links) -> str:
    """The link a layout hangs from: its ``parent``, else (no transform) its ``frame``."""
    link = layout.parent or layout.frame
    links = [n for n in links if n]  # an MJCF body may have no name
    if link not in links:
        raise InputError(f"the layout is in frame {layout.frame!r}"
                         + (f" placed in {layout.parent!r}" if layout.parent else "")
                         + f", not a link of the robot (links: {', '.join(list(links)[:40])}); lay it on a link "
                         "(vtcore layout place ROBOT --link NAME) or say where its frame sits "
                         "(vtcore layout reframe --pose T --parent LINK)", key="layout")
    return link


def urdf_as_mjcf(robot_path, out, packages: dict | None = None) -> ET.ElementTree:
    """The URDF robot at ``robot_path`` as an MJCF tree (MuJoCo's URDF import through ``MjSpec``):
    links become bodies of the same name (``fusestatic`` off), visual geometry is left out (MuJoCo's
    URDF default), collision meshes are copied (COLLADA converted to STL) to ``<out stem>_meshes/``
    beside ``out`` and referenced relative to it."""
    import tempfile

    import mujoco
    import trimesh

    from .mjcf import mujoco_error, mujoco_messages, warn_messages
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
    repair_inertias(root, robot_path, packages)
    ext = ET.SubElement(root, "mujoco")
    ET.SubElement(ext, "compiler", fusestatic="false", discardvisual="true", balanceinertia="true")
    with tempfile.TemporaryDirectory() as tmp, mujoco_messages() as said:
        p = Path(tmp) / "robot.urdf"
        tree.write(p, encoding="unicode")
        try:
            spec = mujoco.MjSpec.from_file(str(p))
        except ValueError as exc:
            raise mujoco_error(exc, "import", robot_path, said) from None
        try:
            xml = spec.to_xml()  # compiles: the copied meshes are referenced by absolute paths until here
        except ValueError as exc:
            raise mujoco_error(exc, "compile", robot_path, said) from None
    warn_messages(said, robot_path)
    root = ET.fromstring(xml)
    compiler = root.find("compiler")
    if compiler is None:
        compiler = ET.Element("compiler")
        root.insert(0, compiler)
    for key in ("meshdir", "assetdir"):
        compiler.attrib.pop(key, None)
    # the import balanced inertias that break A + B >= C (TIAGo's arm_1_link) but writes the model's
    # own numbers back, which MuJoCo then refuses on loading: the written model balances them too
    compiler.set("balanceinertia", "true")
    for mesh in root.iter("mesh"):  # relative to the output's folder, where the model is written
        if mesh.get("file"):
            mesh.set("file", os.path.relpath(mesh.get("file"), out.parent))
    return ET.ElementTree(root)


def repair_inertias(root: ET.Element, robot_path, packages: dict | None = None) -> list[str]:
    """Give each URDF link of ``root`` that has mass but an inertia that is not positive definite
    (an eigenvalue under :data:`INERTIA_MIN`; iCub's ``l_ankle_2``: 0.27 kg, all six entries 0) the inertia of a
    solid box of that mass spanning its collision geometry (its visual geometry, else a 2 cm cube),
    about the inertial frame's axes: MuJoCo's compiler refused such a body ("inertia must have
    positive eigenvalues"), so the robot could not be exported as MJCF at all. ``balanceinertia``
    only repairs inertias that break the triangle inequality. Warns naming the links; returns them."""
    import warnings

    from .meshes import link_mesh
    from .urdf import origin_of

    fixed = []
    robot = None
    for link in root.findall("link"):
        inertia, mass = link.find("inertial/inertia"), link.find("inertial/mass")
        if inertia is None or mass is None:
            continue
        try:
            m = float(mass.get("value", "0"))
            i = np.array([[float(inertia.get(k, "0")) for k in row] for row in
                          (("ixx", "ixy", "ixz"), ("ixy", "iyy", "iyz"), ("ixz", "iyz", "izz"))])
        except ValueError:
            continue  # MuJoCo's own import names the bad number
        # MuJoCo refuses such an inertia with products of inertia (fullinertia: iCub's l_ankle_2) and
        # on a moving body (iCub's r_hip_1: "mass and inertia of moving bodies must be larger than
        # mjMINVAL"); on a fixed leaf (Talos's 0.1 kg force-torque links, all zeros) it takes a point
        # mass, which no part of a robot is: one rule for all. Every other inertia is the maker's.
        if not (m > 0 and np.all(np.isfinite(i))) or np.linalg.eigvalsh(i).min() >= INERTIA_MIN:
            continue
        if robot is None:
            robot = load_robot(robot_path, packages)
        inertial = link.find("inertial")
        frame, ln = origin_of(inertial, robot_path), robot.links[link.get("name")]
        geometry = "collision" if ln.geometry("collision") else ("visual" if ln.geometry("visual") else None)
        if geometry is None:
            size = np.full(3, 0.02)
        else:
            v = link_mesh(robot, link.get("name"), geometry).vertices
            v = (v - frame[:3, 3]) @ frame[:3, :3]  # in the inertial frame
            size = np.maximum(v.max(0) - v.min(0), 1e-3)
        sq = size ** 2
        box = m / 12 * np.array([sq[1] + sq[2], sq[0] + sq[2], sq[0] + sq[1]])
        for k, key in enumerate(("ixx", "iyy", "izz")):
            inertia.set(key, f"{box[k]:.6g}")
        for key in ("ixy", "ixz", "iyz"):
            inertia.set(key, "0")
        fixed.append(link.get("name"))
    if fixed:
        warnings.warn(f"{robot_path}: {len(fixed)} links have mass but an inertia that is not positive definite, "
                      f"which MuJoCo refuses or takes as a point mass ({', '.join(fixed[:6])}"
                      f"{', ...' if len(fixed) > 6 else ''}): the MJCF gives each the inertia of a solid box of "
                      "its mass spanning its geometry", stacklevel=3)
    return fixed


def export_skinned(robot_path, layouts, out, *, format: str | None = None, prefixes=None,
                   packages: dict | None = None, **mjcf_options) -> list[dict]:
    """Write the robot at ``robot_path`` with the skins ``layouts`` added, to ``out``.

    format : "urdf" or "mjcf" (default: from ``out``'s suffix, ``.urdf`` or ``.xml``/``.mjcf``).
    prefixes : one name prefix per layout (None: ``<link>_vtskin_``). mjcf_options : ``footprint``,
    ``pad``, ``site_radius``, ``pad_thickness`` of :func:`vtcore.layout.io.mjcf.add_skin`.
    Returns one record per layout: ``link``, ``taxels``, ``names`` (first and last).

    The file and its ``<out stem>_meshes/`` folder (a URDF robot as MJCF) are written into a staging
    folder beside ``out`` and moved in together at the end (:func:`vtcore._io.staged_into`): a robot
    that MuJoCo or vtcore refuses leaves nothing behind.
    """
    from .._io import staged_into
    from ..inputs import check_output_file

    out = check_output_file(out)
    with staged_into(out.parent, prefix=".vtcore-export-") as stage:
        records = _export_skinned(robot_path, layouts, out, stage / out.name, format=format, prefixes=prefixes,
                                  packages=packages, **mjcf_options)
        _read_back(stage, out, packages)
    return records


def _read_back(stage: Path, out: Path, packages: dict | None) -> None:
    """The consumer judges before anything lands: our reader (MuJoCo's compiler for MJCF) reads the
    staged export back. Where the staging folder holds only the file, its relative paths (meshes of
    the robot's own folder, rebased) hold from ``out``'s folder: a hidden copy is read there; with its
    ``_meshes/`` folder staged beside it, it is read where it is."""
    probe = probe_copy(stage / out.name, out)
    try:
        load_robot(probe, packages)
    except InputError as exc:
        raise FormatError(f"the exported robot would not read back: {exc.reason}", file=out) from None
    finally:
        probe.unlink(missing_ok=True)


def probe_copy(staged: Path, out: Path) -> Path:
    """A hidden copy of the staged export beside ``out``, where it will land, that reads as ``out``
    will: its relative paths hold from ``out``'s folder, and a file reference that will resolve into
    what is staged beside it (``<out stem>_meshes/``) points there absolutely. The caller removes it."""
    probe = out.parent / f".{out.stem}.vtcore-check-{os.getpid()}{out.suffix}"
    tree = ET.parse(staged)
    root = tree.getroot()
    if root.tag == "mujoco":
        base = mjcf_tree.compiler_dirs(root)
        for el in root.iter():
            f = el.get("file")
            if not f or os.path.isabs(f) or el.tag == "include":
                continue
            sub = base["meshdir" if el.tag in ("mesh", "skin") else "texturedir" if el.tag == "texture" else ""] \
                if el.tag in ("mesh", "skin", "texture") else None
            d = sub or base["assetdir"] or ""
            final = Path(os.path.normpath(out.parent / d / f))
            rel = os.path.relpath(final, out.parent)
            if not rel.startswith("..") and (staged.parent / rel).exists():
                el.set("file", str((staged.parent / rel).resolve()))
    else:
        for el in root.iter("mesh"):
            f = el.get("filename")
            if f and "://" not in f and not os.path.isabs(f) and (staged.parent / f).exists():
                el.set("filename", str((staged.parent / f).resolve()))
    tree.write(probe, encoding="utf-8", xml_declaration=True)
    return probe


def reuse_decomposition(mesh, previous: Path, folder: Path) -> None:
    """Copy a convex decomposition of ``mesh`` an earlier export left in ``previous`` (the final
    ``<out stem>_meshes/``) into ``folder`` (the staged one), where :func:`.contact_geometry.convex_parts`
    finds it: CoACD takes ~10 s a link, its result is the same for the same mesh."""
    from .contact_geometry import cache_key

    if not previous.is_dir():
        return
    key = cache_key(mesh)
    for f in sorted(previous.glob(f"contact_{key}_*.stl")):
        folder.mkdir(parents=True, exist_ok=True)
        shutil.copyfile(f, folder / f.name)


def _export_skinned(robot_path, layouts, out, staged, *, format: str | None = None, prefixes=None,
                    packages: dict | None = None, **mjcf_options) -> list[dict]:
    """:func:`export_skinned`, its files written to ``staged`` (``out``'s name in the staging folder);
    paths inside them are relative to ``out``'s folder, where they land."""
    robot_path, out, staged = Path(robot_path), Path(out), Path(staged)
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
    if fmt == "urdf":
        return _export_urdf(robot_path, layouts, prefixes, out, staged, packages)
    tree, model_dir, links = _mjcf_tree(robot_path, source, out, staged, packages)
    records, sites, contact_geoms = _merge_mjcf_skins(robot_path, layouts, prefixes, tree, links, out, staged,
                                                      packages, mjcf_options)
    if mjcf_options.get("footprint") == "tile":  # a body per taxel: MuJoCo's broadphase needs the room
        size_arena(tree.getroot(), sum(len(lay) for lay in layouts), robot_path)
    mjcf_tree.rebase(tree.getroot(), model_dir, out.parent)
    mjcf_tree.relative_contact_files(tree.getroot(), contact_geoms, out.parent)
    mjcf_tree.write_tree(tree, staged)
    probe = probe_copy(staged, out)
    try:
        for rec, names in zip(records, sites):  # MuJoCo's own rays judge the written model
            bad, some = unreadable_sites(probe, names, poses=POSES)
            rec["unreadable"] = [n for n in names if n in bad]
            rec["unreadable_why"] = bad
            rec["covered_at_some_poses"] = some  # read at the zero pose, not at some of POSES random ones
    finally:
        probe.unlink(missing_ok=True)
    return records


def _export_urdf(robot_path: Path, layouts: list, prefixes: list, out: Path, staged: Path, packages) -> list[dict]:
    """The URDF export of :func:`_export_skinned`: each layout's taxel links merged into the robot's
    tree, its mesh paths rebased to ``out``'s folder, written to ``staged``; one record per layout."""
    records = []
    load_robot(robot_path, packages)  # a robot our reader refuses is refused, not exported
    tree = read_robot_xml(robot_path, "robot")
    links = [e.get("name") for e in tree.getroot().findall("link")]
    for lay, prefix in zip(layouts, prefixes):
        link = skin_link(lay, links)
        names = urdf_tree.merge_into_tree(lay, tree, link, prefix=prefix, model=robot_path)
        records.append({"link": link, "taxels": len(lay), "names": [names[0], names[-1]] if names else []})
    urdf_tree.rebase(tree.getroot(), robot_path.parent, out.parent)
    urdf_tree.write_tree(tree, staged)
    return records


def _mjcf_tree(robot_path: Path, source: str, out: Path, staged: Path, packages):
    """``(tree, model_dir, links)``: the robot as an MJCF tree (a URDF converted, its meshes relative to
    ``staged`` as to ``out``; an MJCF's includes inlined), the folder its paths are relative to, and its
    body names."""
    if source == "urdf":
        tree = urdf_as_mjcf(robot_path, staged, packages)  # its meshes: relative to the staged file, as to out
        model_dir = out.parent
    else:
        tree, model_dir = read_robot_xml(robot_path, "mujoco"), robot_path.parent
    links = [b.get("name") for b in tree.getroot().iter("body")]
    if source == "mjcf" and tree.getroot().find(".//include") is not None:
        mjcf_tree.inline_includes(tree.getroot(), robot_path.parent, robot_path)
        links = [b.get("name") for b in tree.getroot().iter("body")]
    return tree, model_dir, links


def _merge_mjcf_skins(robot_path: Path, layouts: list, prefixes: list, tree, links: list, out: Path, staged: Path,
                      packages, mjcf_options: dict):
    """Merge each layout's sites (and pads) into the MJCF ``tree``, each link's contact surface rebuilt
    once under all its skins. Returns ``(records, site names per layout, contact geom names)``."""
    robot = load_robot(robot_path, packages)
    contact_geoms, sites, contact, records = [], [], {}, []
    skins: dict = {}  # link -> every skin on it: its contact surface is cut under all of them
    for lay in layouts:
        skins.setdefault(lay.parent or lay.frame, []).append(lay)
    # links whose hull would hold a ball off another link's skin collide by convex parts (skinned or not)
    crowding = crowding_links(robot, layouts, [skin_link(lay, links) for lay in layouts])
    for lay, prefix in zip(layouts, prefixes):
        link = skin_link(lay, links)
        reach = None
        if link in robot.links:
            # the link's contact surface follows the surface the skin lies on (convex parts), and each
            # site reaches that surface as MuJoCo collides it
            if link not in contact:  # once per link, however many skins it carries
                parts, geoms = link_contact(robot, link, skins.get(link, [lay]), tree, out, staged,
                                            force=link in crowding)
                contact[link] = (parts, bool(geoms))
                contact_geoms += geoms
            parts, rebuilt = contact[link]
            frames = taxel_frames(lay)
            reach = contact_reach(robot, link, *frames, parts=parts)
            if rebuilt:  # each pad rises over where a ball coming down onto its taxel would rest on the parts
                reach = np.maximum(reach, ball_reach(parts, *frames, BALL_M))
        # on a rebuilt link the skin brings its own contact surface: pads under the taxels, where the
        # decomposition's parts (a few mm off the mesh) may lie below it or not reach it
        opts = {**mjcf_options, "pad": mjcf_options.get("pad") if mjcf_options.get("pad") is not None
                else bool(reach is not None and rebuilt)}
        if opts["pad"] and reach is not None and rebuilt:
            opts.setdefault("pad_radius", taxel_radius(lay) + PAD_RIM)
        names = mjcf_tree.merge_into_tree(lay, tree, link, robot_path, prefix=prefix, reach=reach, **opts)
        sites.append(names)
        records.append({"link": link, "taxels": len(lay), "names": [names[0], names[-1]] if names else []})
    contact_geoms += decompose_links(robot, crowding - set(contact), tree, out, staged)
    return records, sites, contact_geoms


def link_contact(robot: Robot, link: str, layouts, tree: ET.ElementTree, out: Path, staged: Path,
                 force: bool = False):
    """``(parts, geom names)``: the convex parts MuJoCo will collide ``link`` by in the exported
    MJCF ``tree``, and the names of the geoms added for them. The link's own colliding geometry (each
    collision element's hull) where it already hugs the skins ``layouts`` (:func:`.contact_geometry.needs_parts`);
    else a convex decomposition of the geometry the skin was laid on (``meta["geometry"]``, default
    collision; written to the staged ``<out stem>_meshes/`` (``staged``: out's name in the staging
    folder), a decomposition already in out's own folder reused), cut under the skin (:func:`.contact_geometry.under_skin`),
    replaces the link's colliding geoms; the parts are written there as ``<link>_contact_<k>.stl``.
    force : decompose even where the link's hulls hug its skins (they hold a ball off another link's:
    :func:`crowding_links`)."""
    from .contact_geometry import convex_parts, needs_parts, under_skin
    from .meshes import link_mesh
    from .reach import collision_hulls, reach_to
    from .skin import occluded

    frames = [taxel_frames(lay) for lay in layouts]
    positions, normals = np.vstack([f[0] for f in frames]), np.vstack([f[1] for f in frames])
    hulls = collision_hulls(robot, link)
    if hulls and not force and not needs_parts(*reach_to(hulls, positions, normals)):
        return hulls, []
    geometry = layouts[0].meta.get("geometry") or "collision"
    if not robot.link(link).geometry(geometry):
        geometry = "collision" if geometry == "visual" else "visual"
    if not robot.link(link).geometry(geometry):
        return hulls, []  # no surface to follow: MuJoCo collides what the file has
    folder = staged.parent / f"{out.stem}_meshes"
    mesh = link_mesh(robot, link, geometry)
    reuse_decomposition(mesh, out.parent / f"{out.stem}_meshes", folder)
    u = normals / np.linalg.norm(normals, axis=1, keepdims=True)
    covered = occluded(mesh, positions + 1e-4 * u, u)  # under the link's own mesh: a pocket, left as it is
    parts = convex_parts(mesh, folder)
    if force and hulls:  # it crowds another link's skin: not beyond its hull there either
        parts = within_hulls(parts, hulls)
    parts = under_skin(parts, positions, normals, covered)
    if not parts:
        return hulls, []
    files = []  # where they will be once the staged set lands in out's folder
    for k, part in enumerate(parts):
        name = f"{identifier(link)}_contact_{k:02d}.stl"
        part.export(folder / name)
        files.append((out.parent / folder.name / name).resolve())
    body = next(b for b in tree.getroot().iter("body") if b.get("name") == link)
    names = mjcf_tree.replace_contact(tree.getroot(), body, files, f"{identifier(link)}_vtcontact_")
    return parts, names


#: metres: a ball this wide rests on each taxel (the MuJoCo check's 20 g ball); a link whose hull reaches
#: into it where the link's own surface stays clear of it collides by convex parts instead
BALL_M, BALL_CLEAR_M = 0.0085, 0.001


def crowding_links(robot: Robot, layouts, links) -> set:
    """The links (names) whose contact surface as MuJoCo collides it (each collision element's convex
    hull) reaches where a ball resting on another link's taxel would be at the zero pose while their own
    collision surface leaves that ball free: the G1's wrist yaw hull over the wrist pitch's skin, where
    the ball rested on the hull and every sensor read 0. layouts : with ``links`` (their links' names)."""
    from .exposure import RobotSurfaces, rigid_inverse
    from .reach import collision_hulls

    poses = robot.link_poses({})
    centres, owner = [], []
    for lay, link in zip(layouts, links):
        if link not in robot.links:
            continue
        p, n = taxel_frames(lay)
        n = n / np.linalg.norm(n, axis=1, keepdims=True)
        t = poses[link]
        centres.append((p + (BALL_M + BALL_CLEAR_M) * n) @ t[:3, :3].T + t[:3, 3])
        owner += [link] * len(p)
    if not centres:
        return set()
    centres, owner = np.vstack(centres), np.array(owner)
    surfaces, out = RobotSurfaces(robot, "collision"), set()
    for name, ln in robot.links.items():
        if not ln.collisions:
            continue
        t = rigid_inverse(poses[name])
        c = centres @ t[:3, :3].T + t[:3, 3]
        near = np.zeros(len(c), bool)
        for hull in collision_hulls(robot, name):  # half-space bound: within the ball's radius of the hull
            nrm = np.asarray(hull.face_normals)
            d = np.einsum("ij,ij->i", nrm, np.asarray(hull.triangles)[:, 0])
            near |= (c @ nrm.T - d).max(axis=1) < BALL_M
        near &= owner != name  # its own skin: link_contact's parts, cut under it
        if near.any() and surfaces.mesh(name) is not None and (surfaces.distance(name, c[near]) >= BALL_M).any():
            out.add(name)
    return out


def decompose_links(robot: Robot, names, tree: ET.ElementTree, out: Path, staged: Path) -> list:
    """Make each link of ``names`` (carrying no skin) collide by a convex decomposition of its collision
    surface (:func:`.contact_geometry.convex_parts`) in the exported ``tree``; returns the geom names added."""
    from .contact_geometry import convex_parts
    from .meshes import link_mesh
    from .reach import collision_hulls

    bodies = {b.get("name"): b for b in tree.getroot().iter("body")}
    folder, added = staged.parent / f"{out.stem}_meshes", []
    for name in sorted(names):
        if name not in bodies:
            continue
        mesh = link_mesh(robot, name, "collision")
        reuse_decomposition(mesh, out.parent / f"{out.stem}_meshes", folder)
        files = []
        for k, part in enumerate(within_hulls(convex_parts(mesh, folder), collision_hulls(robot, name))):
            fname = f"{identifier(name)}_contact_{k:02d}.stl"
            part.export(folder / fname)
            files.append((out.parent / folder.name / fname).resolve())
        added += mjcf_tree.replace_contact(tree.getroot(), bodies[name], files, f"{identifier(name)}_vtcontact_")
    return added


def within_hulls(parts, hulls) -> list:
    """The convex ``parts`` each cut to the union of the convex ``hulls`` (the link's collision elements
    as MuJoCo collided them): CoACD decomposes a decimated mesh, whose parts poke a few mm out of the
    link's hull, over the next link's skin at a mating face (the G1 wrist pitch's over the wrist roll's:
    a taxel that read with the hull was covered by the parts). A part outside every hull is dropped."""
    import trimesh

    out = []
    for part in parts:
        pieces = []
        for hull in hulls:
            try:
                cut = trimesh.boolean.intersection([part, hull], engine="manifold")
            except (ValueError, RuntimeError):  # a degenerate part: keep it as CoACD gave it
                cut = part
            if len(cut.faces) >= 4 and cut.volume > 1e-12:
                pieces.append(cut.convex_hull)
        out += pieces
    return out or list(parts)


def taxel_frames(layout: Layout) -> tuple[np.ndarray, np.ndarray]:
    """(N, 3) taxel positions and (N, 3) normals in the layout's link (its transform applied)."""
    t = layout.transform
    return layout.positions @ t[:3, :3].T + t[:3, 3], layout.normals @ t[:3, :3].T
