"""The evaluate task's outputs as a user opens them: maps.ply in trimesh, result.json, report.md."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from vtcore.scene import run_scene

SCENES = Path(__file__).resolve().parents[1] / "scenes"


@pytest.fixture(scope="module")
def hexagon_run(tmp_path_factory):
    out = tmp_path_factory.mktemp("eval") / "hex"
    res = run_scene(SCENES / "evaluate_hexagon.toml", out, ["task.spacing=0.004", "task.draws=8",
                                                           "task.two_point_spacing=0.008"])
    return out, res


def test_maps_ply_reads_back_with_its_values(hexagon_run):
    import trimesh

    from vtcore.layout import seed001_disc

    out, res = hexagon_run
    m = trimesh.load(out / "maps.ply", process=False)
    disc, _ = seed001_disc()
    # the disc's fan faces are split to the spacing; its own vertices come first, unmoved
    assert len(m.vertices) > 5 * len(disc.vertices) and len(m.faces) > len(disc.faces)
    np.testing.assert_allclose(m.vertices[:len(disc.vertices)], disc.vertices, atol=1e-6)
    assert np.isclose(m.area, disc.area, rtol=1e-5)
    v = m.metadata["_ply_raw"]["vertex"]["data"]
    for name in ("threshold_n", "localisation_mm", "two_point_mm", "detect_rate", "blind", "evaluated", "covered"):
        assert name in v.dtype.names
    assert np.all(np.isfinite(v["threshold_n"])) and v["threshold_n"].min() > 0
    ev = v["evaluated"].astype(bool)
    assert ev.any() and (~ev).any()  # the disc's far side is beyond the margin
    assert np.all(v["blind"][~ev] == 1)
    # the covered top carries the threshold map's colours (not the grey of unevaluated surface)
    rgb = m.visual.vertex_colors[:, :3].astype(int)
    assert len({tuple(c) for c in rgb[ev & v["covered"].astype(bool)]}) > 5


def test_result_json_and_report(hexagon_run):
    out, res = hexagon_run
    r = json.loads((out / "result.json").read_text())
    m = r["metrics"]
    assert m["taxels_live"] == 60 and m["samples"] > 100
    assert 0 < m["threshold_covered_median_n"] <= m["threshold_covered_p95_n"]
    assert m["blind_area_cm2"] >= m["blind_area_covered_cm2"] >= 0
    assert "maps.ply" in r["files"] and {"histograms.png", "maps.png"} <= set(r["figures"])
    text = (out / "report.md").read_text()
    assert "| Detection threshold | covered | N |" in text and "sensor profile 'cyskin'" in text
    a = np.load(out / "arrays.npz")
    assert a["sample_threshold_n"].shape == a["sample_areas"].shape
    np.testing.assert_allclose(a["sample_areas"].sum() * 1e4, m["evaluated_area_cm2"], rtol=1e-9)


def test_bad_settings_name_the_key(tmp_path):
    from vtcore.errors import SceneError

    with pytest.raises(SceneError, match="task.probe_length"):
        run_scene(SCENES / "evaluate_hexagon.toml", tmp_path / "x", ["task.probe=\"sphere\"", "task.probe_length=0.03"])
    with pytest.raises(SceneError, match="task.taxels"):
        run_scene(SCENES / "evaluate_hexagon.toml", tmp_path / "y", ["task.taxels=100"])


def test_no_plots_builds_no_figure(tmp_path):
    """``output.plots = false``: the maps are computed, no figure is drawn and left open (the runner
    closes only the figures it saves: a sweep or a fuzz run in one process piled them up, and drawing
    them was 85 % of a small design's time)."""
    from vtcore.plots import pyplot

    plt = pyplot()
    plt.close("all")
    run_scene(SCENES / "evaluate_hexagon.toml", tmp_path / "o", ["task.spacing=0.01", "task.draws=2",
                                                                  "task.two_point=false", "output.plots=false"])
    assert plt.get_fignums() == []
    assert (tmp_path / "o" / "maps.ply").exists() and not list((tmp_path / "o").glob("*.png"))
