"""Hard cases of CAN logs: truncated, garbage, unknown ids, short DLC, duplicates, time going
backwards, erroring triangles, streamed logs far larger than a chunk, empty logs, 1% corruption."""

from __future__ import annotations

import numpy as np
import pytest

from vtcore.can import (FORMATS, Cyskin16Codec, FrameBatch, IcubCodec, StreamDecoder, Summary, decode_batches,
                        decode_log, encode, iter_batches, read_log, write_log)

from test_can_helpers import hexagon_layout

ICUB_IDS = 192 * 1 + np.arange(60)   # board 1, triangles 0..4


def _icub_log(tmp_path, t=40, name="clean.log", seed=0):
    rng = np.random.default_rng(seed)
    wire = rng.integers(0, 256, size=(t, 60))
    batch = encode(1700000000.0 + np.arange(t) * 0.05, wire, ICUB_IDS, IcubCodec())
    path = tmp_path / name
    write_log(path, batch)
    return path, wire


def _lines(path):
    return path.read_text().splitlines(keepends=True)


def _write(path, lines):
    path.write_text("".join(lines))
    return path


def _same_elsewhere(r0, r1, lost_cells):
    """r1 equals r0 except ``lost_cells`` more masked samples."""
    assert r1.frames.shape == r0.frames.shape
    assert np.all(r1.mask <= r0.mask)
    np.testing.assert_array_equal(r1.frames[r1.mask], r0.frames[r1.mask])
    assert int((r0.mask & ~r1.mask).sum()) == lost_cells


def test_clean_log_baseline(tmp_path):
    path, wire = _icub_log(tmp_path)
    r = decode_log(path, "icub")
    np.testing.assert_array_equal(r.frames, wire)
    np.testing.assert_array_equal(r.taxel_ids, ICUB_IDS)
    assert r.summary.frames_read == r.summary.frames_used == 40 * 10
    assert abs(r.summary.period_s - 0.05) < 1e-6


def test_garbage_lines_are_counted_and_skipped(tmp_path):
    path, wire = _icub_log(tmp_path)
    lines = _lines(path)
    junk = ["hello world\n", "(abc) vcan0 141#40\n", "\x00\xff\xfe garbage\n", "(1700000000.1) vcan0 1G1#4000\n",
            "(1700000000.1) vcan0 141#40F0F0F0F0F0F0F\n"]   # odd number of hex digits
    for i, j in enumerate(junk):
        lines.insert(30 + 37 * i, j)
    r = decode_log(_write(tmp_path / "g.log", lines), "icub")
    rej = r.summary.rejected
    assert rej["unparsable_line"] + rej["malformed_frame"] == 5
    assert rej["malformed_frame"] == 1                          # the odd-hex line parses to dlc != len(data)
    assert r.summary.rejected_total == 5
    np.testing.assert_array_equal(r.frames, wire)
    assert r.mask.all()
    # line numbers point at the inserted lines
    assert 31 in r.summary.examples["unparsable_line"]


def test_truncated_text_log(tmp_path):
    path, wire = _icub_log(tmp_path)
    text = path.read_text()
    cut = text[: len(text) - 9]                       # inside the last line's payload
    r0 = decode_log(path, "icub")
    r = decode_log(_write(tmp_path / "cut.log", [cut]), "icub")
    assert r.summary.rejected_total == 1
    assert r.summary.rejected["short_dlc"] + r.summary.rejected["unparsable_line"] + \
        r.summary.rejected["malformed_frame"] == 1
    _same_elsewhere(r0, r, lost_cells=5)              # last frame: a 0xC0 frame of 5 taxels


def test_truncated_blf(tmp_path):
    layout = hexagon_layout()
    wire = np.random.default_rng(1).integers(0, 65536, (400, 60))
    batch = encode(np.arange(400) * 0.05, wire, layout.taxel_ids, Cyskin16Codec())
    path = tmp_path / "x.blf"
    write_log(path, batch)
    data = path.read_bytes()
    cut = tmp_path / "cut.blf"
    cut.write_bytes(data[: int(len(data) * 0.6)])
    r0 = decode_log(path, "cyskin16", layout=layout)
    r = decode_log(cut, "cyskin16", layout=layout)
    s = r.summary
    assert s.rejected["truncated"] > 0
    assert s.frames_used + s.rejected["truncated"] == len(batch)   # every announced frame accounted for
    t = len(r.timestamps)
    assert 0 < t < 400
    np.testing.assert_array_equal(r.frames[r.mask], r0.frames[:t][r.mask])


def test_unknown_identifiers(tmp_path):
    path, wire = _icub_log(tmp_path)
    lines = _lines(path)
    extra = ["(1700000000.010000) vcan0 123#0102030405060708 R\n",        # class 1
             "(1700000000.020000) vcan0 18000011#0102030405060708 R\n",   # extended
             "(1700000000.030000) vcan0 541#40F0F0F0F0F0F0F0 R\n"]        # class 5
    r = decode_log(_write(tmp_path / "u.log", lines[:5] + extra + lines[5:]), "icub")
    assert r.summary.rejected["unknown_id"] == 3 and r.summary.rejected_total == 3
    np.testing.assert_array_equal(r.frames, wire)


def test_short_dlc(tmp_path):
    path, wire = _icub_log(tmp_path)
    lines = _lines(path)
    # line 0 is the 0x40 frame of triangle 0 in row 0: cut it to 5 bytes
    head, rest = lines[0].split("#")
    lines[0] = head + "#" + rest[:10] + " R\n"
    # a 0xC0 frame of 6 bytes is valid (no diagnostics)
    i = next(k for k, ln in enumerate(lines) if "#C0" in ln and k > 20)
    head, rest = lines[i].split("#")
    lines[i] = head + "#" + rest[:12] + " R\n"
    r0 = decode_log(path, "icub")
    r = decode_log(_write(tmp_path / "s.log", lines), "icub")
    assert r.summary.rejected == {**r.summary.rejected, "short_dlc": 1}
    assert r.summary.rejected_total == 1
    _same_elsewhere(r0, r, lost_cells=7)
    assert not r.mask[0, :7].any() and r.mask[0, 7:].all()


def test_duplicated_frames(tmp_path):
    path, wire = _icub_log(tmp_path)
    lines = _lines(path)
    dup = [5, 17, 100, 101, 399]
    out = []
    for k, ln in enumerate(lines):
        out.append(ln)
        if k in dup:
            out.append(ln)
    r = decode_log(_write(tmp_path / "d.log", out), "icub")
    assert r.summary.rejected["duplicate"] == len(dup) and r.summary.rejected_total == len(dup)
    np.testing.assert_array_equal(r.frames, wire)
    assert r.mask.all()


def test_timestamps_going_backwards(tmp_path):
    path, wire = _icub_log(tmp_path)
    lines = _lines(path)
    r0 = decode_log(path, "icub")
    k = 205                                            # a frame in the middle
    ts = float(lines[k][1:lines[k].index(")")])
    lines[k] = f"({ts - 1.0:.6f})" + lines[k][lines[k].index(")") + 1:]
    r = decode_log(_write(tmp_path / "b.log", lines), "icub")
    assert r.summary.rejected["out_of_order"] == 1 and r.summary.rejected_total == 1
    half = 7 if "#40" in lines[k] else 5
    _same_elsewhere(r0, r, lost_cells=half)
    # rows are not shifted: every other sample stays in its row
    np.testing.assert_allclose(r.timestamps, r0.timestamps)


def test_missing_frame_is_masked_not_shifted(tmp_path):
    path, wire = _icub_log(tmp_path)
    lines = _lines(path)
    # drop every frame of triangle 2 (both halves) in rows 10..12
    drop = {k for k, ln in enumerate(lines) if " 412#" in ln}
    drop = set(sorted(drop)[20:26])
    r = decode_log(_write(tmp_path / "m.log", [ln for k, ln in enumerate(lines) if k not in drop]), "icub")
    assert r.frames.shape == wire.shape
    cols = slice(24, 36)
    assert not r.mask[10:13, cols].any()
    assert r.mask[:10, cols].all() and r.mask[13:, cols].all()
    np.testing.assert_array_equal(r.frames[r.mask], wire[r.mask])
    assert r.summary.masked_samples == 36 and r.summary.rejected_total == 0


def test_triangle_reporting_an_error(tmp_path):
    wire = np.full((6, 60), 200)
    batch = encode(np.arange(6) * 0.05, wire, ICUB_IDS, IcubCodec(), errors={(3, 16 + 2): 2, (4, 16 + 0): 1})
    path = tmp_path / "e.log"
    write_log(path, batch)
    r = decode_log(path, "icub")
    assert r.summary.triangle_errors == {2: 1, 1: 1}
    assert not r.mask[3, 24:36].any() and not r.mask[4, 0:12].any()
    assert r.mask.sum() == 6 * 60 - 24
    np.testing.assert_array_equal(r.errors, [[3, 18, 2], [4, 16, 1]])


def test_one_percent_corrupted_lines(tmp_path):
    """1% corrupted lines: everything else decodes identically; rejections counted exactly, by reason."""
    path, wire = _icub_log(tmp_path, t=200)
    lines = _lines(path)
    rng = np.random.default_rng(7)
    bad = np.sort(rng.choice(len(lines), size=len(lines) // 100, replace=False))
    lost, expect = 0, {"unparsable_line": 0, "short_dlc": 0, "unknown_id": 0}
    for j, k in enumerate(bad):
        ln = lines[k]
        lost += 7 if "#40" in ln else 5
        kind = j % 3
        if kind == 0:                                   # bytes replaced by noise
            lines[k] = "".join(chr(c) for c in rng.integers(33, 126, len(ln) - 1)) + "\n"
            expect["unparsable_line"] += 1
        elif kind == 1:                                 # line cut inside the payload (even digits)
            lines[k] = ln[: ln.index("#") + 7] + "\n"
            expect["short_dlc"] += 1
        else:                                           # a flipped identifier bit
            head, rest = ln.split("#")
            lines[k] = head[:-3] + "5" + head[-2:] + "#" + rest
            expect["unknown_id"] += 1
    r0 = decode_log(path, "icub")
    r = decode_log(_write(tmp_path / "c.log", lines), "icub")
    got = {k: v for k, v in r.summary.rejected.items() if v}
    assert got == {k: v for k, v in expect.items() if v}
    assert r.summary.rejected_total == len(bad) == 20
    _same_elsewhere(r0, r, lost_cells=lost)
    assert r.summary.frames_used + r.summary.rejected_total - expect["unparsable_line"] == r.summary.frames_read


@pytest.mark.parametrize("fmt", FORMATS)
def test_empty_log(tmp_path, fmt):
    path = tmp_path / f"empty{fmt}"
    write_log(path, FrameBatch.empty())
    r = decode_log(path, "cyskin16")
    assert r.frames.shape == (0, 0) and r.timestamps.shape == (0,) and r.mask.shape == (0, 0)
    assert r.summary.frames_read == 0
    assert "no frames" in r.summary.text()


def test_empty_file_candump(tmp_path):
    (tmp_path / "z.log").write_text("")
    r = decode_log(tmp_path / "z.log", "icub", layout=hexagon_layout(icub=True))
    assert r.frames.shape == (0, 60)


def test_chunking_does_not_change_results(tmp_path):
    path, wire = _icub_log(tmp_path, t=60)
    lines = _lines(path)
    lines.insert(50, lines[49])                         # a duplicate
    lines.insert(200, "junk\n")
    p = _write(tmp_path / "k.log", lines)
    a = decode_log(p, "icub", chunk=65536)
    b = decode_log(p, "icub", chunk=7)
    np.testing.assert_array_equal(a.frames, b.frames)
    np.testing.assert_array_equal(a.mask, b.mask)
    np.testing.assert_array_equal(a.timestamps, b.timestamps)
    assert a.summary.as_dict() == b.summary.as_dict()


def test_streamed_log_far_larger_than_a_chunk_in_bounded_memory():
    """A generator of 1.2 M frames: the decoder pulls input lazily and holds only a window of rows."""
    layout = hexagon_layout()
    codec = Cyskin16Codec()
    keys = codec.streams_for(layout.taxel_ids)          # 18 frames per period
    rows_per_chunk = 2000
    n_chunks = 34
    pulled = []

    def source():
        base = encode(np.arange(rows_per_chunk) * 0.05, np.zeros((rows_per_chunk, 60)), layout.taxel_ids, codec)
        for c in range(n_chunks):
            pulled.append(c)
            b = FrameBatch(base.timestamps + c * rows_per_chunk * 0.05, base.ids, base.extended, base.dlc,
                           base.data.copy())
            b.data[:, 2:4] = np.frombuffer(np.uint16(c).tobytes(), np.uint8)  # sensor 1 carries the chunk number
            yield b

    dec = StreamDecoder(codec, taxel_ids=layout.taxel_ids, window=8)
    total_rows, seen, checks = 0, 0, 0
    for b in source():
        seen += len(b)
        out = dec.feed(b)
        assert len(pulled) == seen // (rows_per_chunk * len(keys))   # lazy: one chunk at a time
        if out is not None:
            total_rows += len(out.timestamps)
            col = np.flatnonzero(out.taxel_ids == ((1 << 4) | 1))[0]
            expect = (out.row0 + np.arange(len(out.timestamps))) // rows_per_chunk
            np.testing.assert_array_equal(out.frames[:, col], expect)
            checks += 1
        assert dec.max_pending_rows <= rows_per_chunk + 8 + 1
    last = dec.finish()
    total_rows += len(last.timestamps)
    assert seen == n_chunks * rows_per_chunk * len(keys) > 1_000_000
    assert total_rows == n_chunks * rows_per_chunk and checks == n_chunks
    assert dec.summary.frames_used == seen and dec.summary.masked_samples == 0


def test_file_streaming_yields_bounded_chunks(tmp_path):
    path, wire = _icub_log(tmp_path, t=100)
    lines = _lines(path)
    lines.insert(123, "garbage\n")
    p = _write(tmp_path / "f.log", lines)
    s = Summary()
    sizes = [len(b) for b in iter_batches(p, chunk=64, summary=s)]
    assert max(sizes) <= 64 and sum(sizes) == 1000
    assert s.rejected["unparsable_line"] == 1 and s.lines_read == 1001
    r = decode_batches(iter_batches(p, chunk=64), IcubCodec())
    np.testing.assert_array_equal(r.frames, wire)


def test_layout_lacking_taxels_is_reported(tmp_path):
    layout = hexagon_layout()
    wire = np.full((3, 60), 1000)
    batch = encode(np.arange(3) * 0.05, wire, layout.taxel_ids, Cyskin16Codec())
    path = tmp_path / "l.csv"
    write_log(path, batch)
    small = layout.subset(np.arange(50))                # module 6 missing from the layout
    r = decode_log(path, "cyskin16", layout=small)
    assert r.frames.shape == (3, 50) and r.mask.all()
    assert sorted(r.summary.unmapped_taxel_ids) == sorted(layout.taxel_ids[50:].tolist())
    assert r.summary.unmapped_samples == 30
    # a layout taxel the log lacks stays masked
    big_ids = np.r_[layout.taxel_ids, (9 << 4) | 1]
    r2 = decode_batches(batch, Cyskin16Codec(), taxel_ids=big_ids)
    assert r2.mask[:, :60].all() and not r2.mask[:, 60].any()


def test_mixed_unknown_only_log(tmp_path):
    p = _write(tmp_path / "o.log", ["(1.0) vcan0 123#01\n", "(1.1) vcan0 124#01\n"])
    r = decode_log(p, "icub")
    assert r.frames.shape == (0, 0) and r.summary.rejected["unknown_id"] == 2


def test_out_of_window_late_frame_counted():
    layout = hexagon_layout()
    codec = Cyskin16Codec()
    b = encode(np.arange(30) * 0.05, np.ones((30, 60)), layout.taxel_ids, codec)
    # every frame of one stream arrives after everything else (a delayed bus): placed by
    # time, those whose rows closed (older than the newest row - window + 1) are late
    one = np.flatnonzero(b.ids == b.ids[0])
    order = np.r_[np.setdiff1d(np.arange(len(b)), one), one]
    r = decode_batches(b.take(order), codec, taxel_ids=layout.taxel_ids, window=4)
    assert r.summary.rejected["late"] == 26 and r.summary.rejected_total == 26
    assert (~r.mask).sum() == 26 * 3                    # sensors 1..3 of module 1 in rows 0..25
    assert not r.mask[:26, :3].any() and r.mask[26:].all()


@pytest.mark.parametrize("fmt", [".asc", ".trc", ".csv"])
def test_one_percent_garbage_in_every_text_format(tmp_path, fmt):
    """1% of the frame lines replaced by noise: the rest decodes identically, each line counted."""
    layout = hexagon_layout()
    wire = np.random.default_rng(5).integers(0, 65536, (120, 60))
    path = tmp_path / f"clean{fmt}"
    write_log(path, encode(1700000000.0 + np.arange(120) * 0.05, wire, layout.taxel_ids, Cyskin16Codec()))
    lines = _lines(path)
    clean = decode_log(path, "cyskin16", layout=layout)
    frame_lines = [k for k, ln in enumerate(lines) if "8000" in ln and not ln.startswith((";", "/"))]
    assert len(frame_lines) == 120 * 18
    rng = np.random.default_rng(11)
    bad = rng.choice(frame_lines, size=len(frame_lines) // 100, replace=False)
    frames = read_log(path)                           # which frame each line held
    by_line = dict(zip(frames.lines.tolist(), frames.ids.tolist()))
    # taxels per frame: S00 carries the temperature + 3 taxels, S04 4, S08 3 (DLC 6)
    lost = sum(4 if by_line[int(k) + 1] & 0xF == 4 else 3 for k in bad)
    for k in bad:
        lines[k] = "X" + "".join(chr(c) for c in rng.integers(33, 126, 40)) + "\n"
    r = decode_log(_write(tmp_path / f"bad{fmt}", lines), "cyskin16", layout=layout)
    assert r.summary.rejected_total == r.summary.rejected["unparsable_line"] == len(bad)
    assert np.all(r.mask <= clean.mask)
    np.testing.assert_array_equal(r.frames[r.mask], clean.frames[r.mask])
    assert int((clean.mask & ~r.mask).sum()) == lost



@pytest.mark.parametrize("seed", range(4))
def test_random_losses_duplicates_and_jitter(seed):
    """Random frame losses, duplicates and timing jitter: every kept frame lands in its own row."""
    rng = np.random.default_rng(seed)
    codec = IcubCodec()
    t = 80
    wire = rng.integers(0, 256, (t, 60))
    b = encode(np.arange(t) * 0.05, wire, ICUB_IDS, codec)
    b.timestamps += rng.uniform(-0.008, 0.008, len(b))            # bus jitter, well under a period
    row_of = np.repeat(np.arange(t), 10)
    lost = rng.random(len(b)) < 0.05
    lost[:10] = False                                              # keep row 0 complete (time origin)
    dup = (rng.random(len(b)) < 0.03) & ~lost
    idx = np.sort(np.r_[np.flatnonzero(~lost), np.flatnonzero(dup)], kind="stable")
    # streams stay in time order (jitter could swap two frames of one stream only if > period)
    r = decode_batches(b.take(idx), codec, taxel_ids=ICUB_IDS, window=4)
    assert r.summary.rejected["duplicate"] == dup.sum() and r.summary.rejected_total == dup.sum()
    expect = np.ones((t, 60), bool)
    keys, _ = codec.classify(b)
    half = keys & 1
    tri = (keys >> 1) & 0xF
    for i in np.flatnonzero(lost):                                 # a handful of frames
        cols = 12 * tri[i] + (np.arange(7) if half[i] == 0 else np.arange(7, 12))
        expect[row_of[i], cols] = False
    n_rows = len(r.timestamps)
    np.testing.assert_array_equal(r.mask, expect[:n_rows])
    np.testing.assert_array_equal(r.frames[r.mask], wire[:n_rows][r.mask])
    assert n_rows >= t - 1


def _shift_line(line, dt):
    ts = float(line[1:line.index(")")])
    return f"({ts + dt:.6f})" + line[line.index(")") + 1:]


@pytest.mark.parametrize("k", [0, 1, 205, 206, 399])
@pytest.mark.parametrize("chunk", [7, 65536])
def test_lone_forward_clock_jump_does_not_poison_the_stream(tmp_path, k, chunk):
    """One frame 100 s in the future (first, middle and last lines; any chunking): only that
    frame is lost, counted as clock_jump; every later frame of its stream is still used."""
    path, wire = _icub_log(tmp_path)
    lines = _lines(path)
    r0 = decode_log(path, "icub")
    half = 7 if "#40" in lines[k] else 5
    lines[k] = _shift_line(lines[k], 100.0)
    r = decode_log(_write(tmp_path / "j.log", lines), "icub", chunk=chunk)
    assert r.summary.rejected["clock_jump"] == 1 and r.summary.rejected_total == 1
    assert r.summary.examples["clock_jump"] == [k + 1]
    _same_elsewhere(r0, r, lost_cells=half)
    np.testing.assert_allclose(r.timestamps, r0.timestamps)


def test_run_of_forward_outliers_on_several_streams(tmp_path):
    path, wire = _icub_log(tmp_path)
    lines = _lines(path)
    r0 = decode_log(path, "icub")
    lost = 0
    for k, dt in ((150, 30.0), (151, 30.0), (152, 31.0), (300, 5.0)):   # 5 s = 100 periods
        lost += 7 if "#40" in lines[k] else 5
        lines[k] = _shift_line(lines[k], dt)
    r = decode_log(_write(tmp_path / "j.log", lines), "icub")
    assert r.summary.rejected["clock_jump"] == 4 and r.summary.rejected_total == 4
    _same_elsewhere(r0, r, lost_cells=lost)


def test_small_forward_step_is_not_a_clock_jump(tmp_path):
    """A frame a few periods late in time (within the window) stays an ordinary frame: it lands
    in its own later row and the stream's following frames are out of order, as before."""
    path, wire = _icub_log(tmp_path)
    lines = _lines(path)
    lines[205] = _shift_line(lines[205], 0.05 * 3)
    r = decode_log(_write(tmp_path / "s.log", lines), "icub")
    assert r.summary.rejected["clock_jump"] == 0
    assert r.summary.rejected["out_of_order"] + r.summary.rejected["duplicate"] >= 1


def test_genuine_gap_becomes_masked_rows(tmp_path):
    """Frames missing for 10 periods (more than the window), then the clock continues: the
    periods are masked rows, nothing is rejected."""
    path, wire = _icub_log(tmp_path)
    lines = _lines(path)
    r = decode_log(_write(tmp_path / "g.log", lines[:100] + lines[200:]), "icub")
    assert r.summary.rejected_total == 0
    assert r.frames.shape == wire.shape
    assert not r.mask[10:20].any() and r.mask[:10].all() and r.mask[20:].all()
    np.testing.assert_array_equal(r.frames[r.mask], wire[r.mask])
    np.testing.assert_allclose(np.diff(r.timestamps), 0.05, atol=1e-3)
    assert r.summary.masked_samples == 10 * 60


@pytest.mark.parametrize("chunk", [7, 65536])
def test_logger_clock_jumps_forward_for_good(tmp_path, chunk):
    """Every frame from line 200 on is 100 s later (a clock that really jumped, or the bus
    silent for 100 s): the jump is a gap of masked rows, not rejected frames."""
    path, wire = _icub_log(tmp_path)
    lines = _lines(path)
    lines = lines[:200] + [_shift_line(ln, 100.0) for ln in lines[200:]]
    r = decode_log(_write(tmp_path / "g.log", lines), "icub", chunk=chunk)
    assert r.summary.rejected_total == 0
    assert r.frames.shape == (40 + 2000, 60)
    assert r.mask[:20].all() and not r.mask[20:2020].any() and r.mask[2020:].all()
    np.testing.assert_array_equal(r.frames[2020:], wire[20:])
    assert r.timestamps[2020] - r.timestamps[19] == pytest.approx(100.05, abs=1e-3)


def test_clock_jumps_and_gaps_independent_of_chunking(tmp_path):
    """With the period given, chunks are decoded as they come (no 4096-frame hold): outliers at
    chunk edges, a genuine gap and a jump on the last line decode the same for every chunking."""
    path, wire = _icub_log(tmp_path, t=60)
    lines = _lines(path)
    for k in (0, 6, 7, 8, 131, 299, 300, 599):
        lines[k] = _shift_line(lines[k], 50.0)
    lines = lines[:400] + lines[450:]                      # 5 periods lost (under the window)
    lines = lines[:500] + [_shift_line(ln, 2.0) for ln in lines[500:]]   # the clock moves on 40 periods
    p = _write(tmp_path / "k.log", lines)
    ref = decode_log(p, "icub", period=0.05, chunk=65536)
    s = ref.summary
    assert s.rejected["clock_jump"] == 8 and s.rejected_total == 8
    assert ref.frames.shape[0] == 60 + 40
    for chunk in (1, 2, 3, 4, 7, 50):
        r = decode_log(p, "icub", period=0.05, chunk=chunk)
        np.testing.assert_array_equal(r.frames, ref.frames)
        np.testing.assert_array_equal(r.mask, ref.mask)
        np.testing.assert_array_equal(r.timestamps, ref.timestamps)
        assert r.summary.as_dict() == s.as_dict()


def test_absurd_gap_is_a_clear_error_not_a_memory_error(tmp_path, capsys):
    """Every frame from line 201 on is 10^6 s later (2*10^7 periods): masking that gap would need
    20 M rows; the decoder says so, naming the file and line, instead of exhausting memory."""
    from vtcore.cli import main
    from vtcore.errors import InputError

    path, wire = _icub_log(tmp_path)
    lines = _lines(path)
    p = _write(tmp_path / "far.log", lines[:200] + [_shift_line(ln, 1e6) for ln in lines[200:]])
    with pytest.raises(InputError, match="decode its parts separately") as err:
        decode_log(p, "icub")
    assert err.value.line == 201 and err.value.file == str(p)
    assert main(["can", "decode", str(p), "--codec", "icub", "--out", str(tmp_path / "x.npz")]) == 2
    assert "far.log:201" in capsys.readouterr().err
    assert not (tmp_path / "x.npz").exists()
