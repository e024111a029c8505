"""Meshes as designers have them, for tests and ``vtcore bench layout``.

- :func:`cad_link`: a robot link the way a CAD exporter tessellates it: a capped tube with a
  flange and a boss (a boolean union, by manifold3d through trimesh), long sliver triangles
  from cap to cap, fan caps, then the defects real exports carry: a few non-manifold edges
  (fins sharing an edge with two faces), duplicated faces; optionally in millimetres.
- :func:`convex_hull_link`: a coarse convex collision hull of about 200 triangles (the wrist
  link of a robot's collision model).
- :func:`full_cylinder`: a closed cylinder meshed at a given edge length (quads split in two).
- :func:`sphere`: an icosphere.
- :func:`island_selection`: a face selection as a designer's box or paint select gives it: one side
  of a part plus stray faces (15+ islands, slivers, islands far smaller than a module).

Every function is deterministic (seeded) and returns a ``trimesh.Trimesh`` in metres unless
``mm=True``.
"""

from __future__ import annotations

import numpy as np


def _cylinder(radius, height, sections, z0=0.0, axis="z"):
    import trimesh

    m = trimesh.creation.cylinder(radius=radius, height=height, sections=sections)
    m.apply_translation([0, 0, z0])
    if axis == "x":
        m.apply_transform(trimesh.transformations.rotation_matrix(np.pi / 2, [0, 1, 0]))
    return m


def cad_link(radius: float = 0.036, length: float = 0.2, *, sections: int = 48, mm: bool = False,
             nonmanifold: int = 3, duplicates: int = 4, seed: int = 0):
    """A CAD-style link: tube (radius, length, axis z, centred), a flange at z = -length/2 and a
    boss on the side at z = +length/4 (axis x); ``sections`` facets round (CAD chord tolerance),
    so the sides are needles from cap to cap. ``nonmanifold`` fins are glued on edges of the tube,
    ``duplicates`` faces are repeated. Metres, or millimetres with ``mm=True``."""
    import trimesh

    tube = _cylinder(radius, length, sections)
    flange = _cylinder(1.5 * radius, 0.1 * length, sections, z0=-length / 2 + 0.05 * length)
    boss = _cylinder(0.35 * radius, 2.6 * radius, max(sections // 3, 8), axis="x")
    boss.apply_translation([0, 0, length / 4])
    m = trimesh.boolean.union([tube, flange, boss], engine="manifold")
    v, f = np.asarray(m.vertices, float), np.asarray(m.faces, np.int64)
    rng = np.random.default_rng(seed)
    extra_v, extra_f = [], []
    # fins: a triangle hanging off an existing edge makes that edge shared by three faces
    side = np.flatnonzero(np.abs(m.face_normals[:, 2]) < 0.1)
    for k in rng.choice(side, size=min(nonmanifold, len(side)), replace=False):
        a, b = f[k, 0], f[k, 1]
        out = m.face_normals[k]
        extra_v.append((v[a] + v[b]) / 2 + 0.2 * radius * out)
        extra_f.append([a, b, len(v) + len(extra_v) - 1])
    if extra_v:
        v = np.vstack([v, extra_v])
        f = np.vstack([f, extra_f])
    if duplicates:
        f = np.vstack([f, f[rng.choice(len(m.faces), size=duplicates, replace=False)]])
    if mm:
        v = v * 1000.0
    return trimesh.Trimesh(v, f, process=False, validate=False)


def convex_hull_link(n_faces: int = 200, size=(0.125, 0.125, 0.055), seed: int = 0):
    """A convex collision hull of about ``n_faces`` triangles round a rounded box of ``size``
    metres (a wrist link): the hull of points on a superellipsoid."""
    import trimesh

    rng = np.random.default_rng(seed)
    n_pts = max(n_faces // 2 + 2, 8)
    d = rng.normal(size=(n_pts, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    p = np.sign(d) * np.abs(d) ** 0.5  # superellipsoid: flatter sides, rounder edges than a box
    p *= np.asarray(size) / 2
    return trimesh.convex.convex_hull(p)


def full_cylinder(radius: float = 0.02, length: float = 0.1, edge: float = 0.003, caps: bool = True):
    """A cylinder (axis z, centred) meshed with edges of about ``edge`` metres; closed with fan
    caps when ``caps``."""
    import trimesh

    n = max(int(np.ceil(2 * np.pi * radius / edge)), 8)
    rows = max(int(np.ceil(length / edge)), 1)
    th = np.linspace(0, 2 * np.pi, n, endpoint=False)
    z = np.linspace(-length / 2, length / 2, rows + 1)
    T, Z = np.meshgrid(th, z)
    v = np.column_stack([radius * np.cos(T).ravel(), radius * np.sin(T).ravel(), Z.ravel()])
    i, j = np.meshgrid(np.arange(n), np.arange(rows))
    a = (j * n + i).ravel()
    b = (j * n + (i + 1) % n).ravel()
    f = [np.column_stack([a, b, b + n]), np.column_stack([a, b + n, a + n])]
    if caps:
        c0, c1 = len(v), len(v) + 1
        v = np.vstack([v, [[0, 0, -length / 2], [0, 0, length / 2]]])
        k = np.arange(n)
        f += [np.column_stack([np.full(n, c0), (k + 1) % n, k]),
              np.column_stack([np.full(n, c1), rows * n + k, rows * n + (k + 1) % n])]
    return trimesh.Trimesh(v, np.vstack(f), process=False)


def sphere(radius: float = 0.04, subdivisions: int = 4):
    import trimesh

    return trimesh.creation.icosphere(subdivisions, radius=radius)


def island_selection(mesh, direction=(1.0, 0.0, 0.0), within_deg: float = 50.0, strays: int = 40, seed: int = 1):
    """``(side, region)`` (F,) bool each: the faces facing ``direction`` within ``within_deg``
    degrees (on :func:`cad_link`: the band of needle faces from cap to cap, the flange's rim, the
    boss), and that side plus ``strays`` faces facing away picked at random (seeded): single
    slivers and cap fan triangles, islands far smaller than a module."""
    n = np.asarray(mesh.face_normals)
    d = np.asarray(direction, float) / np.linalg.norm(direction)
    side = n @ d > np.cos(np.radians(within_deg))
    away = np.flatnonzero(n @ d < 0)
    region = side.copy()
    region[np.random.default_rng(seed).choice(away, min(strays, len(away)), replace=False)] = True
    return side, region
