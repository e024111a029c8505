"""``vtcore evaluate`` as a user runs it: one layout, several designs side by side, bad input."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
FAST = ["--set", "task.spacing=0.005", "--set", "task.draws=4", "--set", "task.two_point=false",
        "--set", "task.table_spacing=0.001", "--set", "task.table_forces=4"]


def vt(*args, cwd=ROOT):
    return subprocess.run([sys.executable, "-m", "vtcore", *map(str, args)], capture_output=True, text=True,
                          cwd=cwd, timeout=600)


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    from vtcore.layout import save, seed001_disc

    d = tmp_path_factory.mktemp("inputs")
    mesh, lay = seed001_disc()
    mesh.apply_scale(1000.0)  # a CAD export in millimetres
    mesh.export(d / "disc_mm.stl")
    save(lay, d / "hexagon.json")
    save(lay.subset(slice(0, 30)), d / "half.csv")
    return d


def test_one_layout(files, tmp_path):
    r = vt("evaluate", files / "hexagon.json", "--mesh", files / "disc_mm.stl", "--scale", "0.001", *FAST, "--out", tmp_path / "o")
    assert r.returncode == 0, r.stderr
    assert "threshold median" in r.stdout
    res = json.loads((tmp_path / "o" / "result.json").read_text())
    assert res["task"] == "evaluate" and res["metrics"]["taxels_live"] == 60
    assert (tmp_path / "o" / "maps.ply").is_file() and (tmp_path / "o" / "evaluate.toml").is_file()
    # the folder's scene reruns the same design
    r2 = vt("run", tmp_path / "o" / "evaluate.toml", *FAST, "--out", tmp_path / "again")
    assert r2.returncode == 0, r2.stderr
    again = json.loads((tmp_path / "again" / "result.json").read_text())["metrics"]
    assert again["threshold_covered_median_n"] == res["metrics"]["threshold_covered_median_n"]


def test_designs_side_by_side(files, tmp_path):
    out = tmp_path / "cmp"
    r = vt("evaluate", files / "hexagon.json", files / "half.csv", "--mesh", files / "disc_mm.stl", "--scale", "0.001", *FAST,
           "--set", "layer.thickness=0.002,0.004", "--out", out)
    assert r.returncode == 0, r.stderr
    text = (out / "comparison.md").read_text()
    rows = [ln for ln in text.splitlines() if ln.startswith("| layout.file=")]
    assert len(rows) == 4
    assert (out / "comparison.png").is_file() and (out / "comparison.csv").is_file()
    half = [ln for ln in rows if "half.csv" in ln]
    assert all("| 30 |" in ln for ln in half)


@pytest.mark.parametrize("args, words", [
    (["--set", "task.spacing=0.004"], "--mesh"),
    (["--mesh", "nope.stl"], "nope.stl"),
    (["--mesh", "MESH", "--set", "layer.thicknes=0.003"], "layer.thicknes"),
    (["--mesh", "MESH", "--set", "task.reference_force=-1"], "task.reference_force"),
])
def test_bad_input_is_one_line_exit_2(files, tmp_path, args, words):
    args = [str(files / "disc_mm.stl") if a == "MESH" else a for a in args]
    r = vt("evaluate", files / "hexagon.json", *args, "--out", tmp_path / "bad")
    assert r.returncode == 2, (r.stdout, r.stderr)
    assert words in r.stderr and "Traceback" not in r.stderr


@pytest.mark.slow
def test_designs_through_dask(files, tmp_path):
    out = tmp_path / "dask"
    r = vt("evaluate", files / "hexagon.json", "--mesh", files / "disc_mm.stl", "--scale", "0.001", *FAST,
           "--set", "layer.thickness=0.002,0.003", "--workers", "1", "--out", out)
    assert r.returncode == 0, r.stderr
    assert (out / "sweep.csv").is_file() and (out / "comparison.md").is_file()
    assert "Designs side by side" in (out / "report.md").read_text()


def test_a_robot_layout_needs_no_mesh_and_refuses_one_it_does_not_lie_on(tmp_path):
    """Issue 33: a layout laid on a robot link records the robot, link and geometry; evaluate finds the
    link's surface itself. The Allegro palm skinned on its collision box, evaluated on the palm's visual
    STL, is refused in one line naming how far off the taxels are; a --set typo names the key, not a
    generated TOML, and leaves no output folder."""
    from vtcore.robot import lay_on_link, load_robot
    from vtcore.robot.samples import example_robot_data
    from vtcore.layout import save

    erd = example_robot_data()
    robot = load_robot(erd / "allegro_hand_description" / "urdf" / "allegro_right_hand.urdf")
    lay, _ = lay_on_link(robot, "palm_link", "hexagon", geometry="collision")
    save(lay, tmp_path / "palm.json")
    r = vt("evaluate", tmp_path / "palm.json", "--out", tmp_path / "maps", *FAST)
    assert r.returncode == 0, r.stderr
    res = json.loads((tmp_path / "maps" / "result.json").read_text())
    assert res["metrics"]["samples"] > 0 and (tmp_path / "maps" / "palm_link_collision.stl").is_file()
    # the maps cover the palm's exposed faces only: the fingers' bases cover part of its box
    import trimesh

    mapped = trimesh.load(tmp_path / "maps" / "palm_link_collision.stl")
    from vtcore.robot import link_mesh

    assert 0.5 * link_mesh(robot, "palm_link", "collision").area < mapped.area \
        < 0.95 * link_mesh(robot, "palm_link", "collision").area
    r = vt("evaluate", tmp_path / "palm.json", "--mesh", erd / "allegro_hand_description" / "meshes" / "base_link.STL",
           "--out", tmp_path / "off")
    assert r.returncode == 2 and len(r.stderr.strip().splitlines()) == 1, r.stderr
    assert "does not lie on this mesh" in r.stderr and "mm and" in r.stderr and "palm_link" in r.stderr
    r = vt("evaluate", tmp_path / "palm.json", "--set", "layer.thicknes=0.002", "--out", tmp_path / "typo")
    assert r.returncode == 2 and "thickness" in r.stderr and "evaluate.toml" not in r.stderr, r.stderr
    assert not (tmp_path / "typo").exists()
