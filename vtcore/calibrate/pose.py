"""Where a simulated press goes so that it matches a recorded one: the skin's local shape under a
recorded footprint (its surface point, normal and curvature along the footprint's long axis)."""

from __future__ import annotations

import numpy as np

from ..geometry import tangent_basis


def local_surface(positions, centre, normal, axis, radius: float = 0.02):
    """The taxel surface under ``centre``: ``(point (3,), normal (3,), curvature along axis 1/m)``.

    A quadric ``w = a u^2 + b u v + c v^2 + d u + e v + f`` is fitted by least squares to the taxel
    positions (N, 3) m within ``radius`` of ``centre``, in the frame (u along ``axis``, v across, w
    along ``normal``). The point is the quadric's at (0, 0) (a footprint's centroid lies inside a
    convex skin, below its surface), the normal the quadric's there (the file's taxel normals can
    be tilted by degrees; a press laid along a tilted normal rocks the pad along its length), and
    the curvature along u is ``-2a`` (> 0 convex). Fewer than 6 taxels: the inputs, curvature 0.
    """
    pos = np.asarray(positions, float)
    c = np.asarray(centre, float)
    n = np.asarray(normal, float) / np.linalg.norm(normal)
    u = np.asarray(axis, float) - (np.asarray(axis, float) @ n) * n
    if np.linalg.norm(u) < 1e-9:
        u = tangent_basis(n)[0]
    u /= np.linalg.norm(u)
    v = np.cross(n, u)
    rel = pos - c
    near = np.linalg.norm(rel, axis=1) <= radius
    if near.sum() < 6:
        return c, n, 0.0
    r = rel[near]
    uu, vv, ww = r @ u, r @ v, r @ n
    A = np.column_stack([uu * uu, uu * vv, vv * vv, uu, vv, np.ones_like(uu)])
    a, b, cc, d, e, f = np.linalg.lstsq(A, ww, rcond=None)[0]
    point = c + f * n
    nn = n - d * u - e * v
    nn /= np.linalg.norm(nn)
    # curvature of the graph along u at the origin: w_uu / (1 + w_u^2)^(3/2), convex positive
    kappa = -2.0 * a / (1.0 + d * d) ** 1.5
    return point, nn, float(kappa)


def curvature_along(positions, centre, normal, axis, radius: float = 0.02) -> float:
    """Normal curvature (1/m, > 0 convex) of the skin along ``axis`` at ``centre`` (:func:`local_surface`)."""
    return local_surface(positions, centre, normal, axis, radius)[2]
