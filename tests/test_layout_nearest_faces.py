"""Closest points on a mesh without open3d (inside Blender), against every face tested in float64:
vtcore.layout.surface.nearest_faces must answer the nearest face exactly, on the meshes designers
bring (a CAD link with needle faces from cap to cap and fins, a fine cylinder), for points on,
inside, just off and far from the surface, also when its candidate pairs come in small batches."""

import sys

import numpy as np
import pytest

from vtcore.geometry import closest_point_on_triangles
from vtcore.layout import cadmeshes, surface


def brute_force(mesh, points):
    """(n,) distance to the nearest face: every (point, face) pair, one point at a time."""
    T = np.asarray(mesh.triangles)
    return np.array([np.linalg.norm(closest_point_on_triangles(T, np.broadcast_to(p, (len(T), 3)).copy()) - p,
                                    axis=1).min() for p in points])


def probe_points(mesh, n, seed):
    """Surface points moved along the normal by -0.2 .. 0.2 mm, and a few far from the mesh."""
    rng = np.random.default_rng(seed)
    on, face = mesh.sample(n, return_index=True, seed=seed)
    p = on + mesh.face_normals[face] * rng.uniform(-2e-4, 2e-4, (n, 1))
    far = mesh.bounds.mean(axis=0) + rng.normal(size=(4, 3)) * np.ptp(mesh.bounds, axis=0)
    return np.vstack([p, far, mesh.bounds.mean(axis=0)[None]])


@pytest.mark.parametrize("name", ["cad_link", "cylinder"])
@pytest.mark.parametrize("max_pairs", [2_000_000, 500])
def test_nearest_faces_exact(name, max_pairs):
    mesh = cadmeshes.cad_link() if name == "cad_link" else cadmeshes.full_cylinder(0.02, 0.08, 0.001)
    points = probe_points(mesh, 300, seed=1)
    face = surface.nearest_faces(mesh, points, max_pairs=max_pairs)
    got = np.linalg.norm(surface.closest_on_faces(mesh, points, face) - points, axis=1)
    np.testing.assert_allclose(got, brute_force(mesh, points), rtol=0, atol=1e-12)


def test_closest_points_without_open3d_match_open3d(monkeypatch):
    """The two back-ends of closest_points agree (trimesh's closest_point, the old fallback,
    answered faces 0.1 mm farther on this cylinder)."""
    mesh = cadmeshes.full_cylinder(0.02, 0.08, 0.001)
    points = probe_points(mesh, 2000, seed=2)
    with_o3d, f1, d1 = surface.closest_points(mesh, points)
    monkeypatch.setitem(sys.modules, "open3d", None)
    without, f2, d2 = surface.closest_points(mesh, points)
    assert np.abs(d1 - d2).max() < 1e-9
    # open3d picks the face in float32: beside an edge it may take the neighbour, whose nearest
    # point is then as near to 1e-9 m but up to ~1e-7 m along the edge. The last point is the
    # cylinder's centre, equally near its whole side: either answer is right.
    assert np.abs(with_o3d - without)[:-1].max() < 1e-7
