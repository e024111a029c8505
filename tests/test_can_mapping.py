"""Mapping decoded taxels onto layouts: iCub board addresses of positions files (``--boards``,
``meta["icub_boards"]``, ``can_ids``), taxels the layout lacks, and UIDs a layout repeats."""

from __future__ import annotations

import numpy as np
import pytest

from vtcore.can import (Cyskin16Codec, IcubCodec, decode_batches, decode_log, describe_icub_ids, encode,
                        icub_board_ids, layout_taxel_ids, load_frames_npz, read_cyskin_txt, write_log)
from vtcore.cli import main
from vtcore.errors import InputError
from vtcore.layout import Layout
from vtcore.layout import load as load_layout
from vtcore.layout import save as save_layout

from test_can_helpers import hexagon_layout


def _positions_file(tmp_path, rows, name="board.txt"):
    """An iCub positions file with taxels at ``rows`` (other slots all-zero rows); loaded back."""
    rows = np.asarray(rows)
    n = len(rows)
    pos = np.column_stack([(rows % 12) * 0.005, (rows // 12) * 0.005, np.zeros(n)])   # distinct, metres
    lay = Layout(pos, np.tile([0.0, 0.0, 1.0], (n, 1)), rows, rows // 12, meta={"id_scheme": "icub"})
    path = tmp_path / name
    save_layout(lay, path, format="icub")
    out = load_layout(path, format="icub", units="m")
    np.testing.assert_array_equal(out.taxel_ids, rows)       # a positions file: taxel id = row
    return path, out


def _icub_log(tmp_path, wire_ids, t=6, name="b.log", seed=0):
    wire = np.random.default_rng(seed).integers(0, 256, (t, len(wire_ids)))
    path = tmp_path / name
    write_log(path, encode(1700000000.0 + np.arange(t) * 0.05, wire, wire_ids, IcubCodec()))
    return path, wire


def test_icub_board_ids():
    rows = np.array([0, 11, 191, 192, 383])
    np.testing.assert_array_equal(icub_board_ids(rows, [14, 13]), [14 * 192, 14 * 192 + 11, 14 * 192 + 191,
                                                                    13 * 192, 13 * 192 + 191])
    with pytest.raises(InputError, match="block 1"):
        icub_board_ids(rows, [3])
    with pytest.raises(InputError, match="0..15"):
        icub_board_ids(rows, [3, 16])
    with pytest.raises(InputError, match="twice"):
        icub_board_ids(rows, [3, 3])


def test_positions_file_of_board_3(tmp_path):
    rows = np.arange(60)                                     # triangles 0..4 of the file
    _, layout = _positions_file(tmp_path, rows)
    log, wire = _icub_log(tmp_path, 3 * 192 + rows)          # the skin is on board 3
    # without the board address: nothing maps, and the summary says why
    r0 = decode_log(log, "icub", layout=layout)
    assert not r0.mask.any()
    assert r0.summary.unmapped_frames == 6 * 10 and r0.summary.unmapped_samples == 6 * 60
    assert "board(s) [3]" in " ".join(r0.summary.notes) and "--boards" in " ".join(r0.summary.notes)
    assert "board 3: triangles 0-4 (60 taxels)" in r0.summary.text()
    # with it: every taxel in layout order
    r = decode_log(log, "icub", layout=layout, boards=[3])
    assert r.mask.all() and r.summary.rejected_total == 0 and not r.summary.unmapped_taxel_ids
    np.testing.assert_array_equal(r.frames, wire)
    np.testing.assert_array_equal(r.taxel_ids, 3 * 192 + rows)
    np.testing.assert_array_equal(r.extra["layout_taxel_ids"], rows)


def test_two_board_file_and_missing_taxels_reported(tmp_path):
    """Rows 0..191 are board 14 and 192..383 board 13; the log also has board 2 and a triangle
    of board 13 the file lacks: those frames are counted and named."""
    rows = np.r_[np.arange(24), 192 + np.arange(36)]           # board 14 tri 0-1, board 13 tri 0-2
    _, layout = _positions_file(tmp_path, rows)
    wire_ids = np.r_[14 * 192 + np.arange(24), 13 * 192 + np.arange(48), 2 * 192 + np.arange(12)]
    log, wire = _icub_log(tmp_path, wire_ids)
    r = decode_log(log, "icub", layout=layout, boards=[14, 13])
    assert r.mask.all()
    np.testing.assert_array_equal(r.frames, wire[:, :60])
    s = r.summary
    assert sorted(s.unmapped_taxel_ids) == sorted(wire_ids[60:].tolist())
    assert s.unmapped_frames == 6 * 4 and s.unmapped_samples == 6 * 24
    assert "board 2: triangle 0 (12 taxels); board 13: triangle 3 (12 taxels)" in s.text()
    assert s.metrics()["unmapped_frames"] == 24
    with pytest.raises(InputError, match="one address per 192-row block"):
        decode_log(log, "icub", layout=layout, boards=[14])


def test_boards_from_layout_meta_and_can_ids(tmp_path):
    rows = np.arange(36)
    _, layout = _positions_file(tmp_path, rows)
    log, wire = _icub_log(tmp_path, 5 * 192 + rows)
    layout.meta["icub_boards"] = [5]
    save_layout(layout, tmp_path / "l.json")                  # the mapping travels with the layout
    again = load_layout(tmp_path / "l.json")
    np.testing.assert_array_equal(layout_taxel_ids(again, "icub"), 5 * 192 + rows)
    r = decode_log(log, "icub", layout=again)
    np.testing.assert_array_equal(r.frames, wire)
    # the explicit option wins over the meta
    assert not decode_log(log, "icub", layout=again, boards=[4]).mask.any()
    # per-taxel CAN addresses (board << 4 | triangle) instead
    del layout.meta["icub_boards"]
    layout.can_ids = (5 << 4) | (rows // 12)
    np.testing.assert_array_equal(decode_log(log, "icub", layout=layout).frames, wire)
    # board addresses mean nothing to cyskin16, and nothing without a layout
    with pytest.raises(InputError, match="icub codec only"):
        layout_taxel_ids(hexagon_layout(), "cyskin16", boards=[1])
    with pytest.raises(InputError, match="need a layout"):
        decode_log(log, "icub", boards=[5])


def test_cli_boards(tmp_path, capsys):
    rows = np.arange(24)
    path, _ = _positions_file(tmp_path, rows)
    log, wire = _icub_log(tmp_path, 3 * 192 + rows, name="c.asc")
    out = tmp_path / "f.npz"
    assert main(["can", "decode", str(log), "--codec", "icub", "--layout", str(path), "--boards", "3",
                 "--out", str(out)]) == 0
    d = load_frames_npz(out)
    np.testing.assert_array_equal(d["frames"], wire)
    np.testing.assert_array_equal(d["taxel_ids"], 3 * 192 + rows)
    np.testing.assert_array_equal(d["layout_taxel_ids"], rows)
    capsys.readouterr()
    assert main(["can", "decode", str(log), "--codec", "icub", "--layout", str(path), "--out", str(out)]) == 0
    assert "board 3: triangles 0-1 (24 taxels)" in capsys.readouterr().out
    assert main(["can", "decode", str(log), "--codec", "icub", "--layout", str(path), "--boards", "3,99",
                 "--out", str(out)]) == 2
    assert "0..15" in capsys.readouterr().err


def test_describe_icub_ids():
    ids = np.r_[192 * 3 + np.arange(12 * 3), 192 * 3 + 12 * 7 + 4, 5]
    assert describe_icub_ids(ids) == "board 0: triangle 0 (1 taxels); board 3: triangles 0-2, 7 (37 taxels)"


def _with_repeats(layout, dup_of):
    """``layout`` plus extra taxels that repeat the ids at ``dup_of`` (other positions)."""
    idx = np.r_[np.arange(len(layout)), dup_of]
    out = layout.subset(idx)
    out.positions = out.positions + np.r_[np.zeros(len(layout)), np.ones(len(dup_of))][:, None] * [0, 0, 0.01]
    return out


@pytest.mark.parametrize("chunk", [5, 65536])
def test_repeated_layout_uids_all_receive_the_data(tmp_path, chunk):
    layout = hexagon_layout()
    rep = _with_repeats(layout, [0, 0, 17, 59])                 # id 0 three times in all
    wire = np.random.default_rng(2).integers(0, 65536, (8, 60))
    batch = encode(np.arange(8) * 0.05, wire, layout.taxel_ids, Cyskin16Codec())
    drop = np.flatnonzero(batch.ids == batch.ids[0])[3]         # one frame of module 1 lost (row 3)
    path = tmp_path / "r.log"
    write_log(path, batch.take(np.setdiff1d(np.arange(len(batch)), [drop])))
    r = decode_log(path, "cyskin16", layout=rep, chunk=chunk)
    assert r.frames.shape == (8, 64)
    np.testing.assert_array_equal(r.taxel_ids, rep.taxel_ids)
    expect = wire[:, [*range(60), 0, 0, 17, 59]]
    np.testing.assert_array_equal(r.frames[r.mask], expect[r.mask])
    lost = ~r.mask
    assert lost[3, [0, 1, 2, 60, 61]].all() and lost.sum() == 5  # sensors 1..3 of module 1 and both copies
    assert r.summary.shared_taxel_ids == sorted(layout.taxel_ids[[0, 17, 59]].tolist())
    assert "receives that id's samples" in r.summary.text()
    assert r.summary.masked_samples == 5 and not r.summary.unmapped_taxel_ids
    # encode (first column of a repeated id) -> decode gives the same
    from vtcore.can import encode_to_log

    encode_to_log(r.arrays(), "cyskin16", tmp_path / "again.csv")
    r2 = decode_log(tmp_path / "again.csv", "cyskin16", layout=rep)
    np.testing.assert_array_equal(r2.frames, r.frames)
    np.testing.assert_array_equal(r2.mask, r.mask)


def test_repeated_icub_ids_and_triangle_errors():
    ids = 192 + np.arange(24)
    lay_ids = np.r_[ids, ids[:12]]                               # triangle 0 of board 1 twice
    wire = np.full((4, 24), 100)
    b = encode(np.arange(4) * 0.05, wire, ids, IcubCodec(), errors={(2, 16): 2})
    r = decode_batches(b, IcubCodec(), taxel_ids=lay_ids)
    assert r.frames.shape == (4, 36) and np.all(r.frames[r.mask] == 100)
    assert not r.mask[2, :12].any() and not r.mask[2, 24:].any() and r.mask.sum() == 4 * 36 - 24


def test_recording_repeated_layout_uids(tmp_path):
    layout = hexagon_layout()
    rep = _with_repeats(layout, [5, 5])
    uids = layout.taxel_ids[::-1]
    vals = np.arange(3 * 60).reshape(3, 60)
    lines = [" ".join(map(str, uids)) + "\n"] + [f"{r} {r * 0.1} " + " ".join(map(str, vals[r])) + "\n"
                                                  for r in range(3)]
    (tmp_path / "r.txt").write_text("".join(lines))
    rec = read_cyskin_txt(tmp_path / "r.txt", layout=rep)
    assert rec.mask.all() and rec.frames.shape == (3, 62)
    np.testing.assert_array_equal(rec.frames[:, 60], rec.frames[:, 5])
    np.testing.assert_array_equal(rec.frames[:, 61], rec.frames[:, 5])
    np.testing.assert_array_equal(rec.frames[:, :60], vals[:, ::-1])
    assert rec.report["shared_layout_uids"] == [int(layout.taxel_ids[5])]
    assert rec.report["matched_uids"] == 60 and rec.report["unmatched_uids"] == []
