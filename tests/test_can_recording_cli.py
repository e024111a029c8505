"""CySkin text recordings joined to a layout by UID, the CLI commands, and replay onto a virtual bus."""

from __future__ import annotations

import json

import numpy as np
import pytest

from vtcore.can import decode_log, encode, load_frames_npz, read_cyskin_txt, replay, write_log, Cyskin16Codec
from vtcore.cli import main
from vtcore.errors import FormatError
from vtcore.layout import save as save_layout

from test_can_helpers import hexagon_layout, press_counts


def _recording(tmp_path, layout, rng):
    """A recording whose columns are shuffled, with temperature channels, UIDs the layout lacks,
    and two layout taxels missing. Returns path, the truth in layout order, and the extras."""
    ids = layout.taxel_ids
    recorded = ids[2:]                                          # taxels 0, 1 not recorded
    extra = np.array([(7 << 4) | 3, (8 << 4) | 1])              # modules the layout lacks
    temps = np.array([1 << 4, 2 << 4])                          # sensor 0: temperature
    uids = np.r_[recorded, extra, temps]
    perm = rng.permutation(len(uids))
    uids = uids[perm]
    t = 15
    vals = rng.integers(0, 40000, size=(t, len(uids)))
    lines = [" ".join(map(str, uids)) + " \n"]
    for r in range(t):
        lines.append(f"{r} {r * 0.1:.3f} " + " ".join(map(str, vals[r])) + "\n")
    lines.insert(6, "5 0.450 1 2 3\n")                          # a short row
    path = tmp_path / "rec.txt"
    path.write_text("".join(lines))
    truth = np.zeros((t, len(ids)), np.int64)
    col = {int(u): j for j, u in enumerate(uids)}
    for i, tid in enumerate(ids):
        if int(tid) in col:
            truth[:, i] = vals[:, col[int(tid)]]
    return path, truth, extra, temps


def test_cyskin_txt_joined_by_uid(tmp_path):
    layout = hexagon_layout()
    path, truth, extra, temps = _recording(tmp_path, layout, np.random.default_rng(0))
    rec = read_cyskin_txt(path, layout=layout)
    np.testing.assert_array_equal(rec.taxel_ids, layout.taxel_ids)    # layout order
    assert rec.frames.shape == (15, 60)
    assert not rec.mask[:, :2].any() and rec.mask[:, 2:].all()
    np.testing.assert_array_equal(rec.frames[:, 2:], truth[:, 2:])
    r = rec.report
    assert r["unmatched_uids"] == sorted(extra.tolist())
    assert r["temperature_uids"] == sorted(temps.tolist())
    assert r["unrecorded_taxels"] == sorted(layout.taxel_ids[:2].tolist())
    assert r["rejected_lines"] == [{"line": 7, "reason": "5 fields, expected 64"}]
    np.testing.assert_allclose(rec.timestamps, np.arange(15) * 0.1)


def test_cyskin_txt_bad_header(tmp_path):
    (tmp_path / "b.txt").write_text("a b c\n0 0.0 1 2 3\n")
    with pytest.raises(FormatError, match="line 1"):
        read_cyskin_txt(tmp_path / "b.txt", taxel_ids=[17])
    (tmp_path / "e.txt").write_text("")
    with pytest.raises(FormatError):
        read_cyskin_txt(tmp_path / "e.txt", taxel_ids=[17])


def test_cli_recording_import(tmp_path, capsys):
    layout = hexagon_layout()
    lay = tmp_path / "hex.json"
    save_layout(layout, lay)
    path, truth, extra, _ = _recording(tmp_path, layout, np.random.default_rng(1))
    out = tmp_path / "rec.npz"
    rc = main(["recording", "import", str(path), "--format", "cyskin-txt", "--layout", str(lay),
               "--out", str(out), "--report", str(tmp_path / "rep.json")])
    assert rc == 0
    d = load_frames_npz(out)
    np.testing.assert_array_equal(d["taxel_ids"], layout.taxel_ids)
    np.testing.assert_array_equal(d["frames"][:, 2:], truth[:, 2:])
    rep = json.loads((tmp_path / "rep.json").read_text())
    assert rep["unmatched_uids"] == sorted(extra.tolist())
    assert "unmatched_uids: 2" in capsys.readouterr().out


@pytest.mark.parametrize("codec", ["icub", "cyskin16"])
def test_cli_decode_encode_roundtrip(tmp_path, codec, capsys):
    layout = hexagon_layout(icub=codec == "icub")
    ts, counts = press_counts(layout, peak_counts=200.0 if codec == "icub" else 20000.0)
    from vtcore.can import get_codec, icub_counts_to_wire

    wire = icub_counts_to_wire(counts) if codec == "icub" else np.clip(np.rint(counts), 0, 65535)
    log = tmp_path / "a.trc"
    write_log(log, encode(ts, wire, layout.taxel_ids, get_codec(codec)))
    out = tmp_path / "f.npz"
    assert main(["can", "decode", str(log), "--codec", codec, "--out", str(out)]) == 0
    d = load_frames_npz(out)
    np.testing.assert_array_equal(d["frames"], wire)                     # no layout: sorted by UID
    assert d["mask"].all()
    # encode FRAMES.npz back to a candump log and decode it again
    log2 = tmp_path / "b.log"
    assert main(["can", "encode", str(out), "--codec", codec, "--out", str(log2)]) == 0
    r = decode_log(log2, codec)
    np.testing.assert_array_equal(r.frames, wire)
    # with a layout file
    lay = tmp_path / "lay.json"
    save_layout(layout, lay)
    assert main(["can", "decode", str(log), "--codec", codec, "--layout", str(lay), "--out", str(out)]) == 0
    np.testing.assert_array_equal(load_frames_npz(out)["taxel_ids"], layout.taxel_ids)


def test_cli_errors_exit_2(tmp_path, capsys):
    assert main(["can", "decode", str(tmp_path / "none.log"), "--codec", "icub", "--out", str(tmp_path / "x.npz")]) == 2
    assert "not found" in capsys.readouterr().err
    assert main(["can", "decode", str(tmp_path / "x.xyz"), "--codec", "icub", "--out", str(tmp_path / "x.npz")]) == 2
    np.savez(tmp_path / "bad.npz", frames=np.full((2, 3), 300))
    assert main(["can", "encode", str(tmp_path / "bad.npz"), "--codec", "icub", "--out", str(tmp_path / "y.log")]) == 2
    assert "timestamps" in capsys.readouterr().err
    np.savez(tmp_path / "big.npz", frames=np.full((2, 3), 300), timestamps=[0, 1], taxel_ids=[0, 1, 2])
    assert main(["can", "encode", str(tmp_path / "big.npz"), "--codec", "icub", "--out", str(tmp_path / "y.log")]) == 2
    assert "wire range" in capsys.readouterr().err
    assert not (tmp_path / "y.log").exists()


def test_replay_onto_virtual_bus(tmp_path):
    import can

    layout = hexagon_layout()
    b = encode(np.arange(5) * 0.01, np.ones((5, 60)), layout.taxel_ids, Cyskin16Codec())
    log = tmp_path / "r.log"
    write_log(log, b)
    channel = f"vtcore-test-{tmp_path.name}"
    rx = can.Bus(interface="virtual", channel=channel)
    tx = can.Bus(interface="virtual", channel=channel)
    try:
        waits = []
        stats = replay(log, bus=tx, speed=2.0, sleep=waits.append, clock=lambda: 0.0)
        got = []
        while (m := rx.recv(timeout=0.2)) is not None:
            got.append(m)
    finally:
        rx.shutdown()
        tx.shutdown()
    assert stats["frames_sent"] == len(b) == len(got)
    assert [m.arbitration_id for m in got] == b.ids.tolist()
    assert [bytes(m.data) for m in got] == [b.data[i, :b.dlc[i]].tobytes() for i in range(len(b))]
    # scaled time: the last frame is due at (t_last - t_first) / speed
    assert max(waits) == pytest.approx((b.timestamps[-1] - b.timestamps[0]) / 2.0)


def test_cli_replay(tmp_path, capsys):
    layout = hexagon_layout()
    log = tmp_path / "r.asc"
    write_log(log, encode(np.arange(3) * 0.001, np.ones((3, 60)), layout.taxel_ids, Cyskin16Codec()))
    assert main(["can", "replay", str(log), "--channel", "vtcore-cli", "--speed", "0"]) == 0
    assert "sent 54 frames" in capsys.readouterr().out
