"""Seed 000 scenes: augmented bottles, path following, reaching in clutter.

Most tests switch the probe to the closed-form series model (``task.probe="series"``), which
is fast and gives a dense ground truth; one slow test runs the bottle scenes as written,
with the contact simulator's probe.
"""

from pathlib import Path

import numpy as np
import pytest

from vtcore.augment import read_ply_vertices
from vtcore.errors import SceneError
from vtcore.scene import run_scene

SCENES = Path(__file__).resolve().parents[1] / "scenes"
FAST = ['task.probe="series"']


@pytest.fixture(scope="module")
def bottles(tmp_path_factory):
    out = {}
    for name in ("empty_bottle", "full_bottle"):
        d = tmp_path_factory.mktemp(name)
        out[name] = (run_scene(SCENES / f"augment_{name}.toml", d, overrides=FAST), d)
    return out


def test_bottles_report_c_mean_and_empty_is_more_compliant(bottles):
    empty, full = bottles["empty_bottle"][0]["metrics"], bottles["full_bottle"][0]["metrics"]
    assert empty["touches"] == full["touches"] == 24
    assert empty["points"] == 33676
    assert 0 < empty["c_mean"] < full["c_mean"]
    for m in (empty, full):
        assert m["smooth_error_rel_pct"] < 30 and m["cluster_error_rel_pct"] < 30


def test_empty_bottle_writes_both_plys_and_the_figure(bottles):
    res, d = bottles["empty_bottle"]
    assert {"augmented_cluster.ply", "augmented_smooth.ply"} <= set(res["files"])
    assert "fig7_augmented.png" in res["figures"] and (d / "fig7_augmented.png").stat().st_size > 10_000
    arr = np.load(d / "arrays.npz")
    for name in ("cluster", "smooth"):
        ply = read_ply_vertices(d / f"augmented_{name}.ply")
        assert len(ply["x"]) == 33676
        np.testing.assert_allclose(ply["tactile_color"], arr[f"c_{name}"], rtol=1e-6)
        assert {"red", "green", "blue", "nx"} <= set(ply)
    # cluster colours take only the touches' values; smooth ones vary continuously
    assert len(np.unique(arr["c_cluster"])) <= 24 < len(np.unique(arr["c_smooth"]))


def test_rerun_is_byte_identical(bottles, tmp_path):
    _, d = bottles["empty_bottle"]
    run_scene(SCENES / "augment_empty_bottle.toml", tmp_path, overrides=FAST)
    assert (tmp_path / "arrays.npz").read_bytes() == (d / "arrays.npz").read_bytes()
    assert (tmp_path / "augmented_smooth.ply").read_bytes() == (d / "augmented_smooth.ply").read_bytes()


def test_vector_channels_and_bad_params(tmp_path):
    res = run_scene(SCENES / "augment_tennis_ball.toml", tmp_path,
                    overrides=FAST + ['task.channels=["compliance", "friction"]', "task.points=3000",
                                                 "output.plots=false"])
    assert res["arrays"]["c_smooth"] == [3000, 2]
    assert "friction" in read_ply_vertices(tmp_path / "augmented_smooth.ply")
    with pytest.raises(SceneError, match="task.beta"):
        run_scene(SCENES / "augment_tennis_ball.toml", tmp_path, overrides=["task.beta=300.0"])
    with pytest.raises(SceneError, match="task.object"):
        run_scene(SCENES / "augment_tennis_ball.toml", tmp_path, overrides=['task.object="teapot"'])


@pytest.mark.slow
def test_bottle_scenes_as_written_with_the_contact_probe(tmp_path):
    """Done-when of issue 6: both bottle scenes report c_mean, the empty one lower (contact simulator probe)."""
    m = {}
    for name in ("empty_bottle", "full_bottle"):
        res = run_scene(SCENES / f"augment_{name}.toml", tmp_path / name)
        m[name] = res["metrics"]
        assert [e["name"] for e in res["effects"]][:2] == ["soft_layer", "object_compliance"]
        assert m[name]["touches"] == 24 and np.isfinite(m[name]["c_mean"])
    assert m["empty_bottle"]["c_mean"] < m["full_bottle"]["c_mean"]
    assert (tmp_path / "empty_bottle" / "augmented_smooth.ply").exists()


def test_path_following_steps_vs_smooth(tmp_path):
    m = run_scene(SCENES / "path_following_bottle.toml", tmp_path)["metrics"]
    assert m["cluster_setpoint_steps"] >= 1 and m["smooth_setpoint_steps"] == 0
    assert m["smooth_setpoint_max_jump"] < 0.1 * m["cluster_setpoint_max_jump"]
    for k in ("cluster_tracking_error", "smooth_tracking_error"):
        assert 0 < m[k] < 200
    assert m["duration_s"] == pytest.approx(0.065 / 0.0015, rel=0.01)


def test_reach_clutter(tmp_path):
    out = run_scene(SCENES / "reach_clutter.toml", tmp_path)
    m = out["metrics"]
    controllers = ("augmented", "reactive", "impedance", "straight")
    assert all(m[f"{c}_reached"] for c in controllers)
    assert all(m[f"{c}_speed_max_m_s"] <= 0.02 * (1 + 1e-12) for c in controllers)
    assert m["augmented_pole_contact_max_n"] == 0 < m["reactive_pole_contact_max_n"]
    assert m["pole_colour"] > 5 * m["prism_colour"]
    assert m["pole_radius_eps_m"] == pytest.approx(0.07)
    assert {"reactive_intensity_excess_pct", "impedance_intensity_excess_pct",
            "augmented_slower_than_reactive_pct", "straight_intensity_excess_pct"} <= set(m)
    assert "| reactive intensity above augmented (%) |" in (tmp_path / "report.md").read_text()


def test_bench_quick(tmp_path):
    from vtcore.augment import bench

    rows = bench.run(tmp_path, quick=True)
    assert {"table.md", "table.csv", "accuracy_vs_time.png"} <= {p.name for p in tmp_path.iterdir()}
    methods = {r["method"] for r in rows}
    assert {"cluster", "smooth", "smooth truncated", "GP"} <= methods
    assert all(r["error_rel_pct"] is None or np.isfinite(r["error_rel_pct"]) for r in rows)


def test_user_cloud_from_ply_and_empty_cloud(tmp_path):
    from vtcore.augment import make_seed000_object, two_cameras, visual_cloud, write_ply

    ball = make_seed000_object("sponge_ball")
    pts, nrm = visual_cloud(ball.mesh, two_cameras(target=(0, 0, 0.035), width=240, height=180), rng=0)
    write_ply(tmp_path / "scan.ply", pts, normals=nrm)
    res = run_scene(SCENES / "augment_sponge_ball.toml", tmp_path / "run",
                    overrides=FAST + [f'task.cloud="{tmp_path / "scan.ply"}"', "output.plots=false"])
    assert res["metrics"]["points"] == len(pts)
    write_ply(tmp_path / "empty.ply", np.empty((0, 3)))
    with pytest.raises(SceneError, match="task.cloud.*empty"):
        run_scene(SCENES / "augment_sponge_ball.toml", tmp_path / "run2",
                  overrides=FAST + [f'task.cloud="{tmp_path / "empty.ply"}"'])


def test_recorded_probes_drive_the_cloud(tmp_path):
    """Probes from a file (CSV) replace the simulated ones; the colours follow the file."""
    pts = np.array([[0.0335, 0.0, 0.0335], [0.0, 0.0335, 0.0335], [0.0, 0.0, 0.067]])
    rows = ["x,y,z,p_mean,x_ss,y_ss,z_ss"] + [f"{a},{b},{c},4000,{a},{b},{c - 0.002}" for a, b, c in pts]
    (tmp_path / "probes.csv").write_text("\n".join(rows) + "\n")
    res = run_scene(SCENES / "augment_tennis_ball.toml", tmp_path / "run",
                    overrides=FAST + [f'task.probes="{tmp_path / "probes.csv"}"', "output.plots=false"])
    assert res["metrics"]["touches"] == 3
    assert res["metrics"]["c_mean"] == pytest.approx(2e6)
