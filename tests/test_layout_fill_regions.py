"""Fill regions as designers select them (issue 26): many islands with slivers and islands smaller
than a module on a millimetre CAD export scaled to metres, one lattice across islands, normal-cone
and face-index regions, parts narrower than a module, a start far off the surface, real robot meshes."""

from __future__ import annotations

import sysconfig
import warnings
from pathlib import Path

import numpy as np
import pytest
import trimesh

from vtcore.errors import InputError
from vtcore.layout import PITCH, cadmeshes, fill
from vtcore.layout.meshinput import checked_mesh, load_mesh
from vtcore.layout.regions import face_islands, facing_region, read_face_indices
from vtcore.layout.report import OVERLAP_FRACTION, find_overlaps
from vtcore.layout.surface import closest_points

ROBOTS = Path(sysconfig.get_paths()["purelib"]) / "cmeel.prefix" / "share" / "example-robot-data" / "robots"


def quiet(fn, *a, **k):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return fn(*a, **k)


def no_overlap(lay):
    return not find_overlaps(lay.positions, lay.module_ids, OVERLAP_FRACTION * PITCH)


@pytest.fixture(scope="module")
def mm_link():
    """The CAD link exported in millimetres (slivers, fins, duplicates) and read with scale 0.001."""
    link = cadmeshes.cad_link(mm=True)
    return checked_mesh(link.vertices, link.faces, 0.001, process=False)


def test_a_selection_of_many_islands_with_slivers_fills_in_metres(mm_link):
    band, region = cadmeshes.island_selection(mm_link)
    islands = face_islands(mm_link, region)
    assert len(islands) >= 15
    areas = np.array([mm_link.area_faces[f].sum() for f in islands])
    assert (areas < 0.2 * 468e-6).sum() >= 10  # islands far smaller than a module
    lay, rep = quiet(fill, mm_link, mm_link.triangles_center[band][0], region=region)
    # the band alone: what a person fits on the side of a 72 mm tube, 12 cm long between flange and boss
    assert lay.n_modules >= 10 and no_overlap(lay) and rep.strain_max <= 0.05
    # every taxel on a selected face, in metres (no size taken from a degenerate island)
    _, face, d = closest_points(mm_link, lay.positions)
    assert region[face].all() and d.max() < 1e-4
    assert np.ptp(lay.positions, axis=0).max() < 0.3
    note = next(n for n in rep.notes if "islands" in n)
    assert "left out as smaller than a module" in note


def test_islands_close_together_share_one_lattice():
    """Two pads of a flat plate 6 mm apart (a groove between them): islands='one' lays one lattice
    over both (every taxel on one triangular lattice), 'each' tiles each on its own."""
    plate = trimesh.creation.box(extents=[0.12, 0.06, 0.004]).subdivide_to_size(0.003)
    c, n = plate.triangles_center, plate.face_normals
    top = n[:, 2] > 0.9
    a, b = top & (c[:, 0] < -0.003), top & (c[:, 0] > 0.003)
    lay, rep = quiet(fill, plate, (-0.03, 0, 0.002), (1, 0, 0), region=a | b, islands="one")
    left = lay.positions[:, 0] < 0
    assert left.any() and (~left).any() and no_overlap(lay)
    assert any("share one lattice" in x for x in rep.notes)
    # one lattice: every taxel is a whole number of lattice steps from the first
    e1, e2 = PITCH * np.array([1.0, 0.0]), PITCH * np.array([0.5, np.sqrt(3) / 2])
    basis = np.column_stack([e1, e2])
    k = np.linalg.solve(basis, (lay.positions[:, :2] - lay.positions[0, :2]).T)
    assert np.abs(k - np.round(k)).max() < 0.02


def test_facing_region_and_face_index_file(tmp_path):
    box = trimesh.creation.box(extents=[0.1, 0.06, 0.04])
    up = facing_region(box, (0, 0, 2), 30)
    assert up.sum() == 2 and (box.face_normals[up, 2] > 0.99).all()
    assert facing_region(box, (0, 0, 1), 91).sum() == 10  # the top and the four sides
    with pytest.raises(InputError, match="within"):
        facing_region(box, (0, 0, 1), 0)
    with pytest.raises(InputError, match="facing"):
        facing_region(box, (0, 0, 0), 30)
    f = tmp_path / "faces.txt"
    f.write_text("# the top\n4, 5\n6 # one more\n")
    assert np.flatnonzero(read_face_indices(f, 12)).tolist() == [4, 5, 6]
    (tmp_path / "faces.json").write_text("[1, 2]")
    assert np.flatnonzero(read_face_indices(tmp_path / "faces.json", 12)).tolist() == [1, 2]
    f.write_text("1\n2\n99\n")
    with pytest.raises(InputError, match=r"faces\.txt:3: .*face 99 does not exist: the mesh has 12 faces"):
        read_face_indices(f, 12)
    f.write_text("1\n2.5\n")
    with pytest.raises(InputError, match=r"faces\.txt:2: .*'2\.5' is not a face index"):
        read_face_indices(f, 12)


def test_a_part_narrower_than_a_module_says_so_in_one_line():
    """A 16 mm wide fingertip pad (the top of a 16 x 30 x 8 mm block): no registered module fits;
    the line says how wide the part is and what the smallest module needs."""
    tip = trimesh.creation.box(extents=[0.016, 0.03, 0.008]).subdivide_to_size(0.002)
    with pytest.raises(InputError) as err:
        quiet(fill, tip, (0, 0, 0.004), region=tip.face_normals[:, 2] > 0.9)
    msg = str(err.value)
    assert "\n" not in msg and len(msg) < 300
    assert "16.0 mm across" in msg and "cyskin10 module needs 19.5 mm" in msg
    assert "the smallest module, icub10, needs 17.0 mm" in msg
    assert err.value.details  # the per-island detail block, for --details and the add-on
    # a 18 mm pad fits an icub10 but no cyskin10: the line names the module that fits
    tip = trimesh.creation.box(extents=[0.018, 0.03, 0.008]).subdivide_to_size(0.002)
    with pytest.raises(InputError, match=r"18\.0 mm across.*modules that fit: icub10 \(17\.0 mm\)"):
        quiet(fill, tip, (0, 0, 0.004), region=tip.face_normals[:, 2] > 0.9)


@pytest.mark.skipif(not (ROBOTS / "panda_description").is_dir(), reason="example-robot-data not installed")
def test_a_real_finger_gets_one_short_line():
    finger = load_mesh(ROBOTS / "panda_description/meshes/visual/finger.dae")
    try:
        lay, _ = quiet(fill, finger, finger.vertices[np.argmax(finger.vertices[:, 2])])
        assert lay.n_modules >= 1 and no_overlap(lay)
    except InputError as exc:
        assert "\n" not in str(exc) and len(str(exc)) < 300 and "mm" in str(exc)


def test_fill_from_a_start_far_off_the_surface_still_fills_and_warns():
    """'at' 5 m away snaps to a corner of the hull, where no chart grows: further seeds fill the part."""
    hull = cadmeshes.convex_hull_link()
    with pytest.warns(UserWarning, match="off the surface"):
        lay, rep = fill(hull, (5.0, 0, 0))
    assert lay.n_modules >= 30 and no_overlap(lay)
    assert rep.at_distance > 4.9
    assert any("off the surface" in p for p in rep.problems())


@pytest.mark.slow
@pytest.mark.skipif(not (ROBOTS / "icub_description").is_dir(), reason="example-robot-data not installed")
def test_real_forearm_selection_in_millimetres():
    """iCub's forearm (example-robot-data, a CAD export of 94 bodies), exported in millimetres and read
    with scale 0.001, the faces facing one side selected: 30+ islands; this gave '4.01e+11 module
    positions, a region 13984714 mm across'."""
    src = trimesh.load(ROBOTS / "icub_description/meshes/upmc/visual/icub_l_forearm.dae", force="mesh")
    mesh = checked_mesh(np.asarray(src.vertices) * 1000.0, src.faces, 0.001)
    region = facing_region(mesh, (-1, 0, 0), 45)
    assert len(face_islands(mesh, region)) >= 30
    lay, rep = quiet(fill, mesh, mesh.triangles_center[region][np.argmax(mesh.area_faces[region])], region=region)
    assert lay.n_modules >= 8 and no_overlap(lay)
    _, face, _ = closest_points(mesh, lay.positions)
    assert region[face].all()


@pytest.mark.skipif(not (ROBOTS / "ur_description").is_dir(), reason="example-robot-data not installed")
def test_ur10_wrist_hull_is_filled():
    """UR10's wrist-3 collision hull: no module fit from its outermost point (a crease corner)."""
    w3 = load_mesh(ROBOTS / "ur_description/meshes/ur10/collision/wrist3.stl")
    lay, rep = quiet(fill, w3, w3.vertices[np.argmin(w3.vertices[:, 1])])
    assert lay.n_modules >= 15 and no_overlap(lay) and rep.strain_max <= 0.05


@pytest.mark.skipif(not (ROBOTS / "panda_description").is_dir(), reason="example-robot-data not installed")
@pytest.mark.parametrize("loop", [0, 2])
def test_a_200_triangle_hull_and_its_loop_subdivided_copy(loop):
    """Panda's link-7 collision hull (200 triangles, 125 x 125 x 55 mm, a flat flange of ~87 mm) and
    its Loop-subdivided copy (3,200 faces, where the flange is rounded: its faces within 30 degrees of
    the flange's normal): the flange takes at least the hexagon of six modules a person lays there,
    the whole part many more (the issue saw 'no whole module fits' on both)."""
    hull = load_mesh(ROBOTS / "panda_description/meshes/collision/link7.stl")
    mesh = hull.subdivide_loop(loop) if loop else hull
    flange = facing_region(mesh, (0, 0, -1), 30 if loop else 5)
    centre = mesh.triangles_center[facing_region(mesh, (0, 0, -1), 5)].mean(axis=0)
    lay, rep = quiet(fill, mesh, centre, region=flange)
    assert lay.n_modules >= 6 and no_overlap(lay) and rep.strain_max <= 0.05
    assert (lay.normals[:, 2] < -np.cos(np.radians(31 if loop else 1.0))).all()
    lay, rep = quiet(fill, mesh, centre, max_strain=0.05)
    assert lay.n_modules >= 35 and no_overlap(lay) and not rep.problems()
