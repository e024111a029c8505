"""Minimal patch geometry (foundation placeholder for the layout issue).

The hexagonal CySkin patch of seed 001: a hexagonal lattice of radius 4 at
7.5 mm pitch (61 sites), split into 6 triangular modules of 10 taxels; the
centre site is not a taxel of any module (seed 001: 60 taxels used).
"""

from __future__ import annotations

import numpy as np

PITCH = 7.5e-3  # m, CySkin taxel pitch (seed 001, 002)


def hexagon_flat(pitch: float = PITCH, rings: int = 4) -> tuple[np.ndarray, np.ndarray]:
    """Flat hexagonal patch.

    Returns ``flat (N, 2)`` metres and ``module_ids (N,)``: the lattice sites of a
    hexagon of ``rings`` rings, without the centre, each assigned to the 60°
    sector (module) it lies in.
    """
    a = np.array([1.0, 0.0])
    b = np.array([0.5, np.sqrt(3) / 2])
    i, j = np.meshgrid(np.arange(-rings, rings + 1), np.arange(-rings, rings + 1), indexing="ij")
    i, j = i.ravel(), j.ravel()
    k = -i - j
    keep = (np.maximum(np.maximum(np.abs(i), np.abs(j)), np.abs(k)) <= rings) & ~((i == 0) & (j == 0))
    pts = (i[keep, None] * a + j[keep, None] * b) * pitch
    ang = np.mod(np.arctan2(pts[:, 1], pts[:, 0]) + 1e-9, 2 * np.pi)
    module = np.floor(ang / (np.pi / 3)).astype(np.int64)
    order = np.lexsort((ang, np.hypot(*pts.T).round(9), module))
    return pts[order], module[order]


def wrap_on_sphere(flat: np.ndarray, radius: float) -> tuple[np.ndarray, np.ndarray]:
    """Wrap flat patch coordinates onto a sphere cap without stretching radial lines.

    The azimuthal-equidistant map (the sphere's exponential map at its pole)
    keeps geodesic distance and direction from the patch centre. The sphere's
    pole sits at the origin with outward normal +z (centre at ``(0, 0, -radius)``).

    flat : (N, 2) metres. radius : metres (``inf`` gives a plane).
    Returns positions (N, 3) metres and unit normals (N, 3).
    """
    flat = np.asarray(flat, dtype=np.float64)
    if not np.isfinite(radius):
        pos = np.column_stack([flat, np.zeros(len(flat))])
        return pos, np.tile([0.0, 0.0, 1.0], (len(flat), 1))
    r = np.hypot(flat[:, 0], flat[:, 1])
    theta = r / radius
    phi = np.arctan2(flat[:, 1], flat[:, 0])
    normals = np.column_stack([np.sin(theta) * np.cos(phi), np.sin(theta) * np.sin(phi), np.cos(theta)])
    positions = radius * normals - np.array([0.0, 0.0, radius])
    return positions, normals
