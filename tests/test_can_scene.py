"""The replay scenes, their example logs, and the ``can`` transport effect."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from vtcore.can import decode_log
from vtcore.can.examples import make_cyskin16_slide, make_icub_press
from vtcore.scene import run_scene

SCENES = Path(__file__).resolve().parents[1] / "scenes"


def test_example_logs_are_reproducible_and_small(tmp_path):
    make_cyskin16_slide(tmp_path / "a.log")
    make_icub_press(tmp_path / "b.asc")
    shipped = SCENES / "data"
    # byte for byte (the ASC header dates are the first frame's UTC time, not the writing time)
    assert (tmp_path / "a.log").read_bytes() == (shipped / "replay_cyskin16_slide.log").read_bytes()
    assert (tmp_path / "b.asc").read_bytes() == (shipped / "replay_icub_press.asc").read_bytes()
    for f in shipped.glob("replay_*"):
        assert f.stat().st_size < 200_000


def test_replay_scene_cyskin16(tmp_path):
    res = run_scene(SCENES / "replay_cyskin16_slide.toml", tmp_path)
    m = res["metrics"]
    # the injected faults, each counted by its reason
    assert m["rejected_unparsable_line"] == 3 and m["rejected_duplicate"] == 2 and m["rejected_out_of_order"] == 1
    assert m["frames_rejected"] == 6 and m["rows"] == 60 and m["unmapped_taxels"] == 0
    assert 0 < m["masked_samples"] <= 8       # one lost and one out-of-order frame: <= 4 channels each
    z = np.load(tmp_path / "arrays.npz")
    assert z["frames"].shape == z["edge"].shape == z["mask"].shape == (60, 60)
    assert z["edge"].any() and not z["edge"][:3].any()    # no edges before the sphere arrives
    assert json.loads((tmp_path / "result.json").read_text())["replay_summary"]["rejected"]["duplicate"] == 2
    assert "unparsable_line: 3" in (tmp_path / "report.md").read_text()


def test_replay_scene_icub_error_masked(tmp_path):
    res = run_scene(SCENES / "replay_icub_press.toml", tmp_path)
    m = res["metrics"]
    assert m["triangle_error_2_frames"] == 3 and m["frames_rejected"] == 0
    z = np.load(tmp_path / "arrays.npz")
    assert not z["mask"][30:33, 60:72].any() and z["mask"][:30].all()
    assert m["response_max"] > 100


@pytest.mark.parametrize("codec,step", [("icub", 4.0), ("cyskin16", 1.0)])
def test_can_transport_effect_quantises_like_the_wire(codec, step):
    from vtcore.scene.effects.can import CanTransport

    eff = CanTransport({"codec": codec, "period": 0.05}, None)
    rng = np.random.default_rng(0)
    counts = rng.uniform(0, 900, size=(5, 37))
    out = eff.apply(counts, None)
    assert out.shape == counts.shape
    assert np.all(np.abs(out - counts) <= step)
    assert np.all(np.mod(out, step) == 0)
    single = eff.apply(counts[0], None)
    np.testing.assert_array_equal(single, out[0])


def test_bench_quick_runs(tmp_path):
    from vtcore.can.bench import run

    rows = run(tmp_path, quick=True)
    assert {"table.md", "table.csv", "accuracy_vs_time.png"} <= {p.name for p in tmp_path.iterdir()}
    assert all(r["mismatched_samples"] == 0 for r in rows)
    assert {r["method"] for r in rows} >= {"vectorised", "reference_cantools"}


def test_decode_encode_decode_is_identity_with_errors(tmp_path):
    from vtcore.can import encode_to_log

    a = decode_log(SCENES / "data" / "replay_icub_press.asc", "icub")
    encode_to_log(a.arrays(), "icub", tmp_path / "again.blf")
    b = decode_log(tmp_path / "again.blf", "icub")
    np.testing.assert_array_equal(a.frames, b.frames)
    np.testing.assert_array_equal(a.mask, b.mask)
    np.testing.assert_array_equal(a.errors, b.errors)
    assert b.summary.triangle_errors == {2: 3}


def test_replay_scene_board_addresses(tmp_path):
    """``[task] boards``: the shipped iCub log is board 0; saying the layout is board 2 leaves every
    frame unmapped, counted and explained in the report instead of silently empty."""
    text = (SCENES / "replay_icub_press.toml").read_text()
    text = text.replace('log = "data/replay_icub_press.asc"',
                        f'log = "{(SCENES / "data" / "replay_icub_press.asc").as_posix()}"\nboards = [2]')
    scene = tmp_path / "board2.toml"
    scene.write_text(text)
    m = run_scene(scene, tmp_path / "out")["metrics"]
    assert m["unmapped_taxels"] == 72 and m["unmapped_frames"] == 720 and m["masked_fraction"] == 1.0
    report = (tmp_path / "out" / "report.md").read_text()
    assert "board 0: triangles 0-5 (72 taxels)" in report and "--boards" in report
