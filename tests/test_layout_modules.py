"""Module registry, patches and the seed end-effectors."""

import numpy as np
import pytest
import trimesh
from scipy.spatial import cKDTree

from vtcore.errors import InputError
from vtcore.layout import (MODULES, Patch, get_module, hexagon_flat, make_patch, seed001_disc, seed002_curved,
                           seed002_planar)
from vtcore.layout.modules import ModuleType, register_module
from vtcore.layout.patches import coincident_pairs, patch_from_poses, tile_poses

PITCH = 7.5e-3


def nn(points):
    d, _ = cKDTree(points).query(points, 2)
    return d[:, 1]


def test_registry_entries():
    c10, c11, ic = MODULES["cyskin10"], MODULES["cyskin11"], MODULES["icub12"]
    assert len(c10) == 10 and len(c11) == 11 and len(ic) == 12
    np.testing.assert_allclose(nn(c10.taxels), PITCH)
    assert c10.taxel_diameter == pytest.approx(4e-3)
    # a 4-per-side triangle: side 3 pitches
    d = np.linalg.norm(c10.taxels[:, None] - c10.taxels[None], axis=-1)
    assert d.max() == pytest.approx(3 * PITCH)
    assert list(ic.roles).count("thermal") == 2 and ic.roles[6] == ic.roles[10] == "thermal"
    # the iCub outline is the 30 mm triangle centred on the origin
    np.testing.assert_allclose(ic.outline.mean(axis=0), 0, atol=1e-12)
    assert np.linalg.norm(ic.outline[0] - ic.outline[1]) == pytest.approx(0.030)
    with pytest.raises(InputError, match="unknown module type"):
        get_module("nope")


def test_register_variant_is_data_not_code():
    base = MODULES["cyskin10"]
    mt = ModuleType("test4", base.taxels[:4], np.arange(1, 5), ["pressure"] * 4, base.outline, PITCH, 4e-3,
                    base.strip, base.strip_period, base.fill_row, base.hexagon)
    register_module(mt)
    try:
        p = make_patch("hexagon", "test4")
        assert len(p) == 24 and p.n_modules == 6
    finally:
        MODULES.pop("test4")


def test_hexagon_seed001():
    p = make_patch("hexagon")
    assert len(p) == 60 and p.n_modules == 6
    assert np.all(np.bincount(p.module_ids) == 10)
    # the 61 sites of a hexagonal lattice of radius 4 minus the centre
    r = np.hypot(*p.flat.T) / PITCH
    assert r.min() == pytest.approx(1.0) and r.max() == pytest.approx(4.0)
    np.testing.assert_allclose(nn(p.flat), PITCH)
    assert len(np.unique(p.taxel_ids)) == 60
    assert set(p.sensors) == set(range(1, 11))
    q = make_patch("hexagon", center=True)
    assert len(q) == 61 and np.hypot(*q.flat[0]) == 0
    flat, mods = hexagon_flat()
    np.testing.assert_allclose(flat, p.flat)


def test_cyskin11_hexagon_has_61_taxels():  # real planar hexagons: 61 taxels in 6 modules
    p = make_patch("hexagon", "cyskin11")
    assert len(p) == 61 and np.bincount(p.module_ids).tolist() == [11, 10, 10, 10, 10, 10]
    assert nn(p.flat).min() == pytest.approx(PITCH)
    assert p.meta["shared_sites_dropped"] == 5


@pytest.mark.parametrize("kind,n", [("triangle", 10), ("strip:1", 10), ("strip:2", 20), ("strip:7", 70)])
def test_triangle_and_strips(kind, n):
    p = make_patch(kind)
    assert len(p) == n
    np.testing.assert_allclose(nn(p.flat), PITCH)  # one lattice, no gaps, no duplicates
    assert len(p.module_edges) == 18 * p.n_modules  # 18 unit edges in a 4-per-side triangle


def test_icub_patches():
    p = make_patch("hexagon", "icub12")
    assert len(p) == 72 and p.n_modules == 6
    assert nn(p.flat).min() > 4e-3  # triangles do not overlap
    assert (p.roles == "thermal").sum() == 12
    # iCub ids are rows of a positions file: triangle * 12 + slot
    np.testing.assert_array_equal(p.taxel_ids, np.arange(72))


def test_bad_patch_names():
    for bad in ("strip", "strip:0", "strip:x", "square"):
        with pytest.raises(InputError):
            make_patch(bad)


def test_plane_tiling_has_no_gaps_or_duplicates():
    mod = MODULES["cyskin10"]
    p = patch_from_poses(mod, tile_poses(mod, [-0.05, -0.05], [0.05, 0.05]))
    d = nn(p.flat)
    assert d.min() == pytest.approx(PITCH) and d.max() == pytest.approx(PITCH)
    inner = np.all(np.abs(p.flat) < 0.04, axis=1)
    # lattice density: one site per sqrt(3)/2 pitch^2
    assert inner.sum() == pytest.approx(0.08 ** 2 / (np.sqrt(3) / 2 * PITCH ** 2), rel=0.05)


@pytest.mark.parametrize("factory,n", [(seed001_disc, 60), (seed002_planar, 20), (seed002_curved, 210)])
def test_seed_end_effectors(factory, n):
    mesh, layout = factory()
    assert isinstance(mesh, trimesh.Trimesh) and mesh.is_watertight
    assert len(layout) == n
    assert layout.flat is not None
    _, d, _ = trimesh.proximity.closest_point(mesh, layout.positions)
    assert d.max() < 1e-4  # taxels on the skin surface
    np.testing.assert_allclose(np.linalg.norm(layout.normals, axis=1), 1)
    # outward normals: a point just outside along the normal is outside the body
    assert not mesh.contains(layout.positions + 1e-3 * layout.normals).any()
    assert mesh.contains(layout.positions - 1e-3 * layout.normals).all()


def test_seed001_fits_80mm_disc_and_seed002_curved_is_curved():
    mesh, layout = seed001_disc()
    assert np.ptp(mesh.vertices[:, 0]) == pytest.approx(0.08, rel=1e-3)
    assert np.hypot(*layout.positions[:, :2].T).max() < 0.04
    mesh, layout = seed002_curved()
    assert np.ptp(layout.normals[:, 0]) > 0.9  # the normals turn by about 90 degrees
    ref = layout.meta["reference_taxel"]
    assert layout.normals[ref, 0] > 0.1  # x_R lies on the curvature
    # unrolling is exact on this developable surface: flat distances = arc lengths between neighbours
    from vtcore.layout.conform import layout_strain

    p = make_patch("triangle")
    edges = np.asarray(cKDTree(layout.flat).query_pairs(1.01 * PITCH, output_type="ndarray"))
    s = layout_strain(layout, layout.flat, edges)
    assert np.abs(s).max() < 1e-3


def test_patch_is_dataclass_with_layout():
    p = make_patch("strip:2")
    assert isinstance(p, Patch)
    lay = p.flat_layout()
    assert lay.meta["module_type"] == "cyskin10" and len(lay) == 20
    np.testing.assert_array_equal(lay.taxel_ids >> 4, lay.module_ids + 1)


def test_coincident_pairs_are_the_k_d_trees_pairs():
    """The shared-site search of patch_from_poses finds what cKDTree.query_pairs finds: points a
    fraction of the tolerance apart anywhere, across the borders of its grid cells, in threes."""
    rng = np.random.default_rng(3)
    x = rng.uniform(-1, 1, (3000, 2))
    on_grid = np.round(rng.uniform(-1, 1, (1000, 2)) / 1e-6) * 1e-6  # on the grid's cell borders
    pts = np.concatenate([x, x + rng.uniform(-1, 1, x.shape) * 6e-10, x, on_grid, on_grid + 3e-10,
                          on_grid - 3e-10, rng.uniform(-1, 1, (3000, 2))])
    want = {tuple(p) for p in np.sort(cKDTree(pts).query_pairs(1e-9, output_type="ndarray"), axis=1)}
    got = coincident_pairs(pts, 1e-9)
    assert len(want) == 3 * 3000 + 3 * 1000
    assert {tuple(p) for p in got} == want and (got[:, 0] < got[:, 1]).all()
    assert not len(coincident_pairs(rng.uniform(-1, 1, (500, 2)), 1e-9))
