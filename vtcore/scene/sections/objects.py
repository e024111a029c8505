"""``[[objects]]``: what touches the skin.

One table per object: ``kind`` (cube, cuboid, box, sphere,
halfcylinder, cylinder, ruler, mug, fingerpad (a capsule: radius, length tip to tip), or ``mesh`` with ``mesh = "file.stl"`` and
``scale``), its dimensions (metres; defaults are seed 001's objects), where it is
(``position`` [x, y] on the skin, ``yaw`` rad, ``gap`` m above the layer, ``flip``),
optional trajectory ``keyframes`` ([{t, offset = [dx, dy, dz], yaw}]) and its
compliance (``stiffness`` N/m, ``stiffness_edge`` N/m at its outline, or a
per-vertex ``stiffness_file`` .npy).
"""

from __future__ import annotations

import numpy as np

from ...contact.objects import DEFAULTS, SIZE_RANGE_M, make_object, placement_pose
from ...contact.proximity import OPEN_MESH
from ...errors import InputError
from ...layout.meshinput import load_mesh
from ..budget import STIFFNESS_N_M
from ..registry import register_section
from ..schema import Field, Section
from .layer import build_layer

_DIMS = {
    "side": Field("float", default=None, gt=0, unit="m"),
    "length": Field("float", default=None, gt=0, unit="m"),
    "radius": Field("float", default=None, gt=0, unit="m"),
    "height": Field("float", default=None, gt=0, unit="m"),
    "width": Field("float", default=None, gt=0, unit="m"),
    "thickness": Field("float", default=None, gt=0, unit="m"),
    "wall": Field("float", default=None, gt=0, unit="m"),
    "bottom": Field("float", default=None, gt=0, unit="m"),
    "extents": Field("vec", default=None, length=3, unit="m"),
    "subdivisions": Field("int", default=None, ge=0, le=7),
    "sections": Field("int", default=None, ge=8, le=4096),
    "bend_radius": Field("float", default=None, ge=0, unit="m",
                         doc="fingerpad: radius of its bent axis (0 straight; > radius: wraps a convex skin)"),
}

KEYFRAME = Section({
    "t": Field("float", ge=0, unit="s", doc="time of the keyframe"),
    "offset": Field("vec", default=[0.0, 0.0, 0.0], length=3, unit="m",
                    doc="translation added to the object's placement (z: towards the skin is negative)"),
    "yaw": Field("float", default=0.0, unit="rad", doc="extra rotation about the skin normal"),
})

OBJECT = Section({
    "name": Field("str", default="object"),
    "kind": Field("str", default="sphere", choices=tuple(DEFAULTS) + ("mesh",)),
    **_DIMS,
    "mesh": Field("path", default=None, doc="mesh file (kind = \"mesh\")"),
    "scale": Field("float", default=1.0, gt=0, doc="mesh file units -> metres (0.001 for millimetres)"),
    "open_mesh": Field("str", default="error", choices=OPEN_MESH,
                       doc="what to do with an open mesh: error, fill its holes, or use its envelope only"),
    "position": Field("vec", default=[0.0, 0.0], length=2, unit="m",
                      doc="where the object's axis crosses the skin"),
    "yaw": Field("float", default=0.0, unit="rad"),
    "gap": Field("float", default=1e-3, ge=-0.1, le=1.0, unit="m",
                 doc="distance above the layer before pressing (-0.1 .. 1 m; negative: starting in contact)"),
    "flip": Field("bool", default=True, doc="turn the object over so its top face meets the skin"),
    "keyframes": Field("tables", default=[], section=KEYFRAME, doc="trajectory keyframes"),
    "stiffness": Field("float", default=None, ge=STIFFNESS_N_M[0], le=STIFFNESS_N_M[1], unit="N/m",
                       doc="object stiffness (object_compliance)"),
    "stiffness_edge": Field("float", default=None, ge=STIFFNESS_N_M[0], le=STIFFNESS_N_M[1], unit="N/m",
                            doc="stiffness at the object's outline; varies with r^2 from `stiffness` at its axis"),
    "stiffness_file": Field("path", default=None, doc=".npy per-vertex stiffness, N/m"),
}, check=lambda o: ([("mesh", "kind = \"mesh\" needs a mesh file")] if o["kind"] == "mesh" and not o["mesh"]
                    else []) + ([("keyframes", "keyframe times must increase")]
                                if any(b["t"] <= a["t"] for a, b in zip(o["keyframes"], o["keyframes"][1:]))
                                else []))

register_section("objects", Field("tables", default=[], section=OBJECT))


def object_mesh(scene, i: int):
    """The mesh of ``[[objects]][i]`` (object frame, metres), checked closed unless open_mesh says otherwise."""
    from ...contact.proximity import prepare_mesh

    o = scene["objects"][i]
    key = f"objects[{i}]"
    try:
        if o["kind"] == "mesh":
            try:  # the primitives' size range (make_object) holds for mesh objects too
                mesh = load_mesh(o["mesh"], o["scale"], size_range=SIZE_RANGE_M, key=None,
                                 scale_key=f"{key}.scale")
            except InputError as exc:
                raise scene.error(f"{key}.mesh", str(exc)) from None
        else:
            dims = {k: (tuple(o[k]) if k == "extents" else o[k]) for k in _DIMS if o[k] is not None}
            mesh = make_object(o["kind"], **dims)
        return prepare_mesh(mesh, open_mesh=o["open_mesh"], name=f"{key} ({o['name']})")
    except ValueError as exc:
        if getattr(exc, "file", None):
            raise
        k = getattr(exc, "key", None)
        raise scene.error(f"{key}.{k}" if k and k in OBJECT.fields else key, getattr(exc, "reason", str(exc))) \
            from None


def _skin_top(scene) -> float:
    """Height (z) of the layer's outer surface at its highest point, metres.

    Every scene has a layout (without layout tables: the default patch on the default
    end-effector), so any error building it is a real one and reaches the user.
    """
    from .layout import build_layout

    layer = build_layer(scene)
    lay = build_layout(scene)
    return float((lay.positions[:, 2] + layer.thickness * lay.normals[:, 2]).max())


def object_pose(scene, i: int, mesh=None, top: float | None = None) -> np.ndarray:
    """(4, 4) pose of ``[[objects]][i]`` before pressing (end-effector frame)."""
    o = scene["objects"][i]
    mesh = mesh if mesh is not None else object_mesh(scene, i)
    top = _skin_top(scene) if top is None else top
    return placement_pose(mesh, xy=o["position"], yaw=o["yaw"], top=top, gap=o["gap"], flip=o["flip"])


def keyframe_poses(scene, i: int, times, mesh=None, top: float | None = None) -> np.ndarray:
    """(T, 4, 4) poses of ``[[objects]][i]`` at ``times`` (s), linear between keyframes, held outside."""
    o = scene["objects"][i]
    base = object_pose(scene, i, mesh, top)
    times = np.asarray(times, float).reshape(-1)
    out = np.repeat(base[None], len(times), axis=0)
    kf = o["keyframes"]
    if not kf:
        return out
    kt = np.array([k["t"] for k in kf])
    off = np.array([k["offset"] for k in kf], float)
    yaw = np.array([k["yaw"] for k in kf], float)
    ox = np.column_stack([np.interp(times, kt, off[:, j]) for j in range(3)])
    yw = np.interp(times, kt, yaw)
    c, s = np.cos(yw), np.sin(yw)
    rz = np.zeros((len(times), 3, 3))
    rz[:, 0, 0], rz[:, 0, 1], rz[:, 1, 0], rz[:, 1, 1], rz[:, 2, 2] = c, -s, s, c, 1.0
    # rotate about the object's own axis (through its placement point), then translate
    axis = base[:3, 3].copy()
    out[:, :3, :3] = rz @ base[:3, :3]
    out[:, :3, 3] = np.einsum("tij,j->ti", rz, base[:3, 3] - axis * np.array([1, 1, 0])) + \
        axis * np.array([1, 1, 0]) + ox
    return out


def object_compliance(scene, i: int, mesh=None):
    """Stiffness of ``[[objects]][i]`` for vtcore.contact.press(compliance=...): None, a number,
    per-vertex values, or a callable of object-frame points."""
    o = scene["objects"][i]
    if o["stiffness_file"]:
        try:
            vals = np.load(o["stiffness_file"], allow_pickle=False).astype(float).reshape(-1)
        except (OSError, ValueError, TypeError, EOFError) as exc:  # not a .npy of numbers
            raise scene.error(f"objects[{i}].stiffness_file", f"cannot read a .npy array of numbers: {exc}") from None
        mesh = mesh if mesh is not None else object_mesh(scene, i)
        if len(vals) != len(mesh.vertices):
            raise scene.error(f"objects[{i}].stiffness_file",
                              f"has {len(vals)} values but the mesh has {len(mesh.vertices)} vertices")
        lo, hi = STIFFNESS_N_M
        if not np.all((vals >= lo) & (vals <= hi)):
            raise scene.error(f"objects[{i}].stiffness_file", f"stiffness values must be in [{lo:g}, {hi:g}] N/m "
                              "(finite)")
        return vals
    k0 = o["stiffness"]
    if k0 is None:
        return None
    if o["stiffness_edge"] is None:
        return k0
    mesh = mesh if mesh is not None else object_mesh(scene, i)
    rmax = float(np.hypot(mesh.vertices[:, 0], mesh.vertices[:, 1]).max()) or 1.0
    k1 = o["stiffness_edge"]
    return lambda pts: k0 + (k1 - k0) * np.clip(np.hypot(pts[:, 0], pts[:, 1]) / rmax, 0, 1) ** 2


def build_objects(scene) -> list[tuple[str, "object", np.ndarray]]:
    """``[(name, mesh, pose)]`` for every ``[[objects]]`` table, in order."""
    top = _skin_top(scene) if scene["objects"] else 0.0
    out = []
    for i, o in enumerate(scene["objects"]):
        mesh = object_mesh(scene, i)
        out.append((o["name"], mesh, object_pose(scene, i, mesh, top)))
    return out

