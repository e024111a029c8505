"""Objects that touch the skin: closed triangle meshes of seed 001's shapes and a few more.

Every object is built **as it rests on a table**: its base at ``z = 0``, centred
on the z axis, long side along x, the face meant to be pressed pointing up
(+z). :func:`placement_pose` turns it upside down above a skin whose outward
normal is +z, which is how the end-effector meets it in seed 001 (the arm
descends onto the object).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from ..errors import InputError

if TYPE_CHECKING:  # for annotations only: trimesh is imported where a mesh is built
    import trimesh

#: kind -> default dimensions (metres). Seed 001 objects: cube 30 mm, cuboid 30 x 80 mm,
#: sphere r 30 mm, half-cylinder r 30 mm x 80 mm. Seed 002: a ruler and a mug rim.
DEFAULTS: dict[str, dict] = {
    "cube": {"side": 0.03},
    "cuboid": {"side": 0.03, "length": 0.08},
    "box": {"extents": (0.03, 0.03, 0.03)},
    "sphere": {"radius": 0.03, "subdivisions": 4},
    "halfcylinder": {"radius": 0.03, "length": 0.08, "sections": 96},
    "cylinder": {"radius": 0.02, "height": 0.05, "sections": 96},
    "ruler": {"length": 0.30, "width": 0.03, "thickness": 0.004},
    "mug": {"radius": 0.04, "wall": 0.004, "height": 0.10, "bottom": 0.006, "sections": 128},
    # a finger pad lying on the skin: a capsule 16 mm wide (an adult index fingertip is ~15-20 mm wide)
    # and 40 mm from tip to tip (the pad and part of the middle phalanx, as the footprints of real
    # one-finger presses on a CySkin patch show: ~4x longer than wide, shared/data/cyskin_gesture)
    # bend_radius: 0 = straight; > radius: the pad's axis bent on an arc of that radius, the pressed
    # face concave (a soft finger pad lying along a convex skin wraps around it)
    "fingerpad": {"radius": 0.008, "length": 0.04, "sections": 64, "bend_radius": 0.0},
}


#: Accepted object dimensions, metres (make_object raises outside).
SIZE_RANGE_M = (1e-6, 1e3)


def _positive(kind, dims):
    for k, v in dims.items():
        if k == "bend_radius":
            if not (np.isfinite(v) and (v == 0 or v > dims.get("radius", 0))):
                raise InputError(f"{kind}: bend_radius must be 0 (straight) or larger than the radius "
                                 f"({dims.get('radius')} m), got {v}", key=k)
            continue
        if k in ("subdivisions", "sections"):
            if int(v) != v or v < (0 if k == "subdivisions" else 8):
                raise InputError(f"{kind}: {k} must be an integer >= {0 if k == 'subdivisions' else 8}, got {v}",
                                 key=k)
            continue
        vals = np.atleast_1d(np.asarray(v, dtype=float))
        # a micrometre to a kilometre: below, the mesh's normals underflow to 0/0; above, areas overflow
        if not np.all(np.isfinite(vals)) or np.any(vals < SIZE_RANGE_M[0]) or np.any(vals > SIZE_RANGE_M[1]):
            raise InputError(f"{kind}: {k} must be in [{SIZE_RANGE_M[0]:g}, {SIZE_RANGE_M[1]:g}] m, got {v}", key=k)


def _halfcylinder(radius, length, sections):
    """Half-cylinder lying on its flat face (z = 0), axis along x, round side up."""
    import trimesh

    a = np.linspace(0.0, np.pi, int(sections) // 2 + 1)
    prof = np.column_stack([radius * np.cos(a), radius * np.sin(a)])  # (y, z), CCW seen from +x
    loop = np.vstack([[0.0, 0.0], prof])  # centre of the flat face, then the arc
    m = len(loop)
    x0, x1 = -length / 2, length / 2
    v = np.vstack([np.column_stack([np.full(m, x0), loop]), np.column_stack([np.full(m, x1), loop])])
    i = np.arange(1, m - 1)
    cap1 = np.column_stack([np.zeros_like(i), i, i + 1]) + m        # +x cap, normal +x
    cap0 = np.column_stack([np.zeros_like(i), i + 1, i])            # -x cap, normal -x
    a0 = np.arange(m)
    b0 = (a0 + 1) % m
    side = np.vstack([np.column_stack([a0, b0, b0 + m]), np.column_stack([a0, b0 + m, a0 + m])])
    return trimesh.Trimesh(v, np.vstack([cap0, cap1, side]), process=True)


def fingerpad(radius: float, length: float, sections: int = 64, bend_radius: float = 0.0):
    """A finger pad: a capsule of ``radius`` (m), ``length`` (m, tip to tip, >= 2 radius) lying along
    x on z = 0, centred on the z axis. ``sections`` points around its axis (and half as many
    latitude steps per cap): 64 keeps the facets' sag below 0.02 mm at r = 8 mm.

    bend_radius : m, 0 for a straight pad; else the axis follows an arc of that radius (> radius)
    whose centre lies above the pad (+z, the pressed side), so the pressed face is concave: a
    pad laid along a convex skin of radius R wraps it for ``bend_radius = R + radius`` (the
    layer's outer surface R, the pad's axis one radius further out).
    """
    import trimesh

    if length < 2 * radius:
        raise InputError(f"fingerpad: length ({length} m, tip to tip) must be at least twice the radius "
                         f"({2 * radius} m)", key="length")
    # a solid of revolution about z (then laid along x) with rings every ~0.5 mm along the straight
    # part too: trimesh's capsule has none there, and a bent pad needs vertices to bend
    half = length / 2 - radius
    n_cap = max(int(sections) // 4, 4)
    a = np.linspace(0.0, np.pi / 2, n_cap + 1)
    n_mid = max(int(np.ceil(2 * half / 5e-4)), 1) if half > 0 else 0
    top = np.column_stack([radius * np.sin(a), half + radius * np.cos(a)])[::-1]     # from the rim up to the tip
    mid = np.column_stack([np.full(max(n_mid - 1, 0), radius), np.linspace(half, -half, n_mid + 1)[1:-1]])
    bottom = np.column_stack([radius * np.cos(a), -half - radius * np.sin(a)])        # from the rim to the tip
    prof = np.vstack([top[::-1], mid, bottom]) if half > 0 else np.vstack([top[::-1], bottom[1:]])
    m = trimesh.creation.revolve(prof, sections=int(sections))
    if m.volume < 0:
        m.invert()
    # the solid runs along z, centred at the origin: lay it along x, resting on z = 0
    m.apply_transform(np.array([[0, 0, 1, 0], [0, 1, 0, 0], [-1, 0, 0, 0], [0, 0, 0, 1.0]]))
    m.apply_translation((0, 0, radius))
    if bend_radius:
        # bend: axial coordinate x -> angle x / R_b about a line parallel to y at z = radius + R_b;
        # a point z' = z - radius off the axis keeps its distance R_b - z' from that line
        v = np.asarray(m.vertices, float).copy()
        phi = v[:, 0] / bend_radius
        rho = bend_radius - (v[:, 2] - radius)
        v[:, 0] = rho * np.sin(phi)
        v[:, 2] = radius + bend_radius - rho * np.cos(phi)
        v[:, 2] -= v[:, 2].min()
        m = trimesh.Trimesh(v, m.faces, process=False)
    return m


def make_object(kind: str, **dims) -> "trimesh.Trimesh":
    """A closed, outward-oriented triangle mesh of an object, in metres.

    kind : "cube" (side), "cuboid" (side, length), "box" (extents (3,)),
        "sphere" (radius, subdivisions), "halfcylinder" (radius, length, sections),
        "cylinder" (radius, height, sections), "ruler" (length, width, thickness),
        "mug" (radius, wall, height, bottom, sections), "fingerpad" (radius, length from tip to
        tip >= 2 radius, sections: a capsule lying along x, the standard finger probe).
    dims : overrides of :data:`DEFAULTS` [kind].

    The object rests on z = 0 with the face to press pointing up (+z).
    """
    import trimesh

    if kind not in DEFAULTS:
        raise InputError(f"unknown object kind {kind!r}; known: {', '.join(DEFAULTS)}", key="kind")
    unknown = set(dims) - set(DEFAULTS[kind])
    if unknown:
        raise InputError(f"{kind}: unknown dimension(s) {sorted(unknown)}; valid: {sorted(DEFAULTS[kind])}",
                         key=sorted(unknown)[0])
    d = {**DEFAULTS[kind], **dims}
    _positive(kind, d)
    if kind == "cube":
        s = d["side"]
        mesh = trimesh.creation.box(extents=(s, s, s))
        mesh.apply_translation((0, 0, s / 2))
    elif kind == "cuboid":
        s, length = d["side"], d["length"]
        mesh = trimesh.creation.box(extents=(length, s, s))
        mesh.apply_translation((0, 0, s / 2))
    elif kind == "box":
        ext = np.asarray(d["extents"], float).reshape(3)
        mesh = trimesh.creation.box(extents=ext)
        mesh.apply_translation((0, 0, ext[2] / 2))
    elif kind == "sphere":
        mesh = trimesh.creation.icosphere(subdivisions=int(d["subdivisions"]), radius=d["radius"])
        mesh.apply_translation((0, 0, d["radius"]))
    elif kind == "halfcylinder":
        mesh = _halfcylinder(d["radius"], d["length"], d["sections"])
    elif kind == "cylinder":
        mesh = trimesh.creation.cylinder(radius=d["radius"], height=d["height"], sections=int(d["sections"]))
        mesh.apply_translation((0, 0, d["height"] / 2))
    elif kind == "ruler":
        mesh = trimesh.creation.box(extents=(d["length"], d["width"], d["thickness"]))
        mesh.apply_translation((0, 0, d["thickness"] / 2))
    elif kind == "fingerpad":
        mesh = fingerpad(d["radius"], d["length"], d["sections"], d["bend_radius"])
    elif kind == "mug":
        r, w = d["radius"], d["wall"]
        if w >= r:
            raise InputError(f"mug: wall ({w} m) must be thinner than the radius ({r} m)", key="wall")
        # one solid of revolution (outer wall, rim, inner wall, inner bottom): a tube plus a
        # separate bottom would share the inner wall and stop being a manifold once merged
        h, b = d["height"], d["bottom"]
        if b >= h:
            raise InputError(f"mug: bottom ({b} m) must be thinner than the height ({h} m)", key="bottom")
        prof = np.array([[0, 0], [r, 0], [r, h], [r - w, h], [r - w, b], [0, b]], float)
        mesh = trimesh.creation.revolve(prof, sections=int(d["sections"]))
    if mesh.volume < 0:
        mesh.invert()
    mesh.metadata["kind"] = kind
    mesh.metadata["dims"] = {k: (list(v) if isinstance(v, tuple) else v) for k, v in d.items()}
    return mesh


def placement_pose(mesh, *, xy=(0.0, 0.0), yaw: float = 0.0, top: float = 0.0, gap: float = 0.0,
                   flip: bool = True) -> np.ndarray:
    """4x4 pose that puts ``mesh`` upside down above a skin facing +z.

    xy : (2,) metres, where the object's z axis crosses the skin plane.
    yaw : radians about z. top : metres, height of the skin's outer surface
    (the layer's top) at the object's lowest point. gap : metres left between
    them (0: touching). flip : turn the object over (rotation by pi about x) so
    its upward (pressed) face points down at the skin.
    """
    c, s = np.cos(yaw), np.sin(yaw)
    rz = np.array([[c, -s, 0], [s, c, 0], [0, 0, 1.0]])
    rx = np.diag([1.0, -1.0, -1.0]) if flip else np.eye(3)
    r = rz @ rx
    v = np.asarray(mesh.vertices, float) @ r.T
    t = np.array([xy[0], xy[1], top + gap - v[:, 2].min()])
    pose = np.eye(4)
    pose[:3, :3], pose[:3, 3] = r, t
    return pose


def surface_pose(mesh, point, normal, axis=None, *, gap: float = 0.0, flip: bool = True) -> np.ndarray:
    """4x4 pose that lays ``mesh`` on a skin point: its pressed face towards the skin, its x axis
    (a finger pad's or cuboid's length) along ``axis``, lowest point ``gap`` m above ``point``.

    point : (3,) m, on the layer's outer surface. normal : (3,), the skin's outward normal there.
    axis : (3,) or None, direction for the object's x axis (projected on the tangent plane; None:
    any tangent). flip : as in :func:`placement_pose` (the object's +z face meets the skin).
    The object approaches along ``-normal`` (``press(..., direction=-normal)``).
    """
    from ..geometry import tangent_basis

    n = np.asarray(normal, float).reshape(3)
    if not np.all(np.isfinite(n)) or np.linalg.norm(n) < 1e-12:
        raise InputError(f"normal must be a non-zero 3-vector, got {normal}", key="normal")
    n = n / np.linalg.norm(n)
    t1 = None
    if axis is not None:
        a = np.asarray(axis, float).reshape(3)
        a = a - (a @ n) * n
        if np.linalg.norm(a) > 1e-9:
            t1 = a / np.linalg.norm(a)
    if t1 is None:
        t1 = tangent_basis(n)[0]
    down = -n if flip else n                   # where the object's +z points
    t2 = np.cross(down, t1)
    r = np.column_stack([t1, t2, down])        # object x -> t1, y -> t2, z -> down
    v = np.asarray(mesh.vertices, float) @ r.T
    pose = np.eye(4)
    pose[:3, :3] = r
    pose[:3, 3] = np.asarray(point, float).reshape(3) + (gap - (v @ n).min()) * n
    return pose
