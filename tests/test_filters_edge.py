"""Seed 002 Eqs. 4-8 on hand-built meshes: exact values and every hard case of issue 5."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp
from hypothesis import given, settings
from hypothesis import strategies as st

from vtcore.errors import InputError
from vtcore.filters import (EdgeFilter, MeshEdgeDetector, apply_local, component_orientation,
                            edge_filter, features, local_operator, mean_axis, mesh_components,
                            project_plane, relative_threshold, threshold)
from vtcore.layout import mesh_from_triangles


def grid_mesh(nx=4, ny=3, dx=0.5, dy=0.25, z=None):
    """Rectangular grid, each cell split by its diagonal; edge lengths 0.5, 0.25, sqrt(0.3125)."""
    x, y = np.meshgrid(np.arange(nx) * dx, np.arange(ny) * dy, indexing="ij")
    pos = np.column_stack([x.ravel(), y.ravel(), np.zeros(x.size) if z is None else z(x.ravel(), y.ravel())])
    idx = np.arange(nx * ny).reshape(nx, ny)
    a, b, c, d = idx[:-1, :-1].ravel(), idx[1:, :-1].ravel(), idx[1:, 1:].ravel(), idx[:-1, 1:].ravel()
    tri = np.concatenate([np.column_stack([a, b, c]), np.column_stack([a, c, d])])
    return mesh_from_triangles(pos, np.tile([0.0, 0.0, 1.0], (len(pos), 1)), tri)


def hand_eq6(mesh, p):
    """Eq. 6 written out: p_hat_i = sum_{j in adj(i)} p_j (p(t_i + D_ij k_ij) - p_i) / D_ij."""
    adj = mesh.adjacency.tocsr()
    out = np.zeros(len(p))
    for i in range(len(p)):
        for j in sorted(adj.indices[adj.indptr[i]:adj.indptr[i + 1]]):
            if j == i:
                continue
            dij = np.linalg.norm(mesh.positions[j] - mesh.positions[i])          # Eq. 2
            kij = (mesh.positions[j] - mesh.positions[i]) / dij                  # unit direction
            tj = mesh.positions[i] + dij * kij                                   # = t_j
            jj = int(np.argmin(np.linalg.norm(mesh.positions - tj, axis=1)))     # p(t_i + D k)
            w = (p[jj] - p[i]) / dij                                             # Eq. 5
            out[i] += p[j] * w                                                   # Eq. 4
    return out


def test_step_pressure_equals_hand_computation_exactly():
    mesh = grid_mesh()
    x = mesh.positions[:, 0]
    p = np.where(x > 0.6, 2.0, 0.0)  # a step between the 2nd and 3rd grid columns
    got = edge_filter(mesh, p)
    want = hand_eq6(mesh, p)
    np.testing.assert_array_equal(got, want)
    # and the values themselves: only the low side of the step responds, with sum_j 4 / D_ij
    low = (x > 0.4) & (x < 0.6)
    assert np.all(got[~low] == 0.0)
    assert np.all(got[low] > 0)
    # the middle taxel of the low column has neighbours (1, 0) and (1, -1)... at 0.5 and sqrt(0.3125)
    assert got[low].max() == pytest.approx(4.0 / 0.5 + 4.0 / np.sqrt(0.5**2 + 0.25**2), rel=1e-15)


def test_random_pressure_matches_hand_and_batch_forms():
    rng = np.random.default_rng(3)
    mesh = grid_mesh(6, 5, z=lambda x, y: 0.1 * x**2)  # non-planar
    p = rng.random((3, len(mesh.positions)))
    ef = EdgeFilter(mesh)
    for t in range(3):
        np.testing.assert_allclose(ef(p[t]), hand_eq6(mesh, p[t]), rtol=1e-13, atol=1e-13)
    np.testing.assert_allclose(ef(p), np.array([hand_eq6(mesh, q) for q in p]), rtol=1e-13, atol=1e-13)
    # the two-product sparse form used for big batches agrees to rounding
    np.testing.assert_allclose(ef._sparse(p), ef._gather(p), rtol=1e-12, atol=1e-12)
    # float32 batched form
    e32 = EdgeFilter(mesh, dtype=np.float32)
    assert e32._sparse(p).dtype == np.float32
    np.testing.assert_allclose(e32._sparse(p), ef(p), rtol=1e-4, atol=1e-4)


def test_uniform_and_saturated_frames_have_no_edges_and_no_nan():
    mesh = grid_mesh(5, 5)
    ef = EdgeFilter(mesh)
    for value in (0.0, 1.0, 65535.0):
        p = np.full(len(mesh.positions), value)
        r = ef(p)
        assert np.all(np.isfinite(r)) and np.all(r == 0.0)
        assert not threshold(r, 0.0).any()
        det = MeshEdgeDetector(mesh)
        f = det.detect(p)
        assert not f.found and np.all(np.isfinite(f.centroid)) and f.theta == 0.0
    big = np.full((2000, len(mesh.positions)), 65535.0)  # batched sparse path: rounding only
    r = ef(big)
    assert np.all(np.isfinite(r)) and np.abs(r).max() < 1e-6 * 65535.0**2


def test_one_pressed_taxel_lights_its_ring():
    mesh = grid_mesh(5, 5)
    p = np.zeros(len(mesh.positions))
    centre = 12
    p[centre] = 1.0
    r = edge_filter(mesh, p)
    ring = mesh.adjacency[centre].indices
    assert r[centre] == 0.0
    assert np.all(r[ring] > 0)
    others = np.setdiff1d(np.arange(len(p)), np.r_[ring, centre])
    assert np.all(r[others] == 0.0)
    f = MeshEdgeDetector(mesh, fraction=0.0, epsilon=0.0).detect(p)
    assert f.found and f.n_components == 1


def test_taxel_without_neighbours_and_duplicate_taxels():
    mesh = grid_mesh(3, 3)
    pos = np.vstack([mesh.positions, [[5.0, 5.0, 0.0]], mesh.positions[[4]]])  # isolated + duplicate of 4
    tri = np.vstack([mesh.triangles, [[4, 10, 5]]])
    m2 = mesh_from_triangles(pos, np.tile([0, 0, 1.0], (len(pos), 1)), tri)
    p = np.arange(len(pos), dtype=float)
    r = edge_filter(m2, p)
    assert r.shape == p.shape and np.all(np.isfinite(r))
    assert r[9] == 0.0  # isolated taxel: no neighbours, no response
    assert np.all(np.isfinite(EdgeFilter(m2)(np.tile(p, (5, 1)))))


def test_threshold_above_every_response():
    mesh = grid_mesh()
    p = np.where(mesh.positions[:, 0] > 0.6, 1.0, 0.0)
    r = edge_filter(mesh, p)
    assert not threshold(r, r.max()).any()
    f = MeshEdgeDetector(mesh, epsilon=float(r.max()) * 2).detect(p)
    assert not f.found and f.centroid.tolist() == [0.0, 0.0]
    eps = relative_threshold(np.vstack([r, np.zeros_like(r)]), 0.5, floor=1e-9)
    assert eps.shape == (2,) and eps[1] == 1e-9
    assert threshold(np.vstack([r, r]), eps).shape == (2, len(r))


def test_edge_exactly_through_a_taxel_row():
    mesh = grid_mesh(5, 5, dx=1.0, dy=1.0)
    x = mesh.positions[:, 0]
    p = np.where(x > 2.0, 1.0, np.where(x == 2.0, 0.5, 0.0))  # the edge passes through the x = 2 row
    f = MeshEdgeDetector(mesh, fraction=0.3).detect(p)
    assert f.found and np.all(np.isfinite(f.centroid))
    assert abs(abs(f.theta) - np.pi / 2) < 0.15  # along y (the diagonals of the grid tilt it a little)
    assert 1.0 <= f.centroid[0] <= 2.0


def test_collinear_component_orientation():
    t = np.linspace(0, 1, 7)
    for ang in (0.0, 0.3, np.pi / 2, -1.2):
        xy = np.column_stack([np.cos(ang) * t, np.sin(ang) * t])
        th, ok, _ = component_orientation(xy, np.zeros(7, int))
        assert ok[0]
        d = np.mod(th[0] - ang + np.pi / 2, np.pi) - np.pi / 2
        assert abs(d) < 1e-12
    th, ok, _ = component_orientation(np.zeros((1, 2)), np.zeros(1, int))  # single point
    assert not ok[0] and th[0] == 0.0
    assert abs(mean_axis([np.radians(89), np.radians(-89)]) - np.pi / 2) < 1e-9 or \
        abs(mean_axis([np.radians(89), np.radians(-89)]) + np.pi / 2) < 1e-9


def test_components_projection_and_features():
    mesh = grid_mesh(6, 6, dx=1.0, dy=1.0)
    mask = np.zeros(36, bool)
    mask[[0, 1, 2]] = True        # column x=0, y=0..2
    mask[[30, 31]] = True         # column x=5
    lab = mesh_components(mesh.adjacency, mask)
    assert len(np.unique(lab[mask])) == 2 and np.all(lab[~mask] == -1)
    # Eq. 8 with a tilted normal removes the normal component
    n = np.array([0.0, 1.0, 1.0]) / np.sqrt(2)
    pts = np.array([[1.0, 2.0, 3.0]])
    b = project_plane(pts, n)
    back = b @ np.vstack([np.array([1.0, 0, 0]), np.cross(n, [1.0, 0, 0])])
    np.testing.assert_allclose(back[0], pts[0] - n * (pts[0] @ n), atol=1e-12)
    f = features(mesh.positions[mask], lab[mask])
    assert f.n_components == 2 and f.has_orientation
    assert abs(abs(f.theta) - np.pi / 2) < 1e-9


def test_local_operators_are_eq4():
    mesh = grid_mesh(4, 4)
    n = len(mesh.positions)
    w = local_operator(mesh, "mean")
    np.testing.assert_allclose(np.asarray(w.sum(axis=1)).ravel(), 1.0)
    np.testing.assert_allclose(apply_local(w, np.full(n, 3.0)), 3.0)
    lap = local_operator(mesh, "laplacian")
    np.testing.assert_allclose(apply_local(lap, np.full((2, n), 7.0)), 0.0, atol=1e-12)
    g = local_operator(mesh, "gaussian", sigma=0.3)
    assert sp.issparse(g) and g.shape == (n, n)
    c = local_operator(mesh, lambda i, j, d: 1.0 / d, self_weight=0.0)
    np.testing.assert_allclose(c.toarray(), local_operator(mesh, "inverse_distance").toarray())
    # Eq. 6 = G(p*p) - p * (G p) with G the inverse-distance Eq. 4 operator
    p = np.random.default_rng(0).random(n)
    G = local_operator(mesh, "inverse_distance")
    np.testing.assert_allclose(edge_filter(mesh, p), G @ (p * p) - p * (G @ p), atol=1e-12)


def test_bad_input_is_rejected_with_a_named_key():
    mesh = grid_mesh()
    with pytest.raises(InputError, match="values"):
        edge_filter(mesh, np.zeros(5))
    with pytest.raises(InputError, match="NaN"):
        edge_filter(mesh, np.full(len(mesh.positions), np.nan))
    with pytest.raises(InputError, match="weights"):
        local_operator(mesh, "median")
    p = np.zeros(len(mesh.positions), dtype=np.float32)
    assert edge_filter(mesh, p).shape == p.shape


@settings(max_examples=30, deadline=None)
@given(seed=st.integers(0, 2**31 - 1), c=st.floats(1e-3, 1e3), scale=st.sampled_from([1e-6, 1e-3, 1.0, 1e3]))
def test_eq6_is_quadratic_permutation_equivariant_and_scales_with_one_over_distance(seed, c, scale):
    rng = np.random.default_rng(seed)
    mesh = grid_mesh(4, 4, z=lambda x, y: 0.2 * y**2)
    p = rng.random(len(mesh.positions))
    r = edge_filter(mesh, p)
    np.testing.assert_allclose(edge_filter(mesh, c * p), c**2 * r, rtol=1e-9, atol=1e-12 * c**2)
    # relabelling the taxels relabels the response
    perm = rng.permutation(len(p))
    inv = np.argsort(perm)
    m2 = mesh_from_triangles(mesh.positions[perm], mesh.normals[perm], inv[mesh.triangles])
    np.testing.assert_allclose(edge_filter(m2, p[perm]), r[perm], rtol=1e-12, atol=1e-12)
    # a skin `scale` times larger has 1/scale the response, finite at micrometres and kilometres
    m3 = mesh_from_triangles(mesh.positions * scale, mesh.normals, mesh.triangles)
    r3 = edge_filter(m3, p)
    assert np.all(np.isfinite(r3))
    np.testing.assert_allclose(r3 * scale, r, rtol=1e-9, atol=1e-12)
