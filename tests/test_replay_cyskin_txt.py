"""The replay scene task takes CySkin text recordings as well as CAN logs (issue 25): the real
recording of a finger press on its real calibrated patch, joined by UID, the same response as the
add-on's Load Recording (vtcore.can.timeline.load_recording) computes."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

DATA = Path("/work/shared/data/cyskin_gesture")
pytestmark = pytest.mark.skipif(not DATA.is_dir(), reason="the shared CySkin recordings are not here")


def scene(tmp_path, log, **task):
    extra = "".join(f"{k} = {json.dumps(v)}\n" for k, v in task.items())
    text = f"""[scene]
name = "replay_gesture"
task = "replay"
seed = 0

[end_effector]
shape = "plane"

[layout]
file = "{DATA / 'curved_gesture_patch_full_isomap.json'}"
format = "cyskin"

[task]
log = "{log}"
codec = "cyskin-txt"
baseline_rows = 5
{extra}"""
    p = tmp_path / "replay.toml"
    p.write_text(text)
    return p


def test_replay_task_reads_a_real_cyskin_text_recording(tmp_path, cli):
    import warnings

    from vtcore.can.timeline import load_recording
    from vtcore.layout import load

    rec = DATA / "1_finger" / "sample_01.txt"
    r = cli("run", scene(tmp_path, rec), "--out", tmp_path / "out")
    assert r.returncode == 0, r.stderr
    res = json.loads((tmp_path / "out" / "result.json").read_text())
    m = res["metrics"]
    assert m["rows"] == m["rows_decoded"] == 30 and m["matched_uids"] >= 634 and m["rejected_lines"] == 0
    assert m["response_max"] > 5000  # the finger
    arrays = np.load(tmp_path / "out" / "arrays.npz")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        lay = load(DATA / "curved_gesture_patch_full_isomap.json")
        ref = load_recording(rec, lay, np.asarray(lay.meta["faces"]), kind="cyskin-txt", fps=None)
    np.testing.assert_allclose(arrays["response"], ref.response, rtol=1e-6, atol=1e-2)
    assert arrays["edge"].any()


def test_replay_task_cyskin_text_errors(tmp_path, cli):
    bad = tmp_path / "bad.txt"
    bad.write_text("1 2 3\n0 0.0 1 2 3\n")
    r = cli("run", scene(tmp_path, bad), "--out", tmp_path / "o1")
    assert r.returncode == 2 and "none of the 3 recorded UIDs" in r.stderr and "Traceback" not in r.stderr
    r = cli("run", scene(tmp_path, DATA / "1_finger" / "sample_01.txt", boards=[3]), "--out", tmp_path / "o2")
    assert r.returncode == 2 and "icub codec only" in r.stderr
