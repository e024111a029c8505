"""The soft finger's fit (vtcore.calibrate.finger_fit) and its command, vtcore calibrate-finger."""

import numpy as np
import pytest

from vtcore.calibrate.finger_fit import grid_points, peak_table, score
from vtcore.calibrate.validate import Validation
from vtcore.cli import main


def _validation(sim_shift=0.0):
    rng = np.random.default_rng(0)
    k = 40
    rec = np.repeat(np.arange(8), 5)
    real = rng.uniform(1.0, 2.0, size=(k, 3))
    stats = {m: rng.uniform(1.0, 2.0, size=k) for m in ("ring1", "ring2", "active", "minor_mm")}
    sim = {m: v + sim_shift for m, v in stats.items()}
    return Validation(real=real, sim=real, pressure=real, force=np.ones(k), compression=np.zeros(k), recording=rec,
                      frame=np.arange(k), held_out=rec >= 6, baselines=np.zeros((8, 3)), paths=list("abcdefgh"),
                      real_metrics=stats, sim_metrics=sim)


def test_the_score_is_zero_on_a_perfect_model_and_grows_with_the_shift():
    assert score(_validation(0.0)) == pytest.approx(0.0)
    assert 0 < score(_validation(0.1)) < score(_validation(0.3))
    # resampled recordings: the same score when every recording is drawn once
    v = _validation(0.2)
    assert score(v, np.arange(8)) == pytest.approx(score(v))


def test_peak_table_reports_fitted_and_held_out_recordings_apart():
    rows = peak_table(_validation(0.0))
    assert [r["group"] for r in rows] == ["fitted"] * 4 + ["held out"] * 4
    assert [r["recordings"] for r in rows] == [6] * 4 + [2] * 4
    assert all(r["within"] for r in rows)       # the simulated statistics are the recorded ones


def test_grid_points_cover_every_combination():
    pts = grid_points({"a": (1, 2), "b": (3,), "c": (4, 5, 6)})
    assert len(pts) == 6 and {"a": 2, "b": 3, "c": 6} in pts


def test_the_command_needs_recordings_held_out(tmp_path, capsys):
    rec = tmp_path / "a.txt"
    rec.write_text("1 2\n0 0.0 0 0\n")
    lay = tmp_path / "missing.json"
    assert main(["calibrate-finger", str(rec), "--layout", str(lay), "--out", str(tmp_path / "o")]) == 2
    assert "--holdout" in capsys.readouterr().err


@pytest.mark.slow
def test_the_command_fits_on_some_recordings_and_reports_the_held_out_apart(tmp_path):
    import json
    import os
    from pathlib import Path

    shared = Path(os.environ.get("VTCORE_SHARED_DATA", Path(__file__).resolve().parents[2] / "shared" / "data"))
    data = shared / "cyskin_gesture"
    if not data.is_dir():
        pytest.skip("the shared CySkin recordings are not beside the repository")
    out = tmp_path / "fit"
    recs = [str(data / "1_finger" / f"sample_0{i}.txt") for i in (1, 2)]
    held = str(data / "1_finger" / "sample_12.txt")
    assert main(["calibrate-finger", *recs, "--holdout", held, "--layout",
                 str(data / "curved_gesture_patch_full_isomap.json"), "--quick", "--out", str(out)]) == 0
    doc = json.loads((out / "finger_fit.json").read_text())
    assert len(doc["points"]) == len(doc["scores"]) == 2 and doc["best"] in doc["points"]
    assert doc["held_out"] == [str(Path(held).resolve())] and len(doc["fitted"]) == 2
    groups = [r["group"] for r in doc["table"]]
    assert groups.count("fitted") == 4 and groups.count("held out") == 4
    assert all(r["real_q25"] <= r["real_median"] <= r["real_q75"] for r in doc["table"])
    assert (out / "by_force.png").exists() and (out / "report.md").exists()
