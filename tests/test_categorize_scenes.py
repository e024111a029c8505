"""Scenes of seed 001's category formation and the soft-layer designer (issue: categorize)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from vtcore.errors import SceneError
from vtcore.scene import load_scene, run_scene

SCENES = Path(__file__).resolve().parents[1] / "scenes"

SMALL = ["task.resolution_runs=4", "task.resolution_sizes=[1, 6, 60]", "task.trials=2", "task.readings=3",
         "task.jitter_seeds=0"]


@pytest.fixture(scope="module")
def run3(tmp_path_factory):
    out = tmp_path_factory.mktemp("cat3")
    return out, run_scene(SCENES / "category_3mm.toml", out, overrides=SMALL)


def test_layer_scene_reports_fig8_row_and_plots(run3):
    out, res = run3
    m = res["metrics"]
    for k in range(1, 8):
        a = m[f"accuracy_task{k}"]
        e = m[f"expected_accuracy_task{k}"]
        assert a is None or 0.5 <= a <= 1.0  # 4 objects: Eq. 7 never scores below 1/2
        assert 0.5 - 1e-9 <= e <= 1.0 + 1e-9
    assert m["thickness_mm"] == 3 and m["taxels"] == 60 and m["objects"] == 4
    for name in ("sphere", "cube", "halfcylinder", "cuboid"):
        assert abs(m[f"force_{name}_n"] - 10.0) < 0.1
    assert set(res["figures"]) >= {"tactile_images.png", "projection.png", "accuracy.png", "resolution.png"}
    report = (out / "report.md").read_text()
    assert "| 3 mm (simulated) |" in report and "| 3 mm (seed 001, Fig. 8) |" in report
    assert "Task 5 (edged vs round)" in report
    with np.load(out / "arrays.npz") as z:
        assert z["tactile_images"].shape == (4, 60)
        assert z["readings"].shape == (2, 4, 3, 60)
        assert z["projection"].shape == (4, 2) and np.isfinite(z["projection"]).all()
        assert z["resolution_accuracy"].shape == (3, 4, 7)
        assert abs(z["split_p_accepted"].sum() - 1.0) < 1e-9
        # one-taxel subsets run and give no NaN; the full patch reproduces the main result's split
        assert np.isfinite(z["resolution_accuracy"]).all()
    assert "resolution_s60_task5_accuracy_mean" in m


def test_layer_scene_is_reproducible(run3, tmp_path, scenes_dir):
    out, res = run3
    again = run_scene(scenes_dir / "category_3mm.toml", tmp_path, overrides=SMALL)
    assert again["metrics"] == res["metrics"]
    assert (tmp_path / "arrays.npz").read_bytes() == (out / "arrays.npz").read_bytes()


def test_noise_goes_through_the_pipeline(tmp_path, scenes_dir):
    """Without [effects.noise] the images are exactly the gain's transfer of the stress; with it they are not."""
    base = ["task.resolution_runs=0", "task.trials=1", "task.readings=2", "task.jitter_seeds=0",
            'effects.gain.profile=""', "effects.gain.counts_per_pa=1.0", "effects.gain.p_half=5000.0"]
    quiet = load_scene(scenes_dir / "category_10mm.toml", base)
    for name in ("noise", "quantisation"):
        quiet.effects.pop(name)  # the same table as quiet.data["effects"]
    res = run_scene(quiet, tmp_path / "quiet")
    g = quiet.effects["gain"]
    with np.load(tmp_path / "quiet" / "arrays.npz") as z:
        # the saturating transfer by hand; tension (p < 0) reads negative and the converter clips it to 0
        p = np.clip(z["object_pressure"], 0.0, None)
        expect = g["counts_per_pa"] * g["p_half"] * p / (p + g["p_half"])
        np.testing.assert_allclose(z["tactile_images"], expect, rtol=1e-12)
        assert (z["readings"][:, :, 0] == z["readings"][:, :, 1]).all()
    # saturation is listed; it is reported applied only where it clipped a reading (the effect contract)
    applied = [e["name"] for e in res["effects"]]
    assert applied[:2] == ["soft_layer", "gain"]
    assert sorted(applied + res["effects_not_applied"]) == ["gain", "saturation", "soft_layer"]
    noisy = run_scene(scenes_dir / "category_10mm.toml", tmp_path / "noisy", overrides=base)
    assert "noise" in [e["name"] for e in noisy["effects"]]
    with np.load(tmp_path / "noisy" / "arrays.npz") as z:
        assert (z["readings"][:, :, 0] != z["readings"][:, :, 1]).any()


def test_sweep_presses_each_object_once_per_thickness_and_writes_the_plot(tmp_path, scenes_dir, monkeypatch):
    import vtcore.contact as contact

    calls = []
    real = contact.press

    def counting(layout, mesh, pose, layer, **kw):
        calls.append(round(layer.thickness, 9))
        return real(layout, mesh, pose, layer, **kw)

    monkeypatch.setattr(contact, "press", counting)
    res = run_scene(scenes_dir / "category_variants.toml", tmp_path,
                    overrides=["task.thicknesses=[0.003, 0.010]", "task.repeats=3", "task.readings=3",
                               "task.trials=1", "task.variant_thicknesses=[0.010]",
                               "task.variant_p_halfs=[0, 5000]"])
    # the scene's own base (frictionless) at both thicknesses, plus the bonded variant at 10 mm
    assert sorted(calls) == [0.003] * 4 + [0.010] * 8
    assert "accuracy_vs_thickness.png" in res["figures"]
    assert (tmp_path / "accuracy_vs_thickness.png").stat().st_size > 10_000
    m = res["metrics"]
    for k in range(1, 8):
        assert 0.0 <= m["h3mm_task%d_solve_probability" % k] <= 1.0 + 1e-9
        assert 0.5 - 1e-9 <= m["h10mm_task%d_accuracy" % k] <= 1.0 + 1e-9
    report = (tmp_path / "report.md").read_text()
    assert "| 5 (edged vs round) |" in report and "solved by" in report
    assert "paper_task6_reproduced" in m and isinstance(m["paper_task6_reproduced"], bool)
    assert "### Model variants" in report and "| sliding / saturating, p_half 5 kPa | 10 mm |" in report
    assert "| bonded / linear | 10 mm |" in report and m["variants"] == 4
    with np.load(tmp_path / "arrays.npz") as z:
        assert z["variant_expected_accuracy"].shape == z["variant_solve_probability"].shape == (4, 1, 7)
        assert z["variant_frictionless"].tolist() == [False, False, True, True]
        assert z["variant_p_half"].tolist() == [0.0, 5000.0, 0.0, 5000.0]
        np.testing.assert_allclose(z["variant_solve_probability"].sum(axis=-1), 1.0, atol=1e-9)
    result = json.loads((tmp_path / "result.json").read_text())
    assert result["metrics"] == m


@pytest.mark.parametrize("override, key", [
    ("task.resolution_tasks=[9]", "task.resolution_tasks"),
    ("task.resolution_sizes=[61]", "task.resolution_sizes"),
    ("task.kmeans_runs=0", "task.kmeans_runs"),
    ("task.thickness=0.003", "task.thickness"),
])
def test_bad_task_values_name_the_key(tmp_path, scenes_dir, override, key):
    with pytest.raises(SceneError) as err:
        run_scene(scenes_dir / "category_3mm.toml", tmp_path, overrides=[override, "task.resolution_runs=1"])
    assert key in str(err.value) and "category_3mm.toml" in str(err.value)


def test_one_object_is_a_scene_error(tmp_path, scenes_dir):
    scene = load_scene(scenes_dir / "category_3mm.toml", ["task.resolution_runs=0"])
    scene.data["objects"] = scene.data["objects"][:1]
    with pytest.raises(SceneError, match="at least 2"):
        run_scene(scene, tmp_path)


def test_sweep_rejects_repeated_thicknesses(tmp_path, scenes_dir):
    with pytest.raises(SceneError, match="task.thicknesses"):
        run_scene(scenes_dir / "category_variants.toml", tmp_path, overrides=["task.thicknesses=[0.003, 0.003]"])


def test_identical_objects_give_a_degenerate_outcome_not_nan(tmp_path, scenes_dir):
    """Four identical spheres and no noise: identical tactile images, so no categories and no NaN."""
    scene = load_scene(scenes_dir / "category_10mm.toml", ["task.resolution_runs=2", "task.resolution_sizes=[1, 6]",
                                                           "task.trials=1", "task.readings=2"])
    for o in scene.data["objects"]:
        o.update(kind="sphere", radius=0.03, length=None, side=None)
    for name in ("noise", "quantisation"):
        scene.effects.pop(name)
    res = run_scene(scene, tmp_path)
    m = res["metrics"]
    assert m["formation_ok"] is False
    assert all(m[f"accuracy_task{k}"] is None for k in range(1, 8))  # undefined, reported as such
    assert m["resolution_s1_failed_runs"] == 2 and m["resolution_s6_failed_runs"] == 2
    assert "degenerate" in (tmp_path / "report.md").read_text()
    with np.load(tmp_path / "arrays.npz") as z:
        assert np.isfinite(z["projection"]).all() and (z["labels"] == -1).all()
