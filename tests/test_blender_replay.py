"""Replay on the timeline (vtskin.load_recording): a cyskin16 CAN log made with
``vtcore can encode`` from known frames and a CySkin text recording are loaded onto a laid
skin, played frame by frame and checked against vtcore decoding the same files; save
(compressed), reload, play again; bad input leaves the scene unchanged.
Headless, on the lane's bpy wheel."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

bpy = pytest.importorskip("bpy")
sys.path.insert(0, str(Path(__file__).parent / "blender"))
from bl_helpers import addon_fixtures, attr, build_scene, scene_state  # noqa: E402

pytestmark = [pytest.mark.blender, pytest.mark.filterwarnings("ignore::UserWarning")]

ROOT = Path(__file__).resolve().parents[1]

addon, factory = addon_fixtures()


def saved_and_reopened(ob, path):
    """Save the open file to ``path`` (compressed) and open it again: (the same object, the scene)."""
    name = ob.name
    bpy.ops.wm.save_as_mainfile(filepath=str(path), compress=True)
    bpy.ops.wm.open_mainfile(filepath=str(path))
    return bpy.data.objects[name], bpy.context.scene


@pytest.fixture
def skin_ob():
    ee, _, centre = build_scene()
    bpy.context.scene.cursor.location = centre
    bpy.context.view_layer.objects.active = ee
    assert bpy.ops.vtskin.lay_patch() == {"FINISHED"}
    ob = next(o for o in bpy.data.objects if o.vtskin.role == "TAXELS")
    bpy.context.view_layer.objects.active = ob
    return ob


def known_frames(ids, t=30, seed=0):
    """A bump sliding across the skin on top of per-taxel baselines near 3000 counts:
    timestamps (T,) at 50 Hz, wire values (T, N) uint16."""
    rng = np.random.default_rng(seed)
    n = len(ids)
    base = rng.normal(3000, 50, n)
    bump = np.zeros((t, n))
    centre = np.linspace(0, n - 1, t)
    bump[8:24] = 4000 * np.exp(-0.5 * ((np.arange(n)[None, :] - centre[8:24, None]) / 4) ** 2)
    wire = np.clip(np.rint(base + bump + rng.normal(0, 5, (t, n))), 0, 65535).astype(np.uint16)
    return 1000.0 + np.arange(t) * 0.02, wire


def encode_log(tmp_path, ts, wire, ids, mask):
    """The log a skin would send, written by the ``vtcore can encode`` command."""
    npz = tmp_path / "frames.npz"
    np.savez(npz, timestamps=ts, frames=wire, mask=mask, taxel_ids=np.asarray(ids, np.int64))
    log = tmp_path / "skin.log"
    r = subprocess.run([sys.executable, "-m", "vtcore", "can", "encode", str(npz), "--codec", "cyskin16",
                        "--out", str(log)], capture_output=True, text=True, cwd=ROOT)
    assert r.returncode == 0, r.stderr
    return log


def test_can_log_replay_play_save_reload(skin_ob, tmp_path):
    from vtcore.can import decode_log
    from vtcore.can.timeline import frame_rows, hold, load_recording

    from addon import skin

    ob = skin_ob
    ids = attr(ob, "taxel_id").astype(np.int64)
    n = len(ids)
    extra = (99 << 4) | 1                                   # a module the skin does not have
    ts, wire = known_frames(np.r_[ids, extra])
    mask = np.ones(wire.shape, bool)
    first = np.flatnonzero((ids & 0xF) <= 3)[:3]            # sensors 1-3 of one module: one frame
    first = np.flatnonzero((ids >> 4) == (ids[first[0]] >> 4))
    first = first[(ids[first] & 0xF) <= 3]
    mask[12:14, first] = False                               # that frame lost in rows 12 and 13
    log = encode_log(tmp_path, ts, wire, np.r_[ids, extra], mask)

    scene = bpy.context.scene
    scene.render.fps, scene.render.fps_base = 30, 1.0
    scene.frame_start = 1
    s = scene.vtskin
    s.recording_file, s.recording_codec, s.baseline_rows = str(log), "cyskin16", 4
    assert bpy.ops.vtskin.load_recording() == {"FINISHED"}

    dec = decode_log(log, "cyskin16", layout=skin.read_layout(ob))  # vtcore on the same file
    np.testing.assert_array_equal(dec.frames[dec.mask], wire[:, :n][dec.mask])
    rows = frame_rows(dec.timestamps, 30.0)
    assert (ob.vtskin.bake_start, ob.vtskin.bake_end) == (1, len(rows)) and scene.frame_end == len(rows)
    ref = load_recording(log, skin.read_layout(ob), skin.triangles(ob), kind="cyskin16", fps=30.0, baseline_rows=4,
                         edge_fraction=s.edge_fraction)
    np.testing.assert_array_equal(ref.rows, rows)
    held = hold(wire[:, :n].astype(float), mask[:, :n])
    assert ob.vtskin.lost_rows == 2 and ob.vtskin.lost_samples == 2 * len(first)
    assert ob.vtskin.lost_frames == int(np.isin(rows, [12, 13]).sum()) > 0
    # module 99's first frame carries its sensors 1-3 (2 and 3 at the rest value): all three decoded
    assert "3 recorded taxel(s) the layout lacks (e.g. [1585, 1586, 1587])" in ob.vtskin.replay_report
    assert ob.vtskin.color_by == "response_compensated"

    def check(frame):
        scene.frame_set(frame)
        k = frame - 1
        np.testing.assert_array_equal(attr(ob, "response"), held[rows[k]].astype(np.float32))
        np.testing.assert_array_equal(attr(ob, "response_compensated"), ref.response[k])
        np.testing.assert_array_equal(attr(ob, "edge"), ref.edge[k])
        np.testing.assert_array_equal(attr(ob, "held"), ~mask[rows[k], :n])

    lost_frame = int(np.flatnonzero(rows == 13)[0]) + 1
    for f in (1, 10, lost_frame, len(rows)):
        check(f)
    scene.frame_set(lost_frame)
    # a lost sample shows the last good value (row 11's)
    np.testing.assert_array_equal(attr(ob, "response")[first], wire[11, first].astype(np.float32))
    assert ref.edge.any() and ref.response.max() > 3000

    ob, scene = saved_and_reopened(ob, tmp_path / "replay.blend")
    assert ob.vtskin.cache is not None and ob.vtskin.lost_rows == 2
    for f in (lost_frame, 10):
        check(f)


def test_cyskin_txt_recording_at_its_own_rate(skin_ob, tmp_path):
    ob = skin_ob
    ids = attr(ob, "taxel_id").astype(np.int64)
    rng = np.random.default_rng(5)
    vals = rng.integers(0, 900, (12, len(ids) - 2))
    cols = ids[2:][::-1]                                   # columns in another order, two taxels missing
    lines = [" ".join(map(str, cols))] + [f"{r} {r * 0.01:.2f} " + " ".join(map(str, vals[r])) for r in range(12)]
    rec = tmp_path / "rec.txt"
    rec.write_text("\n".join(lines) + "\n")
    s = bpy.context.scene.vtskin
    s.replay_rate, s.baseline, s.baseline_rows = "RECORDING", "first", 1
    assert bpy.ops.vtskin.load_recording(filepath=str(rec), codec="cyskin-txt") == {"FINISHED"}
    assert (ob.vtskin.bake_start, ob.vtskin.bake_end) == (1, 12)
    truth = np.zeros((12, len(ids)), np.float32)
    truth[:, 2:] = vals[:, ::-1]
    for f in (1, 7, 12):
        bpy.context.scene.frame_set(f)
        np.testing.assert_array_equal(attr(ob, "response"), truth[f - 1])
        np.testing.assert_array_equal(attr(ob, "response_compensated"), np.clip(truth[f - 1] - truth[0], 0, None))
    assert f"2 of {len(ids)} layout taxel(s) never in the recording" in ob.vtskin.replay_report
    assert ob.vtskin.lost_rows == 0  # never-recorded taxels are a mismatch, not lost samples


def test_bad_recordings_change_nothing(skin_ob, tmp_path):
    ob = skin_ob
    ids = attr(ob, "taxel_id").astype(np.int64)
    ts, wire = known_frames(ids, t=6)
    log = encode_log(tmp_path, ts, wire, ids, np.ones(wire.shape, bool))
    before = scene_state()

    def refused(message, **kw):
        # the operator reports {'ERROR'} (bpy.ops raises it as RuntimeError) and cancels
        with pytest.raises(RuntimeError, match=message):
            bpy.ops.vtskin.load_recording(**kw)
        assert scene_state() == before and ob.vtskin.cache is None

    refused("no sample of the recording reached any of the skin's 60 taxels.*right codec",
            filepath=str(log), codec="icub")                 # the log does not match the codec
    refused("missing.log", filepath=str(tmp_path / "missing.log"), codec="cyskin16")
    refused("icub codec only", filepath=str(log), codec="cyskin16", boards="3")
    refused("Boards: expected board addresses", filepath=str(log), codec="icub", boards="three")
    refused("Unknown codec 'mp3'", filepath=str(log), codec="mp3")
    refused("No recording file given", filepath="", codec="cyskin16")
    garbage = tmp_path / "garbage.log"
    garbage.write_bytes(b"\x00\xffnot a log\n")
    refused("garbage.log", filepath=str(garbage), codec="cyskin16")
    ob.data.attributes.remove(ob.data.attributes["taxel_id"])   # a skin without UIDs
    before = scene_state()
    refused("no taxel_id attribute", filepath=str(log), codec="cyskin16")


def _replay_scene(tmp_path, output: str) -> Path:
    """scenes/replay_cyskin16_slide.toml with its log path made absolute and ``output`` as [output]."""
    src = (ROOT / "scenes" / "replay_cyskin16_slide.toml").read_text()
    src = src.replace('log = "data/', f'log = "{(ROOT / "scenes" / "data").as_posix()}/')
    path = tmp_path / "replay.toml"
    path.write_text(src + "\n[output]\nplots = false\n" + output + "\n")
    return path


@pytest.mark.slow
@pytest.mark.parametrize("engine,video", [("workbench", "mp4"), ("cycles", "frames")])
def test_replay_scene_renders_headless(tmp_path, engine, video):
    """A replay scene run from Blender loads the log into the cache and renders it per [output]."""
    from vtcore.scene.interactive import run_scene_file

    fps = 2.0  # 3 s of recording: 6 frames, kept small for the test
    scene_file = _replay_scene(tmp_path, f'video = "{video}"\nengine = "{engine}"\nresolution = [64, 48]\n'
                                         f"samples = 1\nfps = {fps}")
    out = tmp_path / "out"
    bpy.context.scene.vtskin.out_dir = str(out)
    assert bpy.ops.vtskin.run_scene(filepath=str(scene_file)) == {"FINISHED"}
    ob = bpy.context.view_layer.objects.active
    ref = run_scene_file(scene_file, tmp_path / "ref").replay
    s = ob.vtskin
    assert s.bake_end - s.bake_start + 1 == len(ref.rows) and s.lost_samples == ref.lost_samples == 7
    bpy.context.scene.frame_set(s.bake_start + 3)
    np.testing.assert_array_equal(attr(ob, "response_compensated"), ref.response[3])
    np.testing.assert_array_equal(attr(ob, "edge"), ref.edge[3])
    if video == "mp4":
        data = (out / "replay.mp4").read_bytes()
        assert data[4:8] == b"ftyp" and len(data) > 1000
    else:
        pngs = sorted(out.glob("replay_*.png"))
        assert len(pngs) == len(ref.rows)
        assert all(p.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" for p in pngs)


@pytest.mark.slow
def test_icub_replay_scene_then_reload_log_with_boards(tmp_path):
    """The iCub example scene (triangle 5 reports an error in rows 30..32) loads onto its skin;
    the same log loaded again with the operator, as board 0 explicitly, gives the same frames."""
    from vtcore.can.timeline import load_recording
    from vtcore.scene.interactive import run_scene_file

    from addon import skin

    scene_file = ROOT / "scenes" / "replay_icub_press.toml"
    bpy.context.scene.vtskin.out_dir = str(tmp_path / "out")
    assert bpy.ops.vtskin.run_scene(filepath=str(scene_file)) == {"FINISHED"}
    ob = bpy.context.view_layer.objects.active
    ref = run_scene_file(scene_file, tmp_path / "ref").replay
    assert ob.vtskin.lost_samples == ref.lost_samples == 36 and ob.vtskin.lost_rows == 3
    log = ROOT / "scenes" / "data" / "replay_icub_press.asc"
    s = bpy.context.scene.vtskin
    s.replay_rate, s.baseline_rows = "RECORDING", 3
    assert bpy.ops.vtskin.load_recording(filepath=str(log), codec="icub", boards="0") == {"FINISHED"}
    direct = load_recording(log, skin.read_layout(ob), skin.triangles(ob), kind="icub", boards=[0], fps=None,
                            baseline_rows=3, edge_fraction=s.edge_fraction)
    for f in (1, 31, len(direct.rows)):
        bpy.context.scene.frame_set(f)
        np.testing.assert_array_equal(attr(ob, "response"), direct.counts[f - 1])
        np.testing.assert_array_equal(attr(ob, "held"), direct.held[f - 1])
    assert attr(ob, "held").sum() == 0 and direct.held[31].sum() == 12  # row 31: triangle 5's 12 slots held
    with pytest.raises(RuntimeError, match="right codec, skin or board address"):
        bpy.ops.vtskin.load_recording(filepath=str(log), codec="icub", boards="3")  # the wrong board


def test_slow_recording_stored_once_per_row(skin_ob, tmp_path):
    """A 10 Hz recording on a 30 fps timeline: three frames show each row, the cache keeps each
    row once, and playback (also after a compressed save and reload) shows the right row."""
    from addon import bake

    ob = skin_ob
    ids = attr(ob, "taxel_id").astype(np.int64)
    vals = np.random.default_rng(9).integers(0, 900, (6, len(ids)))
    lines = [" ".join(map(str, ids))] + [f"{r} {r * 0.1:.1f} " + " ".join(map(str, vals[r])) for r in range(6)]
    rec = tmp_path / "slow.txt"
    rec.write_text("\n".join(lines) + "\n")
    scene = bpy.context.scene
    scene.render.fps, scene.render.fps_base, scene.frame_start = 30, 1.0, 1
    scene.vtskin.replay_rate = "SCENE"
    assert bpy.ops.vtskin.load_recording(filepath=str(rec), codec="cyskin-txt") == {"FINISHED"}
    assert (ob.vtskin.bake_start, ob.vtskin.bake_end) == (1, 16)          # 0.5 s at 30 fps
    stored = [a.name for a in ob.vtskin.cache.attributes if a.name.startswith("response_0")]
    assert len(stored) == 6                                              # one per row, not per frame

    def shows(frame, row):
        scene.frame_set(frame)
        np.testing.assert_array_equal(attr(ob, "response"), vals[row].astype(np.float32))

    for f in (1, 3, 4, 10, 16):
        shows(f, int(np.floor((f - 1) / 30 / 0.1 + 1e-9)))
    ob, scene = saved_and_reopened(ob, tmp_path / "slow.blend")
    assert bake.SHOWS in ob.vtskin.cache
    shows(12, 3)
