"""Robots for a front end: import a robot as link meshes, bring a calibrated layout onto a link,
export the robot with its skins.

The add-on's *Import Robot*, *Import Layout* and *Export Skinned Robot* each call one function
here. Everything is in SI units and plain numpy; nothing imports ``bpy``.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ...errors import InputError
from .skin import LayoutEdit, skin_triangles


@dataclass
class LinkPart:
    """One link of an imported robot.

    name : the link's name in the file. parent : the parent link's name (None for the root).
    matrix : (4, 4) the link's pose in the robot's root frame at the imported configuration.
    vertices : (V, 3) metres, faces (F, 3): the link's geometry in the link's own frame (its
    model's origins and scale applied), empty when it has none. note : why a link has no mesh.
    exposure : (F,) int8 reason codes of :mod:`vtcore.robot.exposure` per face (0 exposed) at the
    zero pose, or None; legend : what its colours mean (:func:`vtcore.robot.exposure.legend`).
    """

    name: str
    parent: str | None
    matrix: np.ndarray
    vertices: np.ndarray
    faces: np.ndarray
    note: str = ""
    exposure: np.ndarray | None = None
    legend: list = field(default_factory=list)


@dataclass
class RobotImport:
    name: str
    path: Path
    format: str
    geometry: str
    links: list = field(default_factory=list)
    joints: dict = field(default_factory=dict)
    notes: list = field(default_factory=list)


def parse_joint_values(text: str) -> dict:
    """``"elbow=0.5, wrist=-1"`` (radians or metres) as a dict; empty text: {} (the zero pose)."""
    out = {}
    for item in filter(None, (t.strip() for t in str(text).replace(";", ",").split(","))):
        name, sep, value = item.partition("=")
        try:
            v = float(value)
        except ValueError:
            v = float("nan")
        if not sep or not name.strip() or not np.isfinite(v):
            raise InputError(f"give joint values as name=number, got {item!r}", key="joints")
        out[name.strip()] = v
    return out


def parse_packages(text: str) -> dict:
    """``"name=/folder; other=/elsewhere"`` (URDF package:// folders) as a dict."""
    out = {}
    for item in filter(None, (t.strip() for t in str(text).split(";"))):
        name, sep, folder = item.partition("=")
        if not sep or not name.strip() or not folder.strip():
            raise InputError(f"give packages as NAME=FOLDER; ..., got {item!r}", key="packages")
        out[name.strip()] = folder.strip()
    return out


def import_robot(path, *, geometry: str = "visual", joints: dict | None = None,
                 packages: dict | None = None, exposure: bool = True) -> RobotImport:
    """Read the robot at ``path`` (URDF or MJCF) for a scene: every link with its ``geometry``
    ("visual" or "collision"; a link without it falls back to the other kind) in its own frame,
    and its pose at ``joints`` (name -> value; default the zero pose). A link whose mesh cannot be
    read is imported without it and says why in ``note``; a missing robot file is an InputError.
    exposure : give each link its exposed surface at the zero pose (``LinkPart.exposure``, ``legend``:
    faces covered by another link or out of an 8 mm probe's reach). The exposure's distance queries
    need open3d, which the Blender extension does not bundle: without it the links come without
    exposure and ``notes`` says so (the robot itself imports the same)."""
    import importlib.util
    from ...robot import link_mesh, load_robot
    from ...robot.exposure import RobotSurfaces, exposed_faces, legend
    from ...robot.model import GEOMETRY_KINDS

    if geometry not in GEOMETRY_KINDS:
        raise InputError(f"geometry must be one of {', '.join(GEOMETRY_KINDS)}, got {geometry!r}", key="geometry")
    robot = load_robot(path, packages)
    poses = robot.link_poses(joints or {})
    parent_of = {j.child: j.parent for j in robot.joints}
    out = RobotImport(robot.name, robot.path, robot.format, geometry, joints=dict(joints or {}))
    if exposure and importlib.util.find_spec("open3d") is None:
        exposure = False
        out.notes.append("the exposed surface is not shown: it needs open3d (pip install open3d into "
                         "Blender's Python, or use vtcore robot info)")
    surfaces = {k: RobotSurfaces(robot, k) for k in GEOMETRY_KINDS}
    zero = [robot.link_poses({})]
    for name, link in robot.links.items():
        if "::" in name:  # the inner frame of an MJCF body with several joints: not a link
            continue
        kinds = [geometry] + [k for k in GEOMETRY_KINDS if k != geometry]
        kind = next((k for k in kinds if link.geometry(k)), None)
        v, f, note = np.zeros((0, 3)), np.zeros((0, 3), np.int64), "" if kind else "no geometry"
        exp = None
        if kind is not None:
            try:
                mesh = link_mesh(robot, name, kind)
                v, f = np.asarray(mesh.vertices, np.float64), np.asarray(mesh.faces, np.int64)
                note = "" if kind == geometry else f"{kind} geometry (it has no {geometry})"
                if exposure:
                    exp = exposed_faces(robot, name, kind, mesh=mesh, surfaces=surfaces[kind], configs=zero)
            except InputError as exc:
                note = exc.reason
        parent = parent_of.get(name)
        while parent is not None and "::" in parent:
            parent = parent_of.get(parent)
        out.links.append(LinkPart(name, parent, poses[name], v, f, note, None if exp is None else exp.reason,
                                  [] if exp is None else legend(exp)))
    return out


def import_layout(path, format: str | None = None, *, units: str | None = None, link: str | None = None
                  ) -> LayoutEdit:
    """A calibrated layout file (json, icub, cyskin, csv, ply) to put on a link object, ids intact.

    link : the name of the frame the object holds (a robot link, or the object's own name). A layout
    whose frame sits in its parent by a transform (a CySkin ``tf_matrix``, ``layout reframe --pose``)
    is placed on the link by it (the link is taken to be that parent; the notes say when the file
    names another); a layout without one is in the link's frame as it is. Returns the layout (in the
    link's frame), its skin mesh (the file's own faces where it has them) and a report with ``notes``.
    """
    from ...layout import load

    lay = load(path, format, units=units)
    notes = []
    if not np.allclose(lay.transform, np.eye(4)):
        # the file's transform is the pose of its frame in the link it belongs to (a CySkin tf_matrix):
        # the link the user puts it on
        src, parent = lay.frame, lay.parent
        lay = lay.posed(lay.transform, link or parent or "link").in_parent()
        notes.append(f"placed by the file's transform (frame {src!r} in "
                     + (f"{parent!r}" if parent else "its parent link") + ")"
                     + (f"; the file names {parent!r}, put on {link!r}" if parent and link and parent != link else ""))
    elif link is not None and lay.frame not in (link, "end_effector"):
        notes.append(f"the file's frame is {lay.frame!r}; the taxels are put on {link!r} as they are")
    if link is not None:
        lay.frame = link
    faces = lay.meta.get("faces")
    tri = np.asarray(faces, np.int64).reshape(-1, 3) if faces is not None and len(faces) else skin_triangles(lay)
    if len(tri) and (tri.min() < 0 or tri.max() >= len(lay)):
        tri = skin_triangles(lay)
    return LayoutEdit(lay, tri, {"notes": notes, "taxels": len(lay), "source": str(path)})


def export_skinned_robot(robot_path, skins, out, format: str | None = None, *, prefix: str | None = None,
                         packages: dict | None = None, **mjcf_options) -> list[dict]:
    """Write the robot at ``robot_path`` with ``skins`` in it to ``out`` (URDF, or MJCF: sites and
    touch sensors). skins : layouts, each in a link's frame (``frame`` the link, as a skin laid on an
    imported link object is). prefix : one prefix for a single skin, or a ``{link}`` template (e.g.
    ``"{link}_palm_"``) for several (default ``<link>_vtskin_``). mjcf_options : ``footprint``,
    ``pad``, ... (:func:`vtcore.robot.export_skinned`)."""
    from ...layout.io.common import identifier
    from ...robot import export_skinned

    skins = list(skins)
    if not skins:
        raise InputError("no skin on a link of this robot: lay or import one on an imported link first", key="skins")
    prefixes = None
    if prefix:
        prefixes = [prefix.format(link=identifier(s.parent or s.frame)) if "{link}" in prefix else prefix
                    for s in skins]
    return export_skinned(robot_path, [s.subset(slice(None)) for s in skins], out, format=format,
                          prefixes=prefixes, packages=packages, **mjcf_options)
