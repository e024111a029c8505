"""Conforming patches to meshes: log map vs projection, and the hard meshes."""

import warnings

import numpy as np
import pytest
import trimesh

from vtcore.errors import InputError
from vtcore.layout import LayoutWarning, fill, make_patch, place
from vtcore.layout.conform import LogMap, arc_lengths, clean_mesh

PITCH = 7.5e-3


def cylinder(r, h=0.1, size=0.004):
    m = trimesh.creation.cylinder(radius=r, height=h, sections=int(np.ceil(2 * np.pi * r / 0.002)))
    return m.subdivide_to_size(size)


@pytest.fixture(scope="module")
def cyl20():
    return cylinder(0.02)


@pytest.fixture(scope="module")
def sphere40():
    return trimesh.creation.icosphere(4, radius=0.04)


def radial_error(pos, r):
    return np.abs(np.hypot(pos[:, 0], pos[:, 1]) - r)


def test_cylinder_r20_on_surface_no_overlap(cyl20):
    """Done-when: on a cylinder of radius 20 mm taxels lie within 0.1 mm of the surface, no overlap."""
    lay, rep = place(cyl20, "hexagon", at=(0.02, 0, 0), direction=(0, 0, 1))
    assert radial_error(lay.positions, 0.02).max() < 1e-4
    assert rep.overlaps == [] and len(rep.off_boundary) == 0
    assert rep.strain_max < 0.01  # a cylinder is developable: the log map unrolls it
    # normals are the outward surface normals
    radial = lay.positions[:, :2] / np.hypot(*lay.positions[:, :2].T)[:, None]
    assert np.einsum("ij,ij->i", radial, lay.normals[:, :2]).min() > 0.999
    assert lay.meta["placement"]["strain_max"] == pytest.approx(rep.strain_max)
    # the patch x axis follows the direction (the cylinder axis)
    c = lay.positions - lay.positions.mean(axis=0)
    assert np.ptp(lay.positions[:, 2]) == pytest.approx(np.ptp(lay.flat[:, 0]), rel=0.01)


def test_offset_along_normal(cyl20):
    lay, _ = place(cyl20, "triangle", at=(0.02, 0, 0), direction=(0, 0, 1), offset=1e-3)
    np.testing.assert_allclose(np.hypot(*lay.positions[:, :2].T), 0.021, atol=1e-4)


def test_logmap_beats_projection(cyl20):
    a, ra = place(cyl20, "hexagon", at=(0.02, 0, 0), direction=(0, 1, 0), method="logmap")
    b, rb = place(cyl20, "hexagon", at=(0.02, 0, 0), direction=(0, 1, 0), method="project")
    assert radial_error(b.positions, 0.02).max() < 1e-4  # projection also lands on the surface...
    assert rb.strain_max > 5 * ra.strain_max  # ...but squeezes the modules round the curve
    assert rb.method == "project"


def test_sphere(sphere40):
    lay, rep = place(sphere40, "hexagon", at=(0, 0, 0.04))
    assert np.abs(np.linalg.norm(lay.positions, axis=1) - 0.04).max() < 1e-4
    assert rep.overlaps == []
    # distances from the centre taxel are geodesic distances on the sphere (exp map)
    g = 0.04 * np.arccos(np.clip(lay.positions[:, 2] / np.linalg.norm(lay.positions, axis=1), -1, 1))
    np.testing.assert_allclose(g, np.hypot(*lay.flat.T), atol=3e-4)
    # a sphere is not developable: circles shrink, strain is there and reported
    assert 0.02 < rep.strain_max < 0.15


def test_cylinder_r10_wraps_almost_around():
    m = cylinder(0.01, 0.08)
    lay, rep = place(m, "hexagon", at=(0.01, 0, 0), direction=(0, 0, 1))
    assert radial_error(lay.positions, 0.01).max() < 1e-4
    # near the cut locus (the far side of the cylinder) the heat-method log map is smoothed:
    # about 0.25 mm of error at 2.6 rad round a 10 mm cylinder, hence a few percent of strain there
    assert rep.overlaps == [] and rep.strain_max < 0.06 and rep.strain_mean < 0.01
    # the hexagon is 60 mm across, the circumference 62.8 mm: it wraps round but does not overlap
    ang = np.arctan2(lay.positions[:, 1], lay.positions[:, 0])
    assert np.ptp(ang) > 0.8 * 2 * np.pi


def test_patch_larger_than_the_surface_is_reported():
    plate = trimesh.creation.box(extents=[0.04, 0.04, 0.002])
    top = plate.submesh([np.flatnonzero(plate.face_normals[:, 2] > 0.9)], append=True)  # open: a square
    top = top.subdivide_to_size(0.003)
    with pytest.warns(LayoutWarning, match="outside the mapped surface"):
        lay, rep = place(top, "strip:4", at=(0, 0, 0.001), direction=(1, 0, 0))
    assert len(lay) == 40  # never silently dropped
    assert 0 < len(rep.off_boundary) < 40
    off = lay.positions[rep.off_boundary]
    inside = np.all(np.abs(lay.flat) < 0.02 - 1e-4, axis=1)
    assert not inside[rep.off_boundary].any()
    assert np.abs(off[:, :2]).max() <= 0.02 + 1e-9  # kept on the closest surface point


def test_patch_larger_than_closed_surface_overlaps():
    m = cylinder(0.006, 0.06)  # circumference 37.7 mm < a 60 mm hexagon
    lay, rep = place(m, "hexagon", at=(0.006, 0, 0), direction=(0, 0, 1))
    assert np.isfinite(lay.positions).all()
    assert len(rep.overlaps) > 0  # wrapped onto itself: reported


def test_open_nonmanifold_and_degenerate_meshes():
    sheet = trimesh.creation.box(extents=[0.08, 0.08, 0.01])
    top = sheet.submesh([np.flatnonzero(sheet.face_normals[:, 2] > 0.9)], append=True).subdivide_to_size(0.004)
    v, f = np.asarray(top.vertices), np.asarray(top.faces)
    # degenerate triangles: a zero-area sliver and a repeated-vertex face
    degen = np.array([[f[0, 0], f[0, 1], f[0, 1]], [f[1, 0], f[1, 0], f[1, 0]]])
    # non-manifold: a fin hanging down from one interior edge (three faces share it)
    e0, e1 = f[len(f) // 2, 0], f[len(f) // 2, 1]
    fin_v = len(v)
    v2 = np.vstack([v, (v[e0] + v[e1]) / 2 + [0, 0, -0.01]])
    bad = trimesh.Trimesh(v2, np.vstack([f, degen, [[e0, e1, fin_v]]]), process=False, validate=False)
    clean, notes = clean_mesh(bad)
    assert any("degenerate" in n for n in notes)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", LayoutWarning)
        lay, rep = place(bad, "hexagon", at=(0.0, 0.0, 0.005))
    assert np.isfinite(lay.positions).all()
    np.testing.assert_allclose(lay.positions[:, 2], 0.005, atol=1e-9)
    assert rep.overlaps == [] and rep.strain_max < 1e-6
    assert any("degenerate" in n for n in rep.notes)


def test_direction_parallel_to_normal_and_bad_input(cyl20):
    with pytest.raises(InputError, match="parallel"):
        place(cyl20, "triangle", at=(0.02, 0, 0), direction=(1, 0, 0))
    with pytest.raises(InputError, match="'at'"):
        place(cyl20, "triangle", at=(np.nan, 0, 0))
    with pytest.raises(InputError, match="method"):
        place(cyl20, "triangle", at=(0.02, 0, 0), method="magic")


def test_fill_region_without_overlap(cyl20):
    lay, rep = fill(cyl20, at=(0.02, 0, 0), direction=(0, 0, 1), radius=0.035)
    assert lay.n_modules >= 3 and len(lay) == 10 * lay.n_modules
    assert rep.overlaps == [] and len(rep.off_boundary) == 0
    assert radial_error(lay.positions, 0.02).max() < 1e-4
    assert 0.2 < rep.coverage <= 1.0
    # a face mask restricts the fill: only the side (no caps)
    side = np.abs(cyl20.face_normals[:, 2]) < 0.5
    lay2, rep2 = fill(cyl20, at=(0.02, 0, 0), direction=(0, 0, 1), region=side)
    assert np.abs(lay2.positions[:, 2]).max() < 0.05 and rep2.overlaps == []
    with pytest.raises(InputError, match="region"):
        fill(cyl20, at=(0.02, 0, 0), region=side[:10])


def test_arc_lengths_exact_on_circles():
    r = 0.02
    th = np.array([0.0, 0.5])
    p = np.column_stack([r * np.cos(th), r * np.sin(th), [0, 0]])
    n = p / r
    assert arc_lengths(p[:1], p[1:], n[:1], n[1:])[0] == pytest.approx(0.5 * r)


def test_logmap_reuse_for_several_patches(cyl20):
    lm = LogMap(clean_mesh(cyl20)[0], (0.02, 0, 0), (0, 0, 1), radius=0.06)
    a, _ = place(lm.mesh, "triangle", lm.at, (0, 0, 1), logmap=lm)
    b, _ = place(lm.mesh, make_patch("triangle"), lm.at, (0, 0, 1), logmap=lm)
    np.testing.assert_allclose(a.positions, b.positions)


@pytest.mark.parametrize("which,at", [("disc", (0.0, 0.0, 0.0)), ("curved", (-0.03, 0.0, 0.0)),
                                      ("curved", (0.02, 0.0, -0.005))])
def test_coarse_cad_meshes_are_refined_before_solving(which, at):
    """Fan caps and full-width needle faces (CAD-style meshes) would starve the heat method."""
    from vtcore.layout import seed001_disc, seed002_curved

    mesh, _ = seed001_disc() if which == "disc" else seed002_curved()
    assert len(mesh.faces) < 1000
    lay, rep = place(mesh, "hexagon", at, (1, 0, 0))
    assert rep.strain_max < 1e-3 and rep.overlaps == [] and len(rep.off_boundary) == 0
