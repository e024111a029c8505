"""The seed 002 scenes end to end (small: one run, fewer taps), their metrics and their errors."""

from __future__ import annotations

import json

import numpy as np
import pytest

from vtcore.errors import SceneError
from vtcore.scene import load_scene, run_scene

QUICK = ["task.runs=1", "task.max_taps=12"]


@pytest.mark.parametrize("name", ["contour_ruler_planar", "contour_mug_curved"])
def test_contour_scene_reports_every_method(tmp_path, scenes_dir, name):
    out = tmp_path / name
    res = run_scene(scenes_dir / f"{name}.toml", out, QUICK)
    m = res["metrics"]
    for method in ("mesh", "image", "subtaxel"):
        for stat in ("d_mean_mm", "d_std_mm", "d_max_mm"):
            assert isinstance(m[f"{method}_{stat}"], float)
        assert m[f"{method}_taps"] >= 2
        assert m[f"{method}_d_mean_mm"] <= m[f"{method}_d_max_mm"]
    assert m["mesh_d_mean_mm"] < 7.5  # below the taxel pitch
    # every listed effect is reported, applied or not (a floor of 0 on readings already >= 0 changes nothing)
    listed = ["soft_layer", "gain", "noise", "saturation", "quantisation"]
    assert [e["name"] for e in res["effects"]][:3] == listed[:3]
    assert sorted([e["name"] for e in res["effects"]] + res["effects_not_applied"]) == sorted(listed)
    arrays = np.load(out / "arrays.npz")
    t, n = arrays["pressure"].shape
    assert arrays["frames"].shape == (t, n) and arrays["edge"].shape == (t, n) and arrays["edge"].dtype == bool
    assert arrays["positions"].shape == (n, 3) and arrays["force"].shape == (t,)
    report = (out / "report.md").read_text()
    assert "Tables 1-2" in report and "0.89-1.86 mm" in report and "](path.png)" in report
    table = json.loads((out / "result.json").read_text())["contour_table"]
    assert {row["method"] for row in table} == {"mesh", "image", "subtaxel"}


def test_contour_scene_is_reproducible(tmp_path, scenes_dir):
    args = QUICK + ['task.methods=["mesh"]', "output.plots=false"]
    run_scene(scenes_dir / "contour_mug_planar.toml", tmp_path / "a", args)
    run_scene(scenes_dir / "contour_mug_planar.toml", tmp_path / "b", args)
    assert (tmp_path / "a" / "arrays.npz").read_bytes() == (tmp_path / "b" / "arrays.npz").read_bytes()


def test_analytic_contact_scene_runs_without_the_solver(tmp_path, scenes_dir):
    res = run_scene(scenes_dir / "contour_ruler_planar.toml", tmp_path / "an",
                    QUICK + ["task.contact=analytic", 'task.methods=["mesh", "subtaxel"]'])
    assert res["metrics"]["mesh_d_mean_mm"] < 7.5 and "image_d_mean_mm" not in res["metrics"]


def test_two_finger_press_outlines_each_finger(tmp_path, scenes_dir):
    res = run_scene(scenes_dir / "two_finger_press.toml", tmp_path / "tf")
    m = res["metrics"]
    assert m["edge_components"] == 2
    assert m["edge_taxels"] > m["pressed_taxels"] > 0


@pytest.mark.parametrize("override, key", [
    ("task.object=\"cup\"", "object"),
    ("task.step=-0.005", "step"),
    ("task.methods=[\"fourier\"]", "methods"),
    ("task.colour=1", "colour"),
])
def test_bad_contour_scenes_name_the_key(scenes_dir, override, key):
    with pytest.raises(SceneError, match=key):
        load_scene(scenes_dir / "contour_ruler_planar.toml", [override])


def test_inconsistent_mug_is_rejected(tmp_path, scenes_dir):
    with pytest.raises(SceneError, match="mug_inner_diameter"):
        run_scene(scenes_dir / "contour_mug_planar.toml", tmp_path / "x",
                  QUICK + ["task.mug_inner_diameter=0.09"])


@pytest.mark.parametrize("name", ["contour_ruler_planar", "contour_mug_planar", "contour_ruler_curved",
                                  "contour_mug_curved", "two_finger_press"])
def test_scenes_describe_their_cover_in_the_standard_layer_table(scenes_dir, name):
    s = load_scene(scenes_dir / f"{name}.toml")
    assert s["layer"] is not None and s["layer"]["thickness"] > 0
    for key in ("thickness", "material"):  # no longer task keys: one place for the layer
        with pytest.raises(SceneError, match=f"task.{key}"):
            load_scene(scenes_dir / f"{name}.toml", [f"task.{key}=0.006" if key == "thickness"
                                                     else f'task.{key}="ecoflex_00_50"'])


def test_contour_task_presses_through_the_layer_table(tmp_path, scenes_dir):
    args = QUICK + ["task.contact=analytic", 'task.methods=["mesh"]', "output.plots=false"]
    a = run_scene(scenes_dir / "contour_ruler_curved.toml", tmp_path / "a", args)
    b = run_scene(scenes_dir / "contour_ruler_curved.toml", tmp_path / "b",
                  args + ["layer.thickness=0.003", 'layer.material="dragon_skin_30"'])
    ra, rb = (tmp_path / "a" / "report.md").read_text(), (tmp_path / "b" / "report.md").read_text()
    assert "6 mm of ecoflex_00_50" in ra and "3 mm of dragon_skin_30" in rb
    assert "Deviation from seed 002: the cover" in ra
    # on the curved skin the analytic contact's pressure falls off over the layer thickness
    pa, pb = (np.load(tmp_path / x / "arrays.npz")["pressure"] for x in "ab")
    assert not (pa.shape == pb.shape and np.allclose(pa, pb))
    with pytest.raises(SceneError, match="layer.thickness"):
        run_scene(scenes_dir / "contour_ruler_planar.toml", tmp_path / "c", args + ["layer.thickness=0.0"])
