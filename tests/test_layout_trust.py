"""Trust signals (issue 26): a placement with taxels off the surface, over-strained or far from the
point asked for is refused (exit 2, one line) unless forced; fill's region options in the CLI."""

from __future__ import annotations

import sysconfig
import warnings
from pathlib import Path

import numpy as np
import pytest
import trimesh

from test_inputs import cli, one_error_line
from vtcore.layout import cadmeshes, load, place
from vtcore.layout.report import PlacementRefused, check_trust

ROBOTS = Path(sysconfig.get_paths()["purelib"]) / "cmeel.prefix" / "share" / "example-robot-data" / "robots"
HAND = ROBOTS / "panda_description/meshes/visual/hand.dae"


@pytest.fixture(scope="module")
def meshes(tmp_path_factory):
    d = tmp_path_factory.mktemp("trust")
    cadmeshes.convex_hull_link().export(d / "hull.stl")
    box = trimesh.creation.box(extents=[0.1, 0.06, 0.04]).subdivide_to_size(0.004)
    box.export(d / "box.stl")
    return d


def test_report_problems_and_check_trust():
    sph = trimesh.creation.icosphere(4, radius=0.04)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        _, ok = place(sph, "hexagon", (0, 0, 0.04))
        _, far = place(sph, "triangle", (0, 0, 5.0))
    assert ok.problems(0.10) == [] and check_trust(ok, max_strain=0.10) == []
    assert ok.problems(0.05)[0].startswith("module edges stretch up to 7.")  # the hexagon's rim on a 40 mm sphere
    assert far.at_distance == pytest.approx(4.96, abs=1e-6)
    with pytest.raises(PlacementRefused, match=r"^triangle refused: 'at' is 4960\.0 mm off the surface"):
        check_trust(far, what="triangle")
    assert check_trust(far, force=True)[0].startswith("'at' is 4960.0 mm")
    assert far.as_dict()["at_distance_m"] == pytest.approx(4.96)


@pytest.mark.skipif(not HAND.is_file(), reason="example-robot-data not installed")
def test_a_hexagon_forced_onto_a_curved_visual_mesh_is_refused(tmp_path):
    """Panda's hand (visual DAE): a hexagon at its base strains 70 % and loses taxels off the surface."""
    out = tmp_path / "h.json"
    rc, _, err = cli("layout", "place", HAND, "--patch", "hexagon", "--at", "0", "0", "0", "--out", out)
    one_error_line(rc, err, "hexagon refused: ", "taxels fall off the surface", "force it")
    assert not out.exists()
    rc, text, err = cli("layout", "place", HAND, "--patch", "hexagon", "--at", "0", "0", "0", "--out", out, "--force")
    assert rc == 0 and "kept with --force: " in err and "stretch up to" in err
    assert len(load(out)) == 60


def test_fill_far_off_the_surface_is_refused_and_warned(meshes, tmp_path):
    out = tmp_path / "f.json"
    args = ("layout", "place", meshes / "box.stl", "--patch", "fill", "--at", "5", "0", "0", "--facing", "1", "0", "0",
            "--out", out)
    rc, _, err = cli(*args)
    one_error_line(rc, err, "fill refused: 'at' is ", "mm off the surface")
    rc, _, err = cli(*args, "--force")
    assert rc == 0 and "'at' is " in err and load(out).n_modules >= 1


def test_fill_region_options(meshes, tmp_path):
    out = tmp_path / "top.json"
    rc, text, err = cli("layout", "place", meshes / "box.stl", "--patch", "fill", "--at", "0", "0", "0.02",
                        "--facing", "0", "0", "1", "--within", "10", "--out", out)
    assert rc == 0, err
    lay = load(out)
    assert lay.n_modules >= 4 and np.allclose(lay.positions[:, 2], 0.02, atol=1e-6)
    box = trimesh.load(meshes / "box.stl")
    side = np.flatnonzero(box.face_normals[:, 1] > 0.9)  # the 100 x 40 mm side facing +y
    (tmp_path / "side.txt").write_text("\n".join(map(str, side)))
    rc, _, err = cli("layout", "place", meshes / "box.stl", "--patch", "fill", "--at", "0", "0.03", "0",
                     "--faces", tmp_path / "side.txt", "--out", out)
    assert rc == 0, err
    assert np.allclose(load(out).positions[:, 1], 0.03, atol=1e-6)
    # the file and the cone together: no face of the side faces up
    rc, _, err = cli("layout", "place", meshes / "box.stl", "--patch", "fill", "--at", "0", "0.03", "0",
                     "--faces", tmp_path / "side.txt", "--facing", "0", "0", "1", "--out", out)
    one_error_line(rc, err, "--facing: no face of the mesh faces (0 0 1) within 45 deg among the faces of --faces")
    rc, _, err = cli("layout", "place", meshes / "box.stl", "--patch", "hexagon", "--at", "0", "0", "0.02",
                     "--facing", "0", "0", "1", "--out", out)
    one_error_line(rc, err, "--patch: --facing, --faces and --radius choose the region of --patch fill")
    rc, _, err = cli("layout", "place", meshes / "box.stl", "--patch", "fill", "--at", "0", "0", "0.02",
                     "--crease-angle", "0", "--out", out)
    one_error_line(rc, err, "--crease-angle")


def test_a_narrow_part_says_what_fits_and_verbose_gives_the_detail(tmp_path):
    tip = trimesh.creation.box(extents=[0.016, 0.03, 0.008]).subdivide_to_size(0.002)
    tip.export(tmp_path / "tip.stl")
    args = ("layout", "place", tmp_path / "tip.stl", "--patch", "fill", "--at", "0", "0", "0.004",
            "--facing", "0", "0", "1", "--out", tmp_path / "t.json")
    rc, _, err = cli(*args)
    one_error_line(rc, err, "16.0 mm across", "cyskin10 module needs 19.5 mm", "icub10, needs 17.0 mm")
    rc, _, err = cli(*args, "--details")
    assert rc == 2 and "\n  island #0: " in err


@pytest.mark.slow
def test_a_selection_of_many_islands_and_a_hull_through_the_cli(tmp_path):
    """The hard cases as a CLI user gives them: the CAD link exported in millimetres (slivers, fins,
    duplicate faces) read with --scale 0.001 and a face-index file of 31 islands (one side and 40
    stray faces, most far smaller than a module); a 200-triangle convex hull filled from 5 m away."""
    import contextlib
    import io

    from vtcore.cli import main
    from vtcore.layout.meshinput import load_mesh

    def cli(*argv):  # no 30 s bound: these fills take longer on a loaded machine
        out, err = io.StringIO(), io.StringIO()
        with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
            rc = main([str(a) for a in argv])
        return rc, out.getvalue(), err.getvalue()
    from vtcore.layout.regions import face_islands

    src = tmp_path / "link_mm.obj"
    cadmeshes.cad_link(mm=True).export(src)
    seen = load_mesh(src, 0.001)  # the faces as the CLI reads them, which the file's indices name
    side, region = cadmeshes.island_selection(seen)
    assert len(face_islands(seen, region)) >= 15
    (tmp_path / "sel.txt").write_text("# one side and strays\n" + "\n".join(map(str, np.flatnonzero(region))))
    at = seen.triangles_center[side][0]
    out = tmp_path / "sel.json"
    rc, text, err = cli("layout", "place", src, "--scale", "0.001", "--patch", "fill", "--at", *at,
                        "--faces", tmp_path / "sel.txt", "--out", out)
    assert rc == 0, err
    lay = load(out)
    assert lay.n_modules >= 10 and "left out as smaller than a module" in err
    hull = tmp_path / "hull.stl"
    cadmeshes.convex_hull_link().export(hull)
    rc, _, err = cli("layout", "place", hull, "--patch", "fill", "--at", "5", "0", "0", "--out", out)
    one_error_line(rc, err, "fill refused: 'at' is ", "mm off the surface", "force")
    rc, text, err = cli("layout", "place", hull, "--patch", "fill", "--at", "5", "0", "0", "--out", out, "--force")
    assert rc == 0 and "kept with --force: 'at' is " in err and load(out).n_modules >= 30
