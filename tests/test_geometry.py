"""vtcore.geometry: the shared triangle and frame helpers, against brute force and the old copies."""

import numpy as np
import pytest

from vtcore.geometry import barycentric, closest_point_on_triangles, cross2, tangent_basis, tangent_frames


def test_closest_point_matches_dense_sampling():
    rng = np.random.default_rng(0)
    tri = rng.normal(size=(200, 3, 3))
    tri[:10, 2] = tri[:10, 0] + 0.5 * (tri[:10, 1] - tri[:10, 0]) + 1e-3 * tri[:10, 2]  # needle triangles
    p = rng.normal(size=(200, 3)) * 2
    cp = closest_point_on_triangles(tri, p)
    # dense barycentric samples of each triangle: none nearer than the answer
    s = np.linspace(0, 1, 41)
    u, v = np.meshgrid(s, s)
    keep = u + v <= 1
    u, v = u[keep], v[keep]
    samples = tri[:, None, 0] + u[None, :, None] * (tri[:, None, 1] - tri[:, None, 0]) + \
        v[None, :, None] * (tri[:, None, 2] - tri[:, None, 0])
    dmin = np.linalg.norm(samples - p[:, None], axis=2).min(axis=1)
    d = np.linalg.norm(cp - p, axis=1)
    assert np.all(d <= dmin + 1e-12)
    b = barycentric(tri, cp)
    assert b.min() > -1e-6 and np.allclose(b.sum(axis=1), 1)


def test_bases_are_right_handed_and_follow_the_direction():
    rng = np.random.default_rng(1)
    normals = rng.normal(size=(50, 3))
    normals[0] = [1, 0, 0]
    t1, t2 = tangent_frames(normals)
    n = normals / np.linalg.norm(normals, axis=1, keepdims=True)
    np.testing.assert_allclose(np.einsum("ij,ij->i", np.cross(t1, t2), n), 1.0)
    for k in range(5):
        a, b = tangent_basis(normals[k])
        np.testing.assert_allclose(a, t1[k]) and np.testing.assert_allclose(b, t2[k])
    a, _ = tangent_basis([0, 0, 2.0], direction=[1, 0, 1])
    np.testing.assert_allclose(a, [1, 0, 0])
    with pytest.raises(ValueError):
        tangent_basis([0, 0, 1.0], direction=[0, 0, 3.0])


def test_cross2_is_the_signed_area_and_needs_no_numpy_2d_cross():
    a = np.array([[1.0, 0.0], [0.0, 1.0]])
    b = np.array([[0.0, 1.0], [1.0, 0.0]])
    np.testing.assert_array_equal(cross2(a, b), [1.0, -1.0])
