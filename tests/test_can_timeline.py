"""Recordings on a timeline (vtcore.can.timeline): frame mapping, held lost samples, baselines,
edges batched over frames, the mismatch report, and bad input (wrong codec, huge spans)."""

from __future__ import annotations

import numpy as np
import pytest

from vtcore.can import Cyskin16Codec, encode, get_codec, icub_counts_to_wire, write_log
from vtcore.can.timeline import baseline_first, frame_rows, hold, load_recording, quiet_window
from vtcore.cli import main
from vtcore.errors import InputError
from vtcore.filters import edge_filter
from vtcore.layout import Layout, save as save_layout, skin_mesh

from test_can_helpers import hexagon_layout, press_counts


def test_hold_keeps_last_good_value():
    v = np.array([[1.0, 5], [2, 6], [3, 7], [4, 8]])
    m = np.array([[False, True], [True, False], [False, False], [True, True]])
    np.testing.assert_array_equal(hold(v, m), [[0, 5], [2, 5], [2, 5], [4, 8]])


def test_frame_rows_at_scene_rate_and_own_rate():
    ts = 100.0 + np.arange(11) * 0.05                       # 20 Hz, 0.5 s
    rows = frame_rows(ts, 24.0)
    assert len(rows) == 13                                  # frames at 0, 1/24, ..., 12/24 s
    expect = [int(np.floor(k / 24 / 0.05 + 1e-9)) for k in range(13)]
    np.testing.assert_array_equal(rows, expect)
    np.testing.assert_array_equal(frame_rows(ts, None), np.arange(11))
    # time going backwards: a row counts at the running maximum, frames never go back
    back = np.array([0.0, 0.1, 0.05, 0.2])
    r = frame_rows(back, 10.0)
    assert np.all(np.diff(r) >= 0) and r[-1] == 3
    with pytest.raises(InputError, match="fps"):
        frame_rows(ts, 0.0)


def test_baselines_first_and_quiet():
    rng = np.random.default_rng(0)
    t, n = 40, 5
    counts = 1000 + rng.normal(0, 1, (t, n))
    counts[:10] += rng.normal(0, 300, (10, n))              # a busy start: the quiet window is later
    mask = np.ones((t, n), bool)
    assert quiet_window(counts, 8) >= 10 - 1
    b = baseline_first(counts, mask, 3)
    np.testing.assert_allclose(b, np.median(counts[:3], axis=0))
    mask[:2, 0] = False                                     # taxel 0's first three are rows 2..4
    assert baseline_first(counts, mask, 3)[0] == pytest.approx(np.median(counts[2:5, 0]))


def _cyskin_log(tmp_path, layout, lose=()):
    ts, counts = press_counts(layout, t=12, peak_counts=20000.0)
    wire = np.clip(np.rint(counts + 3000.0), 0, 65535)   # a baseline of 3000 counts
    mask = np.ones(wire.shape, bool)
    for r, c in lose:
        mask[r, c] = False
    log = tmp_path / "press.log"
    write_log(log, encode(ts, wire, layout.taxel_ids, Cyskin16Codec(), mask=mask))
    return log, ts, wire, mask


def test_cyskin16_log_on_the_timeline(tmp_path):
    layout = hexagon_layout()
    # a cyskin16 frame carries sensors 0-3, 4-7 or 8-11 of a module: columns 0-2 are sensors 1-3
    # of the first module (one frame), columns 3-6 its sensors 4-7 (the next)
    lose = [(r, c) for r in (5, 6) for c in range(3)] + [(7, c) for c in range(3, 7)]
    log, ts, wire, mask = _cyskin_log(tmp_path, layout, lose=lose)
    rep = load_recording(log, layout, kind="cyskin16", fps=None, baseline_rows=2, edge_fraction=0.3,
                         min_response=200.0)
    assert rep.counts.shape == (12, 60) and rep.lost_rows == 3 and rep.lost_samples == 10
    held = hold(wire, mask)
    np.testing.assert_allclose(rep.counts, held, atol=0.5)
    assert rep.counts[6, 1] == wire[4, 1] and rep.held[6, 1] and not rep.held[6, 4]
    base = np.median(wire[:2], axis=0)
    np.testing.assert_allclose(rep.response, np.clip(held - base, 0, None), atol=0.5)
    np.testing.assert_allclose(rep.edge_response, edge_filter(skin_mesh(layout), rep.response.astype(float)),
                               rtol=1e-4, atol=1e-3)
    assert rep.edge.any() and not rep.edge[0].any()
    assert rep.rate_hz == pytest.approx(20.0, rel=1e-3)
    assert rep.recording_only == [] and rep.layout_only == []
    # at 24 fps the 0.55 s recording spans 14 frames, each showing the last row before its time
    rep24 = load_recording(log, layout, kind="cyskin16", fps=24.0, baseline_rows=2)
    np.testing.assert_array_equal(rep24.rows, frame_rows(rep24.timestamps, 24.0))
    np.testing.assert_allclose(rep24.timestamps, ts, atol=0.005)  # a row is at its earliest frame
    np.testing.assert_array_equal(rep24.counts, rep.counts[rep24.rows])
    assert rep24.lost_frames == int(np.isin(rep24.rows, [5, 6, 7]).sum())


def test_mismatch_both_ways(tmp_path):
    layout = hexagon_layout()
    log, *_ = _cyskin_log(tmp_path, layout)
    keep = np.arange(6, 60)                                 # the skin lacks 6 recorded taxels ...
    extra = np.array([(9 << 4) | 1, (9 << 4) | 2])          # ... and has 2 never recorded
    sub = Layout(np.r_[layout.positions[keep], [[0.1, 0, 0], [0.11, 0, 0]]],
                 np.r_[layout.normals[keep], [[0, 0, 1.0], [0, 0, 1]]],
                 np.r_[layout.taxel_ids[keep], extra], np.r_[layout.module_ids[keep], [9, 9]])
    rep = load_recording(log, sub, kind="cyskin16", fps=None)
    assert rep.recording_only == sorted(layout.taxel_ids[:6].tolist())
    assert rep.layout_only == sorted(extra.tolist())
    lines = rep.mismatch()
    assert lines[0].startswith("6 recorded taxel(s) the layout lacks")
    assert lines[1].startswith("2 of 56 layout taxel(s) never in the recording")
    assert rep.lost_rows == 0  # never-recorded taxels are a mismatch, not lost samples


def test_icub_log_by_board_address(tmp_path):
    layout = hexagon_layout(icub=True)                       # ids of board 1
    ts, counts = press_counts(layout, peak_counts=200.0)
    log = tmp_path / "icub.asc"
    write_log(log, encode(ts, icub_counts_to_wire(counts), layout.taxel_ids, get_codec("icub")))
    rep = load_recording(log, layout, kind="icub", fps=None, baseline_rows=1)
    from vtcore.can import icub_wire_to_counts

    expect = icub_wire_to_counts(icub_counts_to_wire(counts))
    np.testing.assert_allclose(rep.counts, expect, atol=1e-3)
    # the same file read as a board-0 skin: nothing matches, a clear error naming the file
    board0 = Layout(layout.positions, layout.normals, np.arange(60), layout.module_ids)
    with pytest.raises(InputError, match="icub.asc.*no sample of the recording reached any"):
        load_recording(log, board0, kind="icub", fps=None)


def test_cyskin_txt_recording(tmp_path):
    layout = hexagon_layout()
    ids = layout.taxel_ids
    rng = np.random.default_rng(3)
    vals = rng.integers(0, 500, (8, 60))
    lines = [" ".join(map(str, ids[::-1])) + "\n"]            # columns in another order
    lines += [f"{r} {r * 0.01:.2f} " + " ".join(map(str, vals[r, ::-1])) + "\n" for r in range(8)]
    (tmp_path / "rec.txt").write_text("".join(lines))
    rep = load_recording(tmp_path / "rec.txt", layout, kind="cyskin-txt", fps=None, baseline_rows=1)
    np.testing.assert_array_equal(rep.counts, vals)
    np.testing.assert_array_equal(rep.response, np.clip(vals - vals[0], 0, None))


def test_wrong_codec_and_huge_span_are_clear_errors(tmp_path, monkeypatch):
    layout = hexagon_layout()
    log, *_ = _cyskin_log(tmp_path, layout)
    with pytest.raises(InputError, match="right codec"):
        load_recording(log, layout, kind="icub")
    # a recording whose clock jumps a day: 24 fps would need 2 million frames x 60 taxels
    far = tmp_path / "far.txt"
    rows = [f"{r} {t} " + " ".join(["100"] * 60) for r, t in enumerate((0.0, 0.05, 86400.0))]
    far.write_text(" ".join(map(str, layout.taxel_ids)) + "\n" + "\n".join(rows) + "\n")
    monkeypatch.setenv("VTCORE_MEMORY_BUDGET", "64M")
    with pytest.raises(InputError, match="fps: 2073601 frames x 60 taxels.*memory budget"):
        load_recording(far, layout, kind="cyskin-txt", fps=24.0)
    assert len(load_recording(far, layout, kind="cyskin-txt", fps=None).rows) == 3


def test_recording_import_prints_the_mismatch(tmp_path, capsys):
    layout = hexagon_layout()
    lay = tmp_path / "hex.json"
    save_layout(layout, lay)
    ids = layout.taxel_ids[3:]
    uids = np.r_[ids, [(9 << 4) | 1]]
    rows = [f"{r} {r * 0.1:.1f} " + " ".join(["7"] * len(uids)) for r in range(3)]
    (tmp_path / "r.txt").write_text(" ".join(map(str, uids)) + "\n" + "\n".join(rows) + "\n")
    assert main(["recording", "import", str(tmp_path / "r.txt"), "--format", "cyskin-txt", "--layout", str(lay),
                 "--out", str(tmp_path / "o.npz")]) == 0
    out = capsys.readouterr().out
    assert "1 recorded taxel(s) the layout lacks (e.g. [145])" in out
    assert "3 of 60 layout taxel(s) never in the recording" in out
