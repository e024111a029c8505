"""Simulated press -> encode -> log file -> decode, for both codecs and every log format;
vectorised decoding against the python-can + cantools per-message reference."""

from __future__ import annotations

import numpy as np
import pytest

from vtcore.can import (FORMATS, Cyskin16Codec, FrameBatch, IcubCodec, decode_batches, decode_log, encode,
                        icub_counts_to_wire, icub_wire_to_counts, read_log, write_log)

from test_can_helpers import hexagon_layout, press_counts


@pytest.mark.parametrize("fmt", FORMATS)
@pytest.mark.parametrize("codec_name", ["icub", "cyskin16"])
def test_press_encode_log_decode(tmp_path, fmt, codec_name):
    layout = hexagon_layout(icub=codec_name == "icub")
    ts, counts = press_counts(layout, peak_counts=1200.0 if codec_name == "icub" else 30000.0)
    codec = IcubCodec() if codec_name == "icub" else Cyskin16Codec()
    if codec_name == "icub":
        wire = icub_counts_to_wire(counts)
    else:
        wire = np.clip(np.rint(counts), 0, 65535).astype(np.uint16)
    log = tmp_path / f"press{fmt}"
    write_log(log, encode(ts, wire, layout.taxel_ids, codec))
    res = decode_log(log, codec_name, layout=layout)
    assert res.summary.rejected_total == 0
    assert res.frames.shape == counts.shape
    assert res.mask.all()
    np.testing.assert_array_equal(res.taxel_ids, layout.taxel_ids)
    np.testing.assert_array_equal(res.frames, wire)
    # timing survives (asc/trc/blf store times relative to the first frame)
    np.testing.assert_allclose(np.diff(res.timestamps), 0.05, atol=2e-3)
    if codec_name == "icub":
        back = icub_wire_to_counts(res.frames)
        ok = (counts >= -60) & (counts < 240 * 4)          # not clipped on the wire
        assert ok.mean() > 0.9 and (~ok).any()             # the test covers saturation too
        err = counts - back
        assert np.all((err[ok] >= 0) & (err[ok] < 4))      # quantisation: 2**shift counts
        assert np.all(res.frames[counts >= 960] == 0)      # saturated presses read 0
    else:
        c = np.clip(counts, 0, 65535)
        assert np.abs(res.frames - c).max() <= 0.5 + 1e-9  # rounding to integer counts


def test_icub_quantisation_functions():
    counts = np.arange(-100, 1100)
    wire = icub_counts_to_wire(counts)
    assert wire.dtype == np.uint8 and wire.max() == 255 and wire.min() == 0
    assert wire[counts == 0][0] == 240                     # NOLOAD at rest
    back = icub_wire_to_counts(wire)
    inside = (counts >= -60) & (counts < 960)
    assert np.all((counts - back)[inside] >= 0) and np.all((counts - back)[inside] < 4)


def _messages(batch):
    return list(batch.to_messages())


@pytest.mark.parametrize("codec_name", ["icub", "cyskin16"])
def test_vectorised_matches_cantools_reference(codec_name):
    """Every accepted frame's channels decode identically through cantools, one message at a time."""
    layout = hexagon_layout(icub=codec_name == "icub")
    codec = IcubCodec() if codec_name == "icub" else Cyskin16Codec()
    rng = np.random.default_rng(3)
    wire = rng.integers(0, codec.wire_max + 1, size=(6, len(layout)))
    batch = encode(np.arange(6) * 0.05, wire, layout.taxel_ids, codec)
    keys, reason = codec.classify(batch)
    assert (reason < 0).all()
    vals = codec.values(batch)
    pres = codec.present(batch, keys)
    ch = codec.channel_ids(keys)
    for i, msg in enumerate(_messages(batch)):
        key, ref, _err = codec.reference_decode(msg)
        assert key == keys[i]
        mine = {int(c): int(v) for c, v, p in zip(ch[i], vals[i], pres[i]) if p and c >= 0}
        assert mine == ref
    # and the full decode equals the reference assembled by hand
    res = decode_batches(batch, codec, taxel_ids=layout.taxel_ids)
    np.testing.assert_array_equal(res.frames, wire)


def test_cyskin16_ten_taxel_module_sends_dlc6():
    layout = hexagon_layout()
    codec = Cyskin16Codec()
    batch = encode([0.0], np.ones((1, len(layout))), layout.taxel_ids, codec)
    last = (batch.ids & 0xF) == 8
    assert np.all(batch.dlc[last] == 6) and np.all(batch.dlc[~last] == 8)
    assert np.all(batch.extended)
    # identifiers carry the UID of the frame's first channel: module << 4 | sensor
    assert set(np.unique((batch.ids.astype(np.int64) - 0x18000000) >> 4)) == set(range(1, 7))


def test_icub_error_and_outofrange_encoding():
    codec = IcubCodec()
    ids = 192 * 2 + np.arange(24)  # board 2, triangles 0 and 1
    batch = encode([0.0, 0.05], np.full((2, 24), 100), ids, codec, errors={(1, 2 * 16 + 1): 2})
    err, oor = codec.diagnostics(batch, codec.classify(batch)[0])
    assert sorted(err.tolist()) == [-1, -1, -1, -1, 0, 0, 0, 2]
    assert batch.ids.max() == (4 << 8) | (2 << 4) | 1


def test_identifiers_and_headers_follow_the_protocol():
    codec = IcubCodec()
    batch = encode([0.0], np.full((1, 12), 7), icub_taxel_ids := 192 * 3 + 12 * 5 + np.arange(12), codec)
    assert len(batch) == 2
    assert set(batch.ids.tolist()) == {0x435}
    assert sorted(batch.data[:, 0].tolist()) == [0x40, 0xC0]
    first = batch.data[batch.data[:, 0] == 0x40][0]
    np.testing.assert_array_equal(first[1:8], 7)
    res = decode_batches(batch, codec)
    np.testing.assert_array_equal(res.taxel_ids, icub_taxel_ids)


def test_frame_batch_messages_roundtrip():
    b = FrameBatch([0.5, 1.0], [0x123, 0x1ABCDEF0], [False, True], [3, 8],
                   np.arange(16, dtype=np.uint8).reshape(2, 8) * [[1] * 3 + [0] * 5, [1] * 8])
    back = FrameBatch.from_messages(list(b.to_messages()))
    for f in ("timestamps", "ids", "extended", "dlc", "data"):
        np.testing.assert_array_equal(getattr(back, f), getattr(b, f))


def test_read_log_of_written_frames_identical(tmp_path):
    layout = hexagon_layout()
    b = encode(np.arange(3) * 0.05, np.ones((3, 60)) * 5, layout.taxel_ids, Cyskin16Codec())
    for fmt in FORMATS:
        write_log(tmp_path / f"a{fmt}", b)
        r = read_log(tmp_path / f"a{fmt}")
        np.testing.assert_array_equal(r.data, b.data)
        np.testing.assert_array_equal(r.ids, b.ids)
        np.testing.assert_array_equal(r.dlc, b.dlc)


def test_frame_batch_from_messages_mixed_lengths_and_fd():
    """Short, empty, full and over-long (CAN FD) payloads land in the right rows; FD cut at 8."""
    import can

    msgs = [can.Message(timestamp=0.1 * i, arbitration_id=0x400 + i, is_extended_id=False, data=bytes(d))
            for i, d in enumerate([[1, 2, 3], [], list(range(10, 18)), [9] * 6])]
    msgs.append(can.Message(timestamp=0.5, arbitration_id=0x18000011, is_extended_id=True, is_fd=True,
                            data=bytes(range(40, 52))))
    b = FrameBatch.from_messages(msgs)
    np.testing.assert_array_equal(b.dlc, [3, 0, 8, 6, 8])
    np.testing.assert_array_equal(b.extended, [False] * 4 + [True])
    np.testing.assert_array_equal(b.ids, [0x400, 0x401, 0x402, 0x403, 0x18000011])
    np.testing.assert_allclose(b.timestamps, [0.0, 0.1, 0.2, 0.3, 0.5])
    expect = np.zeros((5, 8), np.uint8)
    expect[0, :3] = [1, 2, 3]
    expect[2] = range(10, 18)
    expect[3, :6] = 9
    expect[4] = range(40, 48)
    np.testing.assert_array_equal(b.data, expect)
