"""The reading discipline (vtcore.inputs) and one regression test per defect class of issue 13
that the readers, the CLI and the output folders had."""

from __future__ import annotations

import contextlib
import io
import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from helpers import wall_clock_limit
from vtcore import inputs
from vtcore.cli import main
from vtcore.errors import FormatError, InputError

ROOT = Path(__file__).resolve().parents[1]
LAYOUT = ROOT / "scenes" / "layouts" / "seed001_hexagon.cyskin.json"
SCENE = ROOT / "scenes" / "press_cube_3mm.toml"


def no_hang(seconds=30):
    return wall_clock_limit(seconds)


def cli(*argv):
    out, err = io.StringIO(), io.StringIO()
    with no_hang(), contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        rc = main([str(a) for a in argv])
    return rc, out.getvalue(), err.getvalue()


def one_error_line(rc, err, *needles):
    assert rc == 2, err
    assert err.startswith("vtcore: error: ") and err.count("\n") == 1, err
    for n in needles:
        assert n in err, err


# ----------------------------------------------------------------------------- files
def test_non_regular_files_are_refused_before_opening(tmp_path):
    fifo = tmp_path / "pipe.txt"
    os.mkfifo(fifo)
    with no_hang():
        for p, kind in ((fifo, "named pipe"), (tmp_path, "folder")):
            with pytest.raises(InputError, match=kind):
                inputs.read_text(p)
            with pytest.raises(InputError, match=kind):
                inputs.TextLines(p)
        if Path("/dev/null").exists():
            with pytest.raises(InputError, match="device"):
                inputs.read_bytes("/dev/null")
    with pytest.raises(InputError, match="not found"):
        inputs.check_input(tmp_path / "missing")


def test_encoding_policy(tmp_path):
    p = tmp_path / "t.txt"
    p.write_bytes(b"\xef\xbb\xbfa b\r\nc\rd\n")
    assert inputs.read_text(p).splitlines() == ["a b", "c", "d"]
    p.write_bytes("a b\n".encode("utf-16"))
    with pytest.raises(FormatError, match="UTF-16"):
        inputs.read_text(p)
    p.write_bytes("ab\ncaf\xe9\n".encode("latin-1"))
    with pytest.raises(FormatError, match="byte offset 6.*0xe9"):
        inputs.read_text(p)
    p.write_bytes(b"ab\x00cd")
    with pytest.raises(FormatError, match="byte offset 2.*NUL"):
        inputs.read_text(p)


@pytest.mark.parametrize("block", [1, 2, 3, 5, 64])
def test_text_lines_across_blocks(tmp_path, block):
    p = tmp_path / "t.txt"
    text = "\ufeffé1\r\nzwölf\rdrei€\n\nlast"
    p.write_bytes(text.encode("utf-8"))
    with inputs.TextLines(p, block=block) as fh:
        got = []
        while line := fh.readline():
            got.append(line)
    assert got == ["é1\n", "zwölf\n", "drei€\n", "\n", "last\n"]
    p.write_bytes("ok\nnot \xff here\n".encode("utf-8").replace(b"\xc3\xbf", b"\xff"))
    with pytest.raises(FormatError, match="byte offset 7"):
        with inputs.TextLines(p, block=block) as fh:
            while fh.readline():
                pass


def test_text_lines_refuse_a_line_without_end(tmp_path, monkeypatch):
    monkeypatch.setattr(inputs.text, "MAX_LINE_BYTES", 100)  # read where TextLines lives
    p = tmp_path / "b.log"
    p.write_bytes(b"x" * 1000)
    with pytest.raises(FormatError, match="longer than"):
        with inputs.TextLines(p, block=64) as fh:
            fh.readline()


def test_bounded_conversions():
    assert inputs.to_int("0x10") == 16 and inputs.to_int(7.0) == 7
    for bad in (2 ** 70, "1e3", 1.5, float("nan"), True, "abc", [1]):
        with pytest.raises(InputError):
            inputs.to_int(bad, file="f", key="k", line=3)
    with pytest.raises(InputError, match="0..4294967295"):
        inputs.int_array([1, 2 ** 32], dtype=np.uint32, key="ids")
    with pytest.raises(InputError, match="f:3: ids"):
        inputs.int_array([1, 2 ** 70], file="f", key="ids", line=3)       # OverflowError before
    with pytest.raises(InputError):
        inputs.int_array(np.array(["a"]), key="ids")
    assert inputs.int_array(np.array([1.0, 2.0])).dtype == np.int64
    with pytest.raises(InputError, match="finite"):
        inputs.float_array([1.0, np.inf])
    with pytest.raises(InputError, match="numbers"):
        inputs.float_array(np.array(["1", "2"]))
    with pytest.raises(InputError, match=r"shape \(N x 3\)"):
        inputs.float_array(np.zeros((4, 2)), shape=(None, 3))


def test_record_validation_names_file_and_key():
    spec = {"id": inputs.Spec("int", lo=0), "xyz": inputs.Spec("floats", shape=(3,)),
            "name": inputs.Spec("str", required=False, default="x")}
    assert inputs.validate({"id": 3, "xyz": [0, 1, 2]}, spec)["name"] == "x"
    with pytest.raises(InputError, match=r"^l\.json: taxels\[2\]\.xyz: must be finite"):
        inputs.validate({"id": 3, "xyz": [0, float("nan"), 2]}, spec, file="l.json", prefix="taxels[2]")
    with pytest.raises(InputError, match=r"taxels\[2\]\.id: must be an integer"):
        inputs.validate({"id": "abc", "xyz": [0, 1, 2]}, spec, file="l.json", prefix="taxels[2]")
    with pytest.raises(InputError, match="must be an object"):
        inputs.validate([1, 2], spec, file="l.json", prefix="taxels[2]")


def test_clean_strips_control_bytes():
    assert inputs.clean("a\x1b[31mb\x00c\u2028") == "a\\x1b[31mb\\x00c\\u2028"
    assert len(inputs.clean("x" * 500, limit=50)) == 53


def test_memory_budget(monkeypatch):
    monkeypatch.setenv("VTCORE_MEMORY_BUDGET", "1M")
    assert inputs.memory_budget() == 1 << 20
    inputs.need_memory(1000, key="k", what="w")
    with pytest.raises(InputError, match=r"task\.readings: w would need 7.63 MiB.*VTCORE_MEMORY_BUDGET"):
        inputs.need_memory(8e6, key="task.readings", what="w")
    monkeypatch.setenv("VTCORE_MEMORY_BUDGET", "lots")
    with pytest.raises(InputError, match="VTCORE_MEMORY_BUDGET"):
        inputs.memory_budget()


def test_write_json_refuses_non_finite(tmp_path):
    from vtcore._io import write_json

    with pytest.raises(InputError, match=r"metrics\.force_n: is nan"):
        write_json(tmp_path / "r.json", {"metrics": {"force_n": float("nan")}})
    assert not list(tmp_path.iterdir())                              # nothing half-written


# ----------------------------------------------------------------------------- CLI regressions
def test_named_pipe_inputs_do_not_hang(tmp_path):
    for name in ("in.log", "in.txt", "in.toml", "in.npz"):
        os.mkfifo(tmp_path / name)
    rc, _, err = cli("can", "decode", tmp_path / "in.log", "--codec", "icub", "--out", tmp_path / "f.npz")
    one_error_line(rc, err, "named pipe")
    rc, _, err = cli("recording", "import", tmp_path / "in.txt", "--format", "cyskin-txt", "--layout", LAYOUT,
                     "--out", tmp_path / "f.npz")
    one_error_line(rc, err, "named pipe")
    rc, _, err = cli("run", tmp_path / "in.toml", "--out", tmp_path / "o")
    one_error_line(rc, err, "named pipe")
    rc, _, err = cli("can", "encode", tmp_path / "in.npz", "--codec", "icub", "--out", tmp_path / "o.log")
    one_error_line(rc, err, "named pipe")
    rc, _, err = cli("can", "decode", tmp_path, "--codec", "icub", "--out", tmp_path / "f.npz")
    assert rc == 2


def test_out_folder_checked_up_front(tmp_path):
    afile = tmp_path / "afile"
    afile.write_text("x")
    rc, _, err = cli("run", SCENE, "--out", afile)
    one_error_line(rc, err, "is a file, not a folder")
    rc, _, err = cli("run", SCENE, "--out", afile / "sub")
    one_error_line(rc, err, "afile is a file, not a folder")
    rc, _, err = cli("can", "decode", ROOT / "scenes/data/replay_icub_press.asc", "--codec", "icub",
                     "--out", afile / "f.npz")
    one_error_line(rc, err, "afile: --out: exists and is a file, not a folder")
    rc, _, err = cli("can", "encode", tmp_path / "missing.npz", "--codec", "icub", "--out", tmp_path)
    one_error_line(rc, err, "is a folder")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["afile"]


def test_read_only_out_folder(tmp_path, monkeypatch):
    ro = tmp_path / "ro"
    ro.mkdir()
    real = os.access
    monkeypatch.setattr(os, "access", lambda p, m, **k: False if Path(p) == ro else real(p, m, **k))
    rc, _, err = cli("run", SCENE, "--check", "--out", ro / "x")
    one_error_line(rc, err, "permission denied")


def test_set_scene_to_a_number():
    rc, _, err = cli("run", SCENE, "--check", "--set", "scene=5")
    one_error_line(rc, err, "scene: must be a table")
    rc, _, err = cli("run", SCENE, "--check", "--set", "output=[1]")
    one_error_line(rc, err, "output: must be a table")


def _frames(tmp_path, **over):
    arrays = {"timestamps": np.arange(3) * 0.05, "frames": np.full((3, 2), 10.0),
              "taxel_ids": np.array([17, 18])}
    arrays.update(over)
    p = tmp_path / "f.npz"
    np.savez(p, **arrays)
    return p


@pytest.mark.parametrize("over, needle", [
    ({"frames": np.array([["a", "b"]] * 3)}, "frames: must be numbers"),
    ({"timestamps": np.array([0.0, np.nan, 0.1])}, "timestamps: must be finite"),
    ({"timestamps": np.array([0.0, 1e300, 2e300])}, "timestamps: must be within"),
    ({"taxel_ids": np.array([17, 2 ** 32 + 17])}, "taxel_ids: must be in 0..4294967295"),
    ({"taxel_ids": np.array([17, 3072])}, "taxel_ids: must be in 0..3071"),
    ({"frames": np.array([[1.0, np.inf]] * 3)}, "frames: holds infinite"),
    ({"mask": np.ones((3, 2), np.int8)}, "mask: must be booleans"),
])
def test_can_encode_refuses_bad_frames(tmp_path, over, needle):
    rc, _, err = cli("can", "encode", _frames(tmp_path, **over), "--codec", "icub", "--out", tmp_path / "o.log")
    one_error_line(rc, err, needle)
    assert not (tmp_path / "o.log").exists()


def test_can_log_ids_and_times_out_of_range_are_counted(tmp_path):
    log = tmp_path / "x.log"
    good = "(1.000000) vcan0 141#40F0F0F0F0F0F0F0\n"
    log.write_text(good + "(nan) vcan0 141#40F0F0F0F0F0F0F0\n(1e308) vcan0 141#40F0F0F0F0F0F0F0\n"
                   "(1.1) vcan0 FFFFFFFFFFF#40F0F0F0F0F0F0F0\n" + good.replace("1.0", "1.05"))
    rc, out, err = cli("can", "decode", log, "--codec", "icub", "--out", tmp_path / "f.npz",
                       "--summary", tmp_path / "s.json")
    assert rc == 0, err
    s = json.loads((tmp_path / "s.json").read_text())
    assert s["rejected"]["malformed_frame"] == 2 and s["rejected"]["not_data_frame"] == 1  # (nan), (1e308); the huge id
    rc, out, err = cli("can", "decode", tmp_path / "s.json", "--codec", "icub", "--out", tmp_path / "f.npz")
    assert rc == 2


def test_empty_log_summary_is_strict_json(tmp_path):
    (tmp_path / "e.log").write_text("")
    rc, _, err = cli("can", "decode", tmp_path / "e.log", "--codec", "icub", "--out", tmp_path / "f.npz",
                     "--summary", tmp_path / "s.json")
    assert rc == 0, err
    s = json.loads((tmp_path / "s.json").read_text(), parse_constant=lambda c: 1 / 0)   # no NaN token
    assert s["frames_read"] == 0


def test_utf16_log_is_refused_with_the_reason(tmp_path):
    (tmp_path / "u.log").write_bytes("(1.0) vcan0 141#40F0\n".encode("utf-16"))
    rc, _, err = cli("can", "decode", tmp_path / "u.log", "--codec", "icub", "--out", tmp_path / "f.npz")
    one_error_line(rc, err, "UTF-16")


def _recording(tmp_path, header, rows):
    p = tmp_path / "r.txt"
    p.write_bytes(header + b"\n" + b"".join(r + b"\n" for r in rows))
    return p


def test_recording_bad_values(tmp_path):
    out = tmp_path / "f.npz"
    p = _recording(tmp_path, b"17 18 " + str(2 ** 70).encode(), [b"0 0.0 1 2 3"])
    rc, _, err = cli("recording", "import", p, "--format", "cyskin-txt", "--layout", LAYOUT, "--out", out)
    one_error_line(rc, err, ":1: UIDs: must be in 0..4294967295")
    p = _recording(tmp_path, b"\x1b[2J17 18", [b"0 0.0 1 2"])
    rc, _, err = cli("recording", "import", p, "--format", "cyskin-txt", "--layout", LAYOUT, "--out", out)
    one_error_line(rc, err, "\\x1b[2J")
    assert "\x1b" not in err
    p = _recording(tmp_path, b"17 18", [b"0 nan 1 2", b"1 0.1 inf 2", b"1e300 0.2 1 2", b"3 1e308 4 5",
                                        b"4 -1e308 4 5"])
    rc, _, err = cli("recording", "import", p, "--format", "cyskin-txt", "--layout", LAYOUT, "--out", out,
                     "--report", tmp_path / "r.json")
    assert rc == 0 and "Warning" not in err, err
    rep = json.loads((tmp_path / "r.json").read_text())
    assert [r["line"] for r in rep["rejected_lines"]] == [2, 3, 4]
    assert rep["time_backwards"] == 1
    p.write_bytes("17 18\n0 0.5 1 2\n".encode("latin-1") + b"1 0.6 \xe9 2\n")
    rc, _, err = cli("recording", "import", p, "--format", "cyskin-txt", "--layout", LAYOUT, "--out", out)
    one_error_line(rc, err, "byte offset 22")


# ----------------------------------------------------------------------------- interrupted runs
def test_failed_run_leaves_nothing(tmp_path, monkeypatch):
    from vtcore.scene import registry, run_scene

    registry.discover()
    task = registry.TASKS["press"]

    def boom(scene, ctx):
        (ctx.out / "partial.png").write_bytes(b"x")
        raise KeyboardInterrupt

    monkeypatch.setattr(task, "run", boom)
    with pytest.raises(KeyboardInterrupt):
        run_scene(SCENE, tmp_path / "new")
    assert not (tmp_path / "new").exists()
    (tmp_path / "old").mkdir()
    (tmp_path / "old" / "keep.txt").write_text("x")
    with pytest.raises(KeyboardInterrupt):
        run_scene(SCENE, tmp_path / "old")
    assert sorted(p.name for p in (tmp_path / "old").iterdir()) == ["keep.txt"]


def test_sigterm_removes_the_staging_folder(tmp_path):
    out = tmp_path / "o"
    proc = subprocess.Popen([sys.executable, "-X", "faulthandler", "-m", "vtcore", "run", SCENE, "--out", out], cwd=ROOT,
                            env={**os.environ, "VTCORE_PROGRESS": "0"}, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True)
    try:
        for _ in range(600):  # wait until the run is under way (its staging folder exists)
            if out.exists() and any(out.iterdir()) or proc.poll() is not None:
                break
            time.sleep(0.05)
        proc.send_signal(signal.SIGTERM)
        _, err = proc.communicate(timeout=120)
    finally:
        if proc.poll() is None:
            proc.kill()
    if proc.returncode == 0:
        pytest.skip("the run finished before the signal arrived")
    assert proc.returncode == 143, err
    assert "vtcore: terminated" in err
    # nothing, or (a signal that came during the commit, on a loaded machine) the whole set
    assert_no_half_set(out)


def assert_no_half_set(out: Path) -> list[str]:
    """The output folder of a run that was stopped holds no staging folder and no half set of files."""
    names = sorted(p.name for p in out.iterdir()) if out.exists() else []
    assert not [n for n in names if n.startswith(".vtcore-run-")], names
    if names:
        result = json.loads((out / "result.json").read_text())
        assert set(names) == {"result.json", "report.md", "arrays.npz", *result["figures"], *result["files"]}
    return names


def _signal_self_then(fn):
    def wrapped(*a, **k):
        os.kill(os.getpid(), signal.SIGTERM)
        return fn(*a, **k)
    return wrapped


@pytest.mark.skipif(not hasattr(signal, "SIGTERM") or os.name != "posix", reason="POSIX signals")
def test_sigterm_during_the_run_leaves_nothing_and_during_the_commit_everything(tmp_path, monkeypatch):
    import threading

    from vtcore.scene import runner

    if threading.current_thread() is not threading.main_thread():
        pytest.skip("the SIGTERM handler is installed from the main thread only")
    # while the arrays are written (the run is under way): nothing lands
    with monkeypatch.context() as m:
        m.setattr(runner, "save_npz", _signal_self_then(runner.save_npz))
        rc, _, err = cli("run", SCENE, "--out", tmp_path / "a", "--set", "output.plots=false")
    assert rc == 143 and "vtcore: terminated" in err, err
    assert assert_no_half_set(tmp_path / "a") == []
    # while the first file is moved in: the commit finishes, then the CLI stops with 143
    real = os.replace
    calls = []

    def replace(src, dst):  # os.replace is also atomic_write's rename inside the staging folder
        if Path(dst).parent == tmp_path / "b":
            calls.append(dst)
        return (_signal_self_then(real) if len(calls) == 1 and Path(dst).parent == tmp_path / "b" else real)(src, dst)

    with monkeypatch.context() as m:
        m.setattr(runner.os, "replace", replace)
        rc, _, err = cli("run", SCENE, "--out", tmp_path / "b", "--set", "output.plots=false")
    assert rc == 143 and "vtcore: terminated" in err, err
    assert len(calls) > 1 and len(assert_no_half_set(tmp_path / "b")) == len(calls)


# ----------------------------------------------------------------------------- layout readers
def _edit(src: Path, old: bytes, new: bytes) -> bytes:
    data = src.read_bytes()
    assert old in data
    return data.replace(old, new, 1)


ICUB = ROOT / "scenes" / "layouts" / "icub_two_triangles.txt"


@pytest.mark.parametrize("fmt, name, make, needle", [
    ("cyskin", "l.json", lambda: b"\x80" + LAYOUT.read_bytes(), "byte offset 0"),                     # not UTF-8
    ("cyskin", "l.json", lambda: _edit(LAYOUT, b'"id": 17', b'"id": "abc"'), "cyskin"),              # int("abc")
    ("cyskin", "l.json", lambda: _edit(LAYOUT, b'"taxels": [', b'"taxels": {"a": 1}, "x": ['), "l.json"),
    ("cyskin", "l.json", lambda: _edit(LAYOUT, b'"id": 17', b'"id": 1' + b"0" * 30), "l.json"),       # past int64
    ("icub", "l.txt", lambda: _edit(ICUB, b"0.0025 -0.0101036297108", b"1e308 -0.0101036297108"), "l.txt"),
    ("icub", "l.txt", lambda: ICUB.read_text().encode("utf-16"), "UTF-16"),
])
def test_layout_readers_refuse_bad_values(tmp_path, fmt, name, make, needle):
    src = tmp_path / name
    src.write_bytes(make())
    rc, _, err = cli("layout", "import", src, "--format", fmt, "--out", tmp_path / "out.json")
    one_error_line(rc, err, needle)
    assert not (tmp_path / "out.json").exists()


def test_ply_bad_count_and_truncated_faces(tmp_path):
    from vtcore.layout import load, save

    save(load(ICUB), tmp_path / "s.ply")
    text = (tmp_path / "s.ply").read_text()
    for i, bad in enumerate((text.replace("element vertex 24", "element vertex 99999999999999999999"),
                             text.replace("element vertex 24", "element vertex x"),
                             text[: len(text) - 40])):
        (tmp_path / f"b{i}.ply").write_text(bad)
        rc, _, err = cli("layout", "import", tmp_path / f"b{i}.ply", "--out", tmp_path / f"o{i}.json")
        assert rc in (0, 2) and "Traceback" not in err, err
        if rc == 2:
            one_error_line(rc, err, f"b{i}.ply")
