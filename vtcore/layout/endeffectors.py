"""Reusable end-effectors of the seed papers, each a closed mesh with its skin layout.

All in metres, in the end-effector frame: the sensorized surface faces +z at
the origin (the flat ones lie in the plane z = 0), so a press along -z is a
press onto the skin.

- :func:`seed001_disc`: the 3-D-printed flat end-effector of seed 001, a disc of
  80 mm diameter with the hexagonal CySkin patch (6 modules x 10 taxels, the
  centre taxel excluded: 60 taxels).
- :func:`seed002_planar`: the small flat end-effector of seed 002 (Fig. 6a), 20
  taxels: two CySkin modules side by side (a "strip:2").
- :func:`seed002_curved`: the large non-planar end-effector of seed 002 (Fig. 6b,
  "211 taxels"). The paper gives no drawing with dimensions; we model it from
  what it does give: its flattened skin resampled at 1 mm is a 74 x 132 pixel
  tactile image, so the skin unrolls to about 74 mm x 132 mm, and the reference
  point lies on a taxel "lying on the curvature". Our model: a block whose top
  is flat for 66 mm and then bends down over a quarter cylinder of radius 45 mm
  (71 mm of arc), 80 mm wide, the skin the best whole-module tiling of CySkin
  modules whose taxel centres lie in a 74 x 136 mm unrolled rectangle. Three
  rows of seven modules need 135 mm of length, 3 mm more than the paper's
  132 px image; we took 136 mm so that the count (210 taxels, 21 modules)
  comes near the paper's 211 (its text also says 221). Because the surface is
  developable, unrolling is exact (no strain).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from ..tolerances import LENGTH_TOL
from .model import Layout
from .patches import fill_patch, make_patch
from .modules import get_module

if TYPE_CHECKING:  # for annotations only: trimesh is imported where a mesh is built
    import trimesh


def _closed_extrusion(top: np.ndarray, bottom: np.ndarray, width: float):
    """A closed mesh swept along y from a profile in the x-z plane.

    top, bottom : (n, 2) float, metres, ``(x, z)`` of the upper (skin) and lower
    outline, same n, ordered the same way. The solid spans ``y in [-width/2, width/2]``.
    """
    import trimesh

    n = len(top)
    ring = np.vstack([top, bottom[::-1]])  # closed outline, (2n, 2)
    m = len(ring)
    ys = (-width / 2, width / 2)
    verts = np.vstack([np.column_stack([ring[:, 0], np.full(m, y), ring[:, 1]]) for y in ys])
    i = np.arange(m)
    j = (i + 1) % m
    # side walls between the two copies of the outline
    faces = [np.column_stack([i, j, m + j]), np.column_stack([i, m + j, m + i])]
    # the two caps: quads between top[k], top[k+1], bottom[k+1], bottom[k]
    k = np.arange(n - 1)
    tk, tk1 = k, k + 1
    bk, bk1 = 2 * n - 1 - k, 2 * n - 2 - k
    for off in (0, m):
        faces.append(np.column_stack([tk + off, bk + off, tk1 + off]))
        faces.append(np.column_stack([tk1 + off, bk + off, bk1 + off]))
    mesh = trimesh.Trimesh(verts, np.vstack(faces), process=True)
    mesh.fix_normals()
    return mesh


def seed001_disc(diameter: float = 0.080, thickness: float = 0.010) -> tuple["trimesh.Trimesh", Layout]:
    """The flat 80 mm disc of seed 001 with its hexagonal CySkin patch (60 taxels).

    Returns ``(mesh, layout)``: a closed cylinder whose top face is the plane z = 0,
    and the 60 taxels on it (normals +z, flat coordinates = x, y).
    """
    import trimesh

    mesh = trimesh.creation.cylinder(radius=diameter / 2, height=thickness, sections=96)
    mesh.apply_translation([0.0, 0.0, -thickness / 2])
    layout = make_patch("hexagon", "cyskin10").flat_layout()
    layout.meta.update({"end_effector": "seed001_disc", "diameter_m": diameter,
                        "source": "seed 001: 80 mm flat disc, 6 modules x 10 taxels, centre excluded"})
    return mesh, layout


def seed002_planar(margin: float = 0.005, thickness: float = 0.008) -> tuple["trimesh.Trimesh", Layout]:
    """The small planar end-effector of seed 002: 20 taxels (two CySkin modules).

    Returns ``(mesh, layout)``: a box whose top face is the plane z = 0 covering
    the patch plus ``margin`` on each side; the layout is centred on the origin
    (the reference point x_R of seed 002 is the centre of the flat end-effector).
    """
    import trimesh

    patch = make_patch("strip:2", "cyskin10")
    layout = patch.flat_layout()
    lo, hi = patch.flat.min(axis=0) - margin, patch.flat.max(axis=0) + margin
    ext = np.array([hi[0] - lo[0], hi[1] - lo[1], thickness])
    mesh = trimesh.creation.box(extents=ext)
    mesh.apply_translation([(hi[0] + lo[0]) / 2, (hi[1] + lo[1]) / 2, -thickness / 2])
    layout.meta.update({"end_effector": "seed002_planar", "reference_point": [0.0, 0.0, 0.0],
                        "source": "seed 002 Fig. 6a: planar tactile patch, 20 taxels"})
    return mesh, layout


def seed002_curved(flat_length: float = 0.066, radius: float = 0.045, arc_angle: float = np.pi / 2,
                   width: float = 0.080, skin_size=(0.136, 0.074), thickness: float = 0.012,
                   module: str = "cyskin10") -> tuple["trimesh.Trimesh", Layout]:
    """The large non-planar end-effector of seed 002 (modelled, see the module docstring).

    The skin surface runs along x: flat (z = 0) for ``x in [-flat_length, 0]``,
    then bends down over a cylinder of ``radius`` about the axis
    ``(0, y, -radius)`` for ``arc_angle``. Returns ``(mesh, layout)``; the layout's
    flat coordinates are the exact unrolling (u along the profile from x = 0,
    v = y), ``meta["reference_taxel"]`` is the taxel on the curvature used as x_R.
    """
    mod = get_module(module)
    arc = radius * arc_angle
    # the skin's unrolled rectangle, centred across the width, starting at the flat's far end
    L, W = skin_size
    u0 = -flat_length + max(0.0, (flat_length + arc - L) / 2)
    lo, hi = np.array([u0, -W / 2]), np.array([u0 + L, W / 2])
    # the taxel centres fill the unrolled rectangle (the 1 mm tactile image spans them)
    patch = fill_patch(mod, lambda f: np.all((f >= lo - LENGTH_TOL) & (f <= hi + LENGTH_TOL), axis=1), lo, hi,
                       angles=(0.0,), offsets=10)
    u, v = patch.flat[:, 0], patch.flat[:, 1]
    pos, nrm = _profile_point(u, flat_length, radius)
    positions = np.column_stack([pos[:, 0], v, pos[:, 1]])
    normals = np.column_stack([nrm[:, 0], np.zeros_like(v), nrm[:, 1]])
    layout = patch.to_layout(positions, normals)
    # x_R: the taxel on the curved part closest to the middle of the arc, on the centre line
    on_arc = u > 0
    target = np.array([arc / 2, 0.0])
    d = np.where(on_arc, np.hypot(u - target[0], v - target[1]), np.inf)
    ref = int(np.argmin(d))
    # the solid: top profile sampled finely, bottom offset inwards by ``thickness``
    us = np.concatenate([np.linspace(-flat_length, 0.0, 24, endpoint=False), np.linspace(0.0, arc, 48)])
    top, tn = _profile_point(us, flat_length, radius)
    bottom = top - thickness * tn
    mesh = _closed_extrusion(top, bottom, width)
    layout.meta.update({
        "end_effector": "seed002_curved", "reference_taxel": ref,
        "reference_point": positions[ref].tolist(), "flat_length_m": flat_length, "radius_m": radius,
        "arc_angle_rad": float(arc_angle), "skin_size_m": [float(L), float(W)],
        "source": "seed 002 Fig. 6b (non-planar patch, 211 taxels; 74 x 132 px tactile image at 1 mm), "
                  "geometry modelled"})
    return mesh, layout


def _profile_point(u: np.ndarray, flat_length: float, radius: float):
    """``(x, z)`` (n, 2) and outward normals (n, 2) of the profile at arc length ``u`` from x = 0."""
    u = np.asarray(u, dtype=np.float64)
    a = np.clip(u, 0.0, None) / radius
    x = np.where(u <= 0, u, radius * np.sin(a))
    z = np.where(u <= 0, 0.0, -radius * (1 - np.cos(a)))
    nx = np.where(u <= 0, 0.0, np.sin(a))
    nz = np.where(u <= 0, 1.0, np.cos(a))
    return np.column_stack([x, z]), np.column_stack([nx, nz])
