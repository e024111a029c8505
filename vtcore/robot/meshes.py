"""A link's surface: its visual or collision geometry loaded, scaled and placed in the link frame.

Mesh files load through trimesh (STL, OBJ, PLY; COLLADA ``.dae`` through pycollada, the Panda's
and UR's visual meshes). Each geometry's own ``scale`` (0.001 for a CAD file in millimetres) and
``origin`` are applied, so the result is the surface the robot's model means, in metres, in the
link frame: a skin laid on it is born in that frame.
"""

from __future__ import annotations

import warnings

import numpy as np

from ..errors import InputError
from ..layout import LayoutWarning
from ..layout.meshinput import SURFACE_SIZE_M, checked_mesh, read_trimesh
from .model import Geometry, Robot

#: metres: a link larger than this is almost surely a millimetre mesh whose model forgot its scale
LINK_SIZE_WARN_M = 5.0
#: facets round a primitive cylinder or capsule (a skin needs a surface finer than its 7.5 mm pitch)
PRIMITIVE_SECTIONS = 96


def _primitive(g: Geometry):
    import trimesh

    if g.primitive == "box":
        return trimesh.creation.box(extents=g.size)
    if g.primitive == "cylinder":
        return trimesh.creation.cylinder(radius=g.size[0], height=g.size[1], sections=PRIMITIVE_SECTIONS)
    if g.primitive == "capsule":
        return trimesh.creation.capsule(height=g.size[1], radius=g.size[0], count=[PRIMITIVE_SECTIONS, 48])
    return trimesh.creation.icosphere(subdivisions=4, radius=g.size[0])


def missing_mesh_hint(filename: str | None, robot: Robot) -> str:
    """Where a mesh the robot names was looked for, and what would find it: ``--package`` only
    for a ``package://`` path (a relative path is the robot file's folder's business)."""
    from pathlib import Path

    name = filename or ""
    if name.startswith("package://"):
        pkg = name[len("package://"):].partition("/")[0]
        return f" (map the package to its folder with --package {pkg}=FOLDER)"
    if name.startswith("file://"):
        return " (an absolute file:// path: no such file)"
    where = Path(name) if Path(name).is_absolute() else Path(robot.path).parent / name
    return f" (looked for {where}: paths are relative to the robot file's folder)"


def geometry_mesh(g: Geometry, robot: Robot):
    """One geometry as a ``trimesh.Trimesh`` in its link's frame, metres (origin and scale applied)."""
    import trimesh

    if g.primitive is not None:
        if not np.all(np.asarray(g.size, np.float64) > 0):
            # a <sphere radius="0"/> (placeholders do this) has no surface: trimesh's icosphere of radius 0 is
            # NaN, and its area would reach the exposure and `robot info` as NaN
            raise InputError(f"a {g.primitive} of size {' '.join(f'{v:g}' for v in g.size)} has no surface "
                             "(every size must be > 0)", file=robot.path, key=f"{g.kind} {g.primitive}")
        m = _primitive(g)
    elif g.vertices is not None:
        m = trimesh.Trimesh(g.vertices, g.faces, process=False, validate=False)
    else:
        if g.mesh is None:
            raise InputError(f"mesh {g.filename!r} not found{missing_mesh_hint(g.filename, robot)}", file=robot.path,
                             key="mesh")
        try:
            loaded = read_trimesh(g.mesh)
        except Exception as exc:  # trimesh raises many types for bad files  # noqa: BLE001
            raise InputError(f"cannot read mesh: {type(exc).__name__}: {exc}", file=g.mesh, key="mesh") from None
        if not len(getattr(loaded, "faces", ())):
            raise InputError("the mesh has no triangles", file=g.mesh, key="mesh")
        m = trimesh.Trimesh(np.asarray(loaded.vertices, np.float64) * g.scale, loaded.faces, process=False,
                            validate=False)
    m.apply_transform(g.origin)
    return m


def link_mesh(robot: Robot, link: str, geometry: str = "visual"):
    """The surface of ``link`` (all its ``geometry`` elements, "visual" or "collision", joined) as a
    checked ``trimesh.Trimesh`` in the link frame, metres. An InputError names a link without such
    geometry (and which kind it has), a missing file or an unreadable one."""
    import trimesh

    ln = robot.link(link)
    parts = ln.geometry(geometry)
    if not parts:
        other = "collision" if geometry == "visual" else "visual"
        hint = f" (it has {other} geometry: --geometry {other})" if ln.geometry(other) else " (nor any other)"
        raise InputError(f"link {link!r} has no {geometry} geometry{hint}", file=robot.path, key="--geometry")
    meshes = [geometry_mesh(g, robot) for g in parts]
    m = meshes[0] if len(meshes) == 1 else trimesh.util.concatenate(meshes)
    size = float(np.ptp(m.vertices, axis=0).max())
    if size > LINK_SIZE_WARN_M:
        warnings.warn(f"{robot.path}: link {link!r} is {size:.3g} m across: a mesh in millimetres without the "
                      "model's scale=\"0.001 0.001 0.001\"?", LayoutWarning, stacklevel=2)
    return checked_mesh(m.vertices, m.faces, size_range=SURFACE_SIZE_M, key=f"link {link}",
                        file=robot.path, process=False)


def describe(robot: Robot) -> list[dict]:
    """One record per link: its geometry (kind, file or primitive, scale, faces where loaded) for
    ``vtcore robot info``; meshes are read to count faces and measure size (metres)."""
    rows = []
    for name, ln in robot.links.items():
        for g in ln.visuals + ln.collisions:
            row = {"link": name, "kind": g.kind, "source": g.primitive or (str(g.mesh) if g.mesh else g.filename),
                   "scale": [float(v) for v in g.scale], "faces": None, "size_m": None, "error": None}
            try:
                m = geometry_mesh(g, robot)
                row["faces"], row["size_m"] = len(m.faces), float(np.ptp(m.vertices, axis=0).max())
            except InputError as exc:
                row["error"] = exc.reason
            if row["size_m"] is not None and row["size_m"] > LINK_SIZE_WARN_M:
                warnings.warn(f"{robot.path}: link {name!r} {g.kind} mesh {row['source']} is {row['size_m']:.3g} m "
                              "across: a mesh in millimetres without the model's scale=\"0.001 0.001 0.001\"?",
                              LayoutWarning, stacklevel=2)
            rows.append(row)
        if not ln.visuals and not ln.collisions:
            rows.append({"link": name, "kind": None, "source": None, "scale": None, "faces": None,
                         "size_m": None, "error": None})
    return rows
