"""``vtcore layout place|import|export|info`` and the scene tables."""

import json

import numpy as np
import pytest
import trimesh

from vtcore.cli import main
from vtcore.layout import load, save, seed001_disc


@pytest.fixture(scope="module")
def meshes(tmp_path_factory):
    d = tmp_path_factory.mktemp("meshes")
    cyl = trimesh.creation.cylinder(radius=0.02, height=0.1, sections=64).subdivide_to_size(0.004)
    cyl.export(d / "cyl20.stl")
    trimesh.creation.icosphere(4, radius=0.04).export(d / "sphere.ply")
    return d


def test_place_on_cylinder_and_sphere_then_info(meshes, tmp_path, capsys):
    """Done-when: place on a 20 mm cylinder and on a sphere: within 0.1 mm, no overlap, info reports strain."""
    out = tmp_path / "cyl.json"
    assert main(["layout", "place", str(meshes / "cyl20.stl"), "--patch", "hexagon", "--at", "0.02", "0", "0",
                 "--direction", "0", "0", "1", "--out", str(out)]) == 0
    lay = load(out)
    assert np.abs(np.hypot(*lay.positions[:, :2].T) - 0.02).max() < 1e-4
    out2 = tmp_path / "sph.json"
    assert main(["layout", "place", str(meshes / "sphere.ply"), "--patch", "strip:3", "--at", "0", "0", "0.04",
                 "--module", "cyskin10", "--offset", "0.0005", "--out", str(out2)]) == 0
    lay2 = load(out2)
    assert np.abs(np.linalg.norm(lay2.positions, axis=1) - 0.0405).max() < 1e-4
    capsys.readouterr()
    for f in (out, out2):
        assert main(["layout", "info", str(f), "--json"]) == 0
        info = json.loads(capsys.readouterr().out)
        for key in ("taxels", "modules", "spacing_min_mm", "spacing_median_mm", "strain_max", "overlaps"):
            assert key in info
        assert info["overlaps"] == 0 and info["strain_max"] is not None
    assert info["taxels"] == 30 and info["modules"] == 3
    assert main(["layout", "info", str(out)]) == 0
    text = capsys.readouterr().out
    assert "strain: max" in text and "bounding box" in text


def test_place_fill_and_icub_module(meshes, tmp_path):
    out = tmp_path / "fill.csv"
    assert main(["layout", "place", str(meshes / "cyl20.stl"), "--patch", "fill", "--at", "0.02", "0", "0",
                 "--direction", "0", "0", "1", "--radius", "0.03", "--out", str(out)]) == 0
    assert len(load(out)) >= 30
    out = tmp_path / "icub.json"
    assert main(["layout", "place", str(meshes / "cyl20.stl"), "--patch", "triangle", "--at", "0.02", "0", "0",
                 "--module", "icub12", "--out", str(out)]) == 0
    assert (load(out).roles == "thermal").sum() == 2


def test_import_export_transform(tmp_path, capsys):
    _, lay = seed001_disc()
    save(lay, tmp_path / "disc.json", "cyskin")
    assert main(["layout", "import", str(tmp_path / "disc.json"), "--format", "cyskin",
                 "--out", str(tmp_path / "own.json")]) == 0
    t = ["1", "0", "0", "0.1", "0", "1", "0", "0", "0", "0", "1", "0", "0", "0", "0", "1"]
    for fmt, ext in (("icub", "txt"), ("mjcf", "xml"), ("ply", "ply"), ("csv", "csv")):
        assert main(["layout", "export", str(tmp_path / "own.json"), "--format", fmt,
                     "--out", str(tmp_path / f"x.{ext}"), "--transform", *t]) == 0
    np.testing.assert_allclose(load(tmp_path / "x.csv").positions, lay.positions + [0.1, 0, 0], atol=1e-12)
    (tmp_path / "t.txt").write_text(" ".join(t))
    assert main(["layout", "export", str(tmp_path / "own.json"), "--format", "csv", "--out",
                 str(tmp_path / "y.csv"), "--transform", str(tmp_path / "t.txt")]) == 0
    np.testing.assert_allclose(load(tmp_path / "y.csv").positions, lay.positions + [0.1, 0, 0], atol=1e-12)


def test_cli_errors_exit_2_without_traceback(tmp_path, capsys, meshes):
    (tmp_path / "bad.csv").write_text("x,y,z\n0,0,0\n0,nan,0\n")
    assert main(["layout", "import", str(tmp_path / "bad.csv"), "--out", str(tmp_path / "o.json")]) == 2
    err = capsys.readouterr().err
    assert "bad.csv:3" in err and "Traceback" not in err
    assert not (tmp_path / "o.json").exists()
    assert main(["layout", "place", str(tmp_path / "none.stl"), "--at", "0", "0", "0", "--out", "x.json"]) == 2
    assert main(["layout", "export", str(tmp_path / "bad.csv"), "--format", "csv", "--out", "x.csv",
                 "--transform", "1", "2"]) == 2
    capsys.readouterr()
    assert main(["layout", "place", str(meshes / "cyl20.stl"), "--patch", "strip:0", "--at", "0", "0", "0",
                 "--out", "x.json"]) == 2  # argparse's usage errors are one line too
    err = capsys.readouterr().err
    assert err.startswith("vtcore: error: vtcore layout place: argument --patch: ") and err.count("\n") == 1, err
    assert main(["layout"]) == 2
