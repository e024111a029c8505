"""Fuzz of the CAN readers (``can decode`` per log format, ``can encode``, ``recording import``).

Seeds: the first lines of the repository's recorded logs (scenes/data), logs of every
format written by python-can from a short decoded run, a CySkin text recording made
here, FRAMES.npz files made here. See fuzzing.py for the mutations and the contract.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from hypothesis import strategies as st

from fuzzing import assert_clean_exit, fuzz, mutated, run_cli

ROOT = Path(__file__).resolve().parents[2]
DATA = ROOT / "scenes" / "data"
LAYOUT = ROOT / "scenes" / "layouts" / "seed001_hexagon.cyskin.json"


@pytest.fixture(scope="module")
def seeds(tmp_path_factory):
    """Seed files per reader: {name: (suffix, [bytes, ...], codec)}."""
    from vtcore.can import decode_log, encode, get_codec, write_log

    d = tmp_path_factory.mktemp("seeds")
    head = {p.suffix: b"".join(p.read_bytes().splitlines(keepends=True)[:40]) for p in DATA.iterdir()}
    (d / "slide.log").write_bytes(head[".log"])
    res = decode_log(d / "slide.log", "cyskin16")
    batch = encode(res.timestamps, res.frames, res.taxel_ids, get_codec("cyskin16"), mask=res.mask)
    out = {}
    for fmt in (".log", ".asc", ".trc", ".csv", ".blf"):
        write_log(d / f"s{fmt}", batch)
        seeds_ = [(d / f"s{fmt}").read_bytes()]
        if fmt in head:
            seeds_.append(head[fmt])
        codec = "icub" if fmt == ".asc" else "cyskin16"
        out[f"decode{fmt}"] = (fmt, seeds_, codec)
    # a CySkin text recording of the seed001 hexagon's UIDs (with a temperature channel)
    from vtcore.layout import load

    ids = load(LAYOUT).taxel_ids[:12]
    uids = np.r_[ids, [16]]
    rows = [" ".join(map(str, uids))]
    rows += [f"{r} {0.05 * r:.3f} " + " ".join(str((r * 37 + k * 11) % 3000) for k in range(len(uids)))
             for r in range(8)]
    out["recording"] = (".txt", [("\n".join(rows) + "\n").encode()], None)
    # FRAMES.npz
    from vtcore.can import save_frames_npz

    save_frames_npz(d / "f.npz", res)
    out["frames"] = (".npz", [(d / "f.npz").read_bytes()], "cyskin16")
    return out


def _check_frames_npz(path):
    from vtcore.can import load_frames_npz

    data = load_frames_npz(path)          # re-readable by its own reader
    assert np.isfinite(data["timestamps"]).all()
    f = data["frames"]
    m = data.get("mask", np.ones(f.shape, bool))
    assert np.isfinite(f[m]).all()


@pytest.mark.parametrize("fmt", [".log", ".asc", ".trc", ".csv", ".blf"])
def test_fuzz_can_decode(fmt, seeds, tmp_path, pytestconfig):
    suffix, blobs, codec = seeds[f"decode{fmt}"]
    src, out = tmp_path / f"in{suffix}", tmp_path / "out.npz"

    def check(data):
        src.write_bytes(data)
        out.unlink(missing_ok=True)
        rc, so, se = run_cli(f"can decode {fmt}", ["can", "decode", src, "--codec", codec, "--out", out])
        assert_clean_exit(rc, so, se)
        if rc == 0:
            _check_frames_npz(out)

    fuzz(pytestconfig, mutated(blobs), check)


def test_fuzz_recording_import(seeds, tmp_path, pytestconfig):
    _, blobs, _ = seeds["recording"]
    src, out, rep = tmp_path / "rec.txt", tmp_path / "out.npz", tmp_path / "report.json"

    def check(data):
        src.write_bytes(data)
        out.unlink(missing_ok=True)
        rc, so, se = run_cli("recording import", ["recording", "import", src, "--format", "cyskin-txt",
                                                  "--layout", LAYOUT, "--out", out, "--report", rep])
        assert_clean_exit(rc, so, se)
        if rc == 0:
            import json

            with np.load(out) as z:
                assert np.isfinite(z["timestamps"]).all()
                assert z["frames"].dtype == np.uint16
            json.loads(rep.read_text(encoding="utf-8"))   # strict JSON (no NaN token)

    fuzz(pytestconfig, mutated(blobs), check)


def test_fuzz_can_encode_bytes(seeds, tmp_path, pytestconfig):
    _, blobs, codec = seeds["frames"]
    src, out = tmp_path / "f.npz", tmp_path / "out.log"

    def check(data):
        src.write_bytes(data)
        out.unlink(missing_ok=True)
        rc, so, se = run_cli("can encode (bytes)", ["can", "encode", src, "--codec", codec, "--out", out])
        assert_clean_exit(rc, so, se)

    fuzz(pytestconfig, mutated(blobs), check)


_VALUES = st.one_of(st.floats(allow_nan=True, allow_infinity=True), st.integers(-2**70, 2**70),
                    st.sampled_from([0.0, 1.0, 255.0, 65535.0, 65536.0, -1.0, 1e308, np.nan]))


@st.composite
def frames_arrays(draw):
    """FRAMES.npz contents with wrong dtypes, shapes and values mixed into valid ones."""
    t = draw(st.integers(0, 5))
    n = draw(st.integers(0, 6))
    kind = draw(st.sampled_from(["float", "int", "str", "bool", "object-ish", "uint16"]))
    vals = draw(st.lists(_VALUES, min_size=t * n, max_size=t * n))
    if kind == "str":
        frames = np.array([str(v) for v in vals] or ["x"], dtype=str)
    elif kind == "bool":
        frames = np.array([bool(v == v and v) for v in vals], bool).reshape(t, n)
    elif kind == "int":
        frames = np.array([int(min(max(v, -2**62), 2**62)) if v == v and abs(v) != float("inf") else 0
                           for v in vals], np.int64).reshape(t, n)
    elif kind == "uint16":
        frames = np.zeros((t, n), np.uint16) + 7
    else:
        frames = np.array(vals, np.float64).reshape(t, n)
    ts = np.array(draw(st.lists(_VALUES, min_size=t, max_size=t)), np.float64) \
        if draw(st.booleans()) else np.arange(t) * 0.05
    if draw(st.booleans()):
        ids = np.array(draw(st.lists(st.integers(-5, 2**40), min_size=n, max_size=n)), np.int64)
    else:
        ids = ((np.arange(n) // 10 + 1) << 4) | (np.arange(n) % 10 + 1)
    out = {"timestamps": ts, "frames": frames, "taxel_ids": ids}
    if draw(st.booleans()):
        out["mask"] = np.array(draw(st.lists(st.booleans(), min_size=t * n, max_size=t * n)), bool).reshape(t, n)
    if draw(st.booleans()):
        victim = draw(st.sampled_from(sorted(out)))
        out[victim] = draw(st.sampled_from([np.array("text"), np.zeros((2, 2, 2)), np.array([], float)]))
    return out


@pytest.mark.parametrize("codec", ["icub", "cyskin16"])
def test_fuzz_can_encode_arrays(codec, tmp_path, pytestconfig):
    src, out = tmp_path / "f.npz", tmp_path / "out.log"

    def check(arrays):
        np.savez(src, **arrays)
        out.unlink(missing_ok=True)
        rc, so, se = run_cli(f"can encode ({codec})", ["can", "encode", src, "--codec", codec, "--out", out])
        assert_clean_exit(rc, so, se)
        if rc == 0:
            back = tmp_path / "back.npz"
            rc2, so2, se2 = run_cli("can decode .log", ["can", "decode", out, "--codec", codec, "--out", back])
            assert rc2 == 0, se2
            _check_frames_npz(back)

    fuzz(pytestconfig, frames_arrays(), check)
