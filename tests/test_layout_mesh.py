"""The skin mesh (seed 002, Eqs. 1-2) and its hard cases."""

import warnings

import numpy as np
import pytest
import scipy.sparse as sp
from hypothesis import given, settings
from hypothesis import strategies as st

from vtcore.errors import InputError
from vtcore.layout import Layout, LayoutWarning, make_patch, mesh_from_triangles, skin_mesh
from vtcore.layout.modules import MODULES
from vtcore.layout.patches import patch_from_poses, tile_poses
from vtcore.layout.synthetic import cyskin_half_cylinder, edge_agreement, faces_to_edges

PITCH = 7.5e-3


def positions_only(layout):
    return Layout(layout.positions, layout.normals, layout.taxel_ids, layout.module_ids)


def cylinder_layout(radius, width_m, length_m=0.06):
    """A tiling wrapped round a cylinder (axis y) by exact unrolling; x in [-width/2, width/2]."""
    mod = MODULES["cyskin10"]
    p = patch_from_poses(mod, tile_poses(mod, [-width_m / 2, -length_m / 2], [width_m / 2, length_m / 2]))
    keep = np.all(np.abs(p.flat) <= [width_m / 2, length_m / 2], axis=1)
    f = p.flat[keep]
    th = f[:, 0] / radius
    pos = np.column_stack([radius * np.sin(th), f[:, 1], radius * np.cos(th)])
    nrm = np.column_stack([np.sin(th), np.zeros_like(th), np.cos(th)])
    return Layout(pos, nrm, np.arange(len(f)), np.zeros(len(f)), flat=f)


def test_matrices_symmetric_and_consistent():
    lay = make_patch("hexagon").flat_layout()
    m = skin_mesh(lay)
    assert isinstance(m.adjacency, sp.csr_matrix) and isinstance(m.distances, sp.csr_matrix)
    assert (m.adjacency != m.adjacency.T).nnz == 0
    assert abs(m.distances - m.distances.T).max() == 0
    np.testing.assert_array_equal(m.adjacency.indices, m.distances.indices)
    e = m.edges
    np.testing.assert_allclose(np.asarray(m.distances[e[:, 0], e[:, 1]]).ravel(),
                               np.linalg.norm(lay.positions[e[:, 0]] - lay.positions[e[:, 1]], axis=1))
    assert m.adjacency.diagonal().sum() == 0
    # every lattice neighbour pair (7.5 mm) is an edge
    d = np.asarray(m.distances[e[:, 0], e[:, 1]]).ravel()
    # the 61-site hexagon has 156 unit edges, 6 of them at the missing centre; the hole gets 3 diagonals
    assert (np.abs(d - PITCH) < 1e-9).sum() == 150 and len(e) == 153


def test_flat_and_surface_agree_on_flat_patch():
    lay = make_patch("hexagon").flat_layout()
    a = skin_mesh(lay)
    b = skin_mesh(positions_only(lay))
    assert a.meta["method"] == "flat" and b.meta["method"] == "surface"
    assert edge_agreement(b.edges, a.edges) == 1.0


def test_boundary_slivers_and_long_edges_are_peeled():
    # an L-shaped region: Delaunay spans the notch with long hull edges
    lay = make_patch("strip:4").flat_layout()
    keep = ~((lay.flat[:, 0] > 0.0) & (lay.flat[:, 1] > 0.0))
    lay = lay.subset(keep)
    m = skin_mesh(lay)
    d = np.asarray(m.distances[m.edges[:, 0], m.edges[:, 1]]).ravel()
    assert d.max() <= 1.5 * PITCH + 1e-9
    assert m.meta["peeled"] > 0
    # slightly noisy straight border: no sliver triangles with a flat angle
    rng = np.random.default_rng(0)
    lay2 = make_patch("strip:6").flat_layout()
    lay2.flat = lay2.flat + rng.normal(0, 2e-4, lay2.flat.shape)
    m2 = skin_mesh(lay2)
    t = lay2.flat[m2.triangles]
    a = np.linalg.norm(t - np.roll(t, 1, axis=1), axis=2)
    assert a.max() < 1.5 * PITCH


def test_duplicates_merged_or_rejected():
    lay = make_patch("hexagon").flat_layout()
    dup = Layout(np.vstack([lay.positions, lay.positions[:2]]), np.vstack([lay.normals, lay.normals[:2]]),
                 np.arange(62), np.zeros(62), np.vstack([lay.flat, lay.flat[:2]]))
    with pytest.warns(LayoutWarning, match="duplicate"):
        m = skin_mesh(dup)
    assert m.meta["duplicates"] == [[60, 0], [61, 1]]
    # the duplicates have their representative's neighbours, and no zero-length edge
    assert set(m.adjacency[60].indices) <= set(m.adjacency[0].indices) and 1 in m.adjacency[60].indices
    assert m.distances.data.min() > 0
    assert np.all(np.isfinite(m.distances.data))
    with pytest.raises(InputError, match="60=0"):
        skin_mesh(dup, duplicates="error")


def test_collinear_and_tiny_sets():
    x = np.linspace(0, 0.03, 5)
    pos = np.column_stack([x, 0 * x, 0 * x])
    lay = Layout(pos, np.tile([0, 0, 1.0], (5, 1)), np.arange(5), np.zeros(5), flat=pos[:, :2])
    m = skin_mesh(lay)
    assert len(m.triangles) == 0 and len(m.edges) == 4
    m2 = skin_mesh(positions_only(lay))  # collinear 3-D positions
    assert len(m2.edges) == 4
    for n in (0, 1, 2):
        small = Layout(pos[:n], np.tile([0, 0, 1.0], (n, 1)), np.arange(n), np.zeros(n), flat=pos[:n, :2])
        assert len(skin_mesh(small).edges) == max(n - 1, 0)


def test_coplanar_3d_positions_tilted():
    lay = make_patch("strip:3").flat_layout()
    rot = np.linalg.qr(np.random.default_rng(1).normal(size=(3, 3)))[0]
    pos = lay.positions @ rot.T + [0.1, -0.2, 0.3]
    nrm = np.zeros_like(pos)  # unknown normals
    m = skin_mesh(Layout(pos, nrm, lay.taxel_ids, lay.module_ids))
    ref = skin_mesh(lay)
    assert edge_agreement(m.edges, ref.edges) == 1.0


def test_single_module():
    lay = make_patch("triangle").flat_layout()
    m = skin_mesh(lay)
    assert len(m.triangles) == 9 and len(m.edges) == 18


def test_half_cylinder_surface_mesh_does_not_cut_through():
    """Done-when: a patch wrapped half-way round a cylinder, midpoints within 1 mm of the surface."""
    r = 0.02
    lay = cylinder_layout(r, np.pi * r)
    for method in ("flat", "surface"):
        m = skin_mesh(lay if method == "flat" else positions_only(lay))
        assert m.meta["method"] == method
        mid = (lay.positions[m.edges[:, 0]] + lay.positions[m.edges[:, 1]]) / 2
        assert np.abs(np.hypot(mid[:, 0], mid[:, 2]) - r).max() < 1e-3


def test_full_tube_of_radius_10mm_never_bridges_the_inside():
    r = 0.010
    lay = positions_only(cylinder_layout(r, 2 * np.pi * r - 1e-3, 0.08))
    m = skin_mesh(lay)
    d = np.asarray(m.distances[m.edges[:, 0], m.edges[:, 1]]).ravel()
    assert d.max() < 1.8 * PITCH  # the seam where the tiling meets itself is irregular; the inside is 20 mm
    mid = (lay.positions[m.edges[:, 0]] + lay.positions[m.edges[:, 1]]) / 2
    assert np.abs(np.hypot(mid[:, 0], mid[:, 2]) - r).max() < 2.5e-3
    # no taxel is cut off, and the inside of the tube is connected as a lattice (6 neighbours)
    deg = np.diff(m.adjacency.indptr)
    assert deg.min() >= 2 and np.median(deg) >= 5


def test_thin_part_faces_are_not_bridged():
    """Two faces of a 3 mm plate, each with a patch: no edge between them."""
    top = make_patch("hexagon").flat_layout()
    pos = np.vstack([top.positions, top.positions * [1, 1, 0] + [0.0, 0.0, -3e-3]])
    nrm = np.vstack([top.normals, -top.normals])
    lay = Layout(pos, nrm, np.arange(120), np.repeat([0, 1], 60))
    m = skin_mesh(lay)
    e = m.edges
    assert np.all((e[:, 0] < 60) == (e[:, 1] < 60))
    assert len(e) == 2 * 153


def test_maker_triangulation_agreement_synthetic(tmp_path):
    """On a (synthetic, see vtcore.layout.synthetic) CySkin half-cylinder read from positions
    alone (a CSV of x, y, z without normals or faces), the skin mesh agrees with the maker's
    triangulation on >= 80% of its edges."""
    from vtcore.layout import load

    lay, faces, _ = cyskin_half_cylinder(seed=3)
    assert 500 <= len(lay) <= 650 and lay.flat is None
    rows = ["x,y,z"] + [",".join(f"{v:.6f}" for v in p) for p in lay.positions]
    (tmp_path / "patch.csv").write_text("\n".join(rows) + "\n")
    with pytest.warns(LayoutWarning, match="no normal"):
        read = load(tmp_path / "patch.csv")
    m = skin_mesh(read)
    assert m.meta["method"] == "surface"
    assert edge_agreement(m.edges, faces_to_edges(faces)) >= 0.8


def test_float32_and_mm_scale_inputs_stay_finite():
    lay = make_patch("hexagon").flat_layout()
    f32 = Layout(lay.positions.astype(np.float32), lay.normals.astype(np.float32), lay.taxel_ids, lay.module_ids)
    m = skin_mesh(f32)
    assert np.isfinite(m.distances.data).all() and len(m.edges) == 153
    big = Layout(lay.positions * 1e3, lay.normals, lay.taxel_ids, lay.module_ids)
    assert len(skin_mesh(big).edges) == 153


def test_mesh_from_triangles_extra_edges():
    pos = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [5, 5, 0]], float)
    m = mesh_from_triangles(pos, np.tile([0, 0, 1.0], (4, 1)), [[0, 1, 2]], extra_edges=[[2, 3]])
    assert m.edges.tolist() == [[0, 1], [0, 2], [1, 2], [2, 3]]


def test_4000_taxels_builds():
    mod = MODULES["cyskin10"]
    p = patch_from_poses(mod, tile_poses(mod, [-0.25, -0.25], [0.25, 0.25]))
    lay = p.flat_layout()
    assert len(lay) >= 4000
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        m = skin_mesh(lay)
    assert np.diff(m.adjacency.indptr).max() <= 12


@settings(max_examples=25, deadline=None)
@given(seed=st.integers(0, 10_000), keep=st.floats(0.3, 1.0), jitter=st.floats(0.0, 0.3),
       scale=st.sampled_from([1e-3, 1.0, 1e3]), flat=st.booleans())
def test_skin_mesh_properties(seed, keep, jitter, scale, flat):
    """Random subsets of a jittered lattice, at any scale, with or without flat coordinates:
    E and D stay symmetric and finite, triangles index valid taxels, no boundary edge spans a gap."""
    rng = np.random.default_rng(seed)
    base = make_patch("strip:4").flat_layout()
    sel = rng.random(len(base)) < keep
    f = (base.flat[sel] + rng.normal(0, jitter * PITCH, (sel.sum(), 2))) * scale
    n = len(f)
    pos = np.column_stack([f, np.zeros(n)])
    lay = Layout(pos, np.tile([0, 0, 1.0], (n, 1)), np.arange(n), np.zeros(n), flat=f if flat else None)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", LayoutWarning)
        m = skin_mesh(lay)
    assert np.isfinite(m.distances.data).all()
    assert (m.adjacency != m.adjacency.T).nnz == 0
    if len(m.triangles):
        assert m.triangles.min() >= 0 and m.triangles.max() < n
    if n >= 2 and len(m.edges):
        assert m.distances.data.min() > 0
