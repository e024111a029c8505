"""Triangle and frame geometry shared by every package (layout, contact, filters, augment).

One home for the small vectorised helpers that used to be written several times:
closest point on triangles, barycentric coordinates, tangent bases and frames,
and the 2-D cross product (``np.cross`` on 2-vectors is deprecated in numpy 2).
Everything is float64 numpy, no state, units are whatever the caller's are (metres
in vtcore). No vtcore imports, so every package may use it (tests/test_foundation_layering.py).
"""

from __future__ import annotations

import numpy as np

#: the helper axis a tangent basis starts from: world x, or world y when the normal is near x
_X, _Y = np.array([1.0, 0.0, 0.0]), np.array([0.0, 1.0, 0.0])


def cross2(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """z component of the cross product of 2-D vectors ``a``, ``b`` (..., 2) -> (...)."""
    a, b = np.asarray(a), np.asarray(b)
    return a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]


def tangent_basis(normal, direction=None) -> tuple[np.ndarray, np.ndarray]:
    """Unit tangents ``(t1, t2)`` (3,) each with ``t1, t2, n`` right-handed.

    normal : (3,), need not be unit. direction : (3,) or None: ``t1`` is ``direction``
    projected onto the tangent plane; by default world x (world y when the normal is
    within ~25 degrees of x). Raises ``ValueError`` when ``direction`` is parallel to
    the normal (callers turn it into an :class:`~vtcore.errors.InputError` naming their key).
    """
    n = np.asarray(normal, dtype=np.float64).reshape(3)
    n = n / np.linalg.norm(n)
    if direction is None:
        d = _X if abs(n[0]) < 0.9 else _Y
    else:
        d = np.asarray(direction, dtype=np.float64).reshape(3)
    t = d - n * (d @ n)
    if np.linalg.norm(t) < 1e-9 * max(np.linalg.norm(d), 1e-300):
        raise ValueError("direction is parallel to the normal")
    t1 = t / np.linalg.norm(t)
    return t1, np.cross(n, t1)


def tangent_frames(normals: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Vectorised :func:`tangent_basis` with the default helper: ``(t1, t2)`` (n, 3) each."""
    n = np.asarray(normals, dtype=np.float64).reshape(-1, 3)
    n = n / np.linalg.norm(n, axis=1, keepdims=True)
    helper = np.where(np.abs(n[:, [0]]) < 0.9, _X, _Y)
    t = helper - n * np.einsum("ij,ij->i", helper, n)[:, None]
    t1 = t / np.linalg.norm(t, axis=1, keepdims=True)
    return t1, np.cross(n, t1)


def barycentric(tri: np.ndarray, pts: np.ndarray) -> np.ndarray:
    """Barycentric coordinates (n, 3) of ``pts`` (n, d) in triangles ``tri`` (n, 3, d), d = 2 or 3.

    For d = 3 the point is first projected onto the triangle's plane (least squares).
    Degenerate triangles give finite (meaningless) numbers, never a division error.
    """
    tri = np.asarray(tri, dtype=np.float64)
    pts = np.asarray(pts, dtype=np.float64)
    a, b, c = tri[:, 0], tri[:, 1], tri[:, 2]
    v0, v1, v2 = b - a, c - a, pts - a
    d00 = np.einsum("ij,ij->i", v0, v0)
    d01 = np.einsum("ij,ij->i", v0, v1)
    d11 = np.einsum("ij,ij->i", v1, v1)
    d20 = np.einsum("ij,ij->i", v2, v0)
    d21 = np.einsum("ij,ij->i", v2, v1)
    den = d00 * d11 - d01 * d01
    den = np.where(np.abs(den) > 1e-300, den, 1e-300)
    v = (d11 * d20 - d01 * d21) / den
    w = (d00 * d21 - d01 * d20) / den
    return np.column_stack([1 - v - w, v, w])


def closest_point_on_triangles(tri: np.ndarray, p: np.ndarray) -> np.ndarray:
    """Closest point (n, 3) of triangles ``tri`` (n, 3, 3) to points ``p`` (n, 3), pairwise.

    Ericson's region test ("Real-Time Collision Detection", 5.1.5), vectorised. Written
    here because trimesh.triangles.closest_point misplaces points on needle-thin
    triangles (seen with 0.1 x 2.5 mm faces of a subdivided cylinder).
    """
    tri = np.asarray(tri, dtype=np.float64)
    p = np.asarray(p, dtype=np.float64)
    a, b, c = tri[:, 0], tri[:, 1], tri[:, 2]
    ab, ac, ap = b - a, c - a, p - a
    dot = lambda x, y: np.einsum("ij,ij->i", x, y)  # noqa: E731
    d1, d2 = dot(ab, ap), dot(ac, ap)
    bp = p - b
    d3, d4 = dot(ab, bp), dot(ac, bp)
    cp = p - c
    d5, d6 = dot(ab, cp), dot(ac, cp)
    va = d3 * d6 - d5 * d4
    vb = d5 * d2 - d1 * d6
    vc = d1 * d4 - d3 * d2
    out = np.empty_like(p)
    done = np.zeros(len(p), bool)

    def put(mask, value):
        m = mask & ~done
        out[m] = value[m] if np.ndim(value) == 2 else value
        done[m] = True

    with np.errstate(divide="ignore", invalid="ignore"):
        put((d1 <= 0) & (d2 <= 0), a)
        put((d3 >= 0) & (d4 <= d3), b)
        put((d6 >= 0) & (d5 <= d6), c)
        v = np.where(d1 - d3 != 0, d1 / (d1 - d3), 0.0)
        put((vc <= 0) & (d1 >= 0) & (d3 <= 0), a + v[:, None] * ab)
        w = np.where(d2 - d6 != 0, d2 / (d2 - d6), 0.0)
        put((vb <= 0) & (d2 >= 0) & (d6 <= 0), a + w[:, None] * ac)
        den = (d4 - d3) + (d5 - d6)
        w2 = np.where(den != 0, (d4 - d3) / den, 0.0)
        put((va <= 0) & ((d4 - d3) >= 0) & ((d5 - d6) >= 0), b + w2[:, None] * (c - b))
        s = va + vb + vc
        s = np.where(s != 0, s, 1.0)
        put(np.ones(len(p), bool), a + (vb / s)[:, None] * ab + (vc / s)[:, None] * ac)
    return out
