"""The tactile-image baseline (flatten, 1 mm grid, Canny, back-projection) and sub-taxel subdivision."""

from __future__ import annotations

import numpy as np
import pytest

from vtcore.errors import InputError
from vtcore.filters import (ImageEdgeDetector, MeshEdgeDetector, SubtaxelEdgeDetector, TactileImage,
                            canny_edges, flatten, loop_subdivision)
from vtcore.layout import mesh_from_triangles, wrap_on_sphere


def lattice(radius=np.inf, rings=4, pitch=7.5e-3):
    """Full hexagonal lattice of ``rings`` rings (centre last), wrapped on a sphere of ``radius``."""
    from scipy.spatial import Delaunay

    i, j = np.meshgrid(np.arange(-rings, rings + 1), np.arange(-rings, rings + 1), indexing="ij")
    i, j = i.ravel(), j.ravel()
    keep = (np.maximum(np.maximum(np.abs(i), np.abs(j)), np.abs(i + j)) <= rings) & ~((i == 0) & (j == 0))
    flat = pitch * np.column_stack([i[keep] + 0.5 * j[keep], np.sqrt(3) / 2 * j[keep]])
    flat = np.vstack([flat, [[0.0, 0.0]]])
    pos, nrm = wrap_on_sphere(flat, radius)
    return flat, mesh_from_triangles(pos, nrm, Delaunay(flat).simplices)


def band(pos, offset, angle, width=2e-3):
    n = np.array([-np.sin(angle), np.cos(angle)])
    return 1e4 * np.exp(-0.5 * ((pos[:, :2] @ n - offset) / width) ** 2)


def test_image_reproduces_linear_fields_and_back_projects_onto_the_mesh():
    flat, mesh = lattice(radius=0.06)
    ti = TactileImage(mesh.positions, mesh.triangles, flat, resolution=1e-3)
    f = 3.0 + 200.0 * flat[:, 0] - 50.0 * flat[:, 1]
    img = ti.image(f)
    h, w = ti.shape
    xs = ti.origin[0] + 1e-3 * np.arange(w)
    ys = ti.origin[1] + 1e-3 * np.arange(h)
    gx, gy = np.meshgrid(xs, ys)
    want = 3.0 + 200.0 * gx - 50.0 * gy
    np.testing.assert_allclose(img[ti.inside], want[ti.inside], atol=1e-9)
    assert np.all(img[~ti.inside] == 0.0)
    # back-projected pixel centres lie on the sphere-wrapped mesh (inside its chord tolerance)
    pts = ti.back_project(ti.inside)
    r = np.linalg.norm(pts - np.array([0, 0, -0.06]), axis=1)
    assert np.all(r <= 0.06 + 1e-9) and np.all(r > 0.06 - 1.5e-3)
    # batches
    assert ti.image(np.vstack([f, f])).shape == (2, h, w)


def test_flatten_without_layout_coordinates_keeps_distances():
    flat, mesh = lattice(radius=0.08)
    f2 = flatten(mesh.positions, mesh.triangles, None)
    assert f2.shape == flat.shape and np.all(np.isfinite(f2))
    i, j = mesh.edges.T
    d_flat = np.linalg.norm(f2[i] - f2[j], axis=1)
    d_true = np.linalg.norm(flat[i] - flat[j], axis=1)
    assert np.median(np.abs(d_flat - d_true) / d_true) < 0.05


def test_canny_finds_a_step_and_nothing_on_flat_images():
    inside = np.ones((40, 40), bool)
    img = np.zeros((40, 40))
    img[:, 20:] = 1.0
    e = canny_edges(img, inside, sigma=1.0)
    cols = np.flatnonzero(e.any(axis=0))
    assert e.any() and cols.min() >= 17 and cols.max() <= 22
    assert not canny_edges(np.full((40, 40), 7.0), inside).any()
    assert not canny_edges(np.zeros((40, 40)), inside).any()


def test_image_detector_hard_cases():
    flat, mesh = lattice()
    det = ImageEdgeDetector(mesh.positions, mesh.triangles, flat)
    for p in (np.zeros(len(flat)), np.full(len(flat), 65535.0)):
        f = det.detect(p)
        assert not f.found and np.all(np.isfinite(f.centroid))
    one = np.zeros(len(flat))
    one[-1] = 1.0  # the centre taxel alone
    f = det.detect(one)
    assert f.found and np.linalg.norm(f.centroid) < 2e-3
    with pytest.raises(InputError):
        TactileImage(mesh.positions, np.zeros((0, 3), int), flat)


def test_loop_operator_shapes_and_partition_of_unity():
    flat, mesh = lattice(rings=2)
    n = len(flat)
    for levels in (0, 1, 2):
        s, tri = loop_subdivision(n, mesh.triangles, levels)
        assert len(tri) == len(mesh.triangles) * 4**levels
        np.testing.assert_allclose(np.asarray(s.sum(axis=1)).ravel(), 1.0, atol=1e-12)
        assert tri.max() < s.shape[0]
    # an isolated taxel (no triangle) is carried over unchanged
    s, _ = loop_subdivision(n + 1, mesh.triangles, 1)
    assert s[n, n] == 1.0 and s[n].nnz == 1


@pytest.mark.parametrize("interpolate", ["log", "linear"])
def test_subtaxel_hard_cases(interpolate):
    flat, mesh = lattice(rings=3)
    det = SubtaxelEdgeDetector(mesh, levels=1, interpolate=interpolate)
    for p in (np.zeros(len(flat)), np.full(len(flat), 5.0)):
        f = det.detect(p)
        assert not f.found and np.all(np.isfinite(f.centroid))
    one = np.zeros(len(flat))
    one[-1] = 1.0
    f = det.detect(one)
    assert f.found and np.linalg.norm(f.centroid) < 1.5e-3
    with pytest.raises(InputError):
        SubtaxelEdgeDetector(mesh, interpolate="cubic")


def test_subtaxel_places_a_line_between_taxel_rows_better_than_the_mesh_filter():
    """A 2 mm wide line at offsets between taxel rows: the log-interpolated sub-taxel estimate
    follows the offset; the mesh filter's centroid snaps towards taxel rows."""
    flat, mesh = lattice()
    pos = mesh.positions
    rng = np.random.default_rng(5)
    mesh_det = MeshEdgeDetector(mesh)
    sub = SubtaxelEdgeDetector(mesh, levels=2)
    err_mesh, err_sub = [], []
    for _ in range(25):
        off, ang = rng.uniform(-3e-3, 3e-3), rng.uniform(-0.3, 0.3)
        n = np.array([-np.sin(ang), np.cos(ang)])
        p = band(pos, off, ang)
        for det, err in ((mesh_det, err_mesh), (sub, err_sub)):
            f = det.detect(p)
            assert f.found
            err.append(abs(f.centroid @ n - off))
    assert np.mean(err_sub) < np.mean(err_mesh)
    assert np.mean(err_sub) < 0.6e-3


def test_curve_fit_finds_an_arc_where_it_crosses_x_ref():
    """A 3 mm rim of radius 39 mm whose centreline passes 1 mm beside the origin: the centroid
    of its edges lies inside the arc by the sagitta; the local quadratic fit does not."""
    flat, mesh = lattice(rings=4)
    pos = mesh.positions
    centre = np.array([0.0, 0.040])  # the rim's centre: the rim crosses x = 0 at y = +1 mm
    d = np.abs(np.hypot(pos[:, 0] - centre[0], pos[:, 1] - centre[1]) - 0.039)
    p = 1e4 * np.exp(-0.5 * (np.maximum(d - 1.5e-3, 0) / 2e-3) ** 2)
    curve = SubtaxelEdgeDetector(mesh, levels=2, centroid="curve").detect(p)
    comps = SubtaxelEdgeDetector(mesh, levels=2, centroid="components").detect(p)
    assert curve.extra.get("located") == "curve" and curve.centroid[0] == 0.0
    assert abs(curve.centroid[1] - 1e-3) < 0.5e-3
    assert comps.centroid[1] - 1e-3 > 1e-3  # pulled towards the rim's centre (+y)
    assert abs(curve.theta) < np.radians(3)
