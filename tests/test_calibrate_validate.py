"""vtcore calibrate / validate on recordings written here (issue 27's hard cases), and on the shared
real CySkin recordings when they are beside the repository."""

import json
import os
from pathlib import Path

import numpy as np
import pytest

from vtcore.calibrate.footprint import footprint_metrics
from vtcore.cli import main
from vtcore.layout import load

ROOT = Path(__file__).resolve().parents[1]
HEX = ROOT / "scenes" / "layouts" / "seed001_hexagon.cyskin.json"
SHARED = Path(os.environ.get("VTCORE_SHARED_DATA", ROOT.parent / "shared" / "data")) / "cyskin_gesture"


def write_recording(path, layout, frames, uids=None, rate=10.0):
    """A CySkin text recording: line 1 the UIDs, then ``row time v1 ... vN`` (integer counts)."""
    uids = layout.taxel_ids if uids is None else uids
    lines = [" ".join(str(int(u)) for u in uids) + " "]
    for i, f in enumerate(frames):
        lines.append(f"{i} {i / rate:.4f} " + " ".join(str(int(v)) for v in np.rint(f)))
    Path(path).write_text("\n".join(lines) + "\n")


def synthetic_press(layout, rng, *, centre, n_frames=24, contact=range(8, 16), sigma=150.0, peak=12000.0,
                    half_lengths=(0.012, 0.004), angle=0.4):
    """Idle noise clipped at 0, and an elongated footprint (an anisotropic Gaussian) in ``contact``."""
    pos = layout.positions
    u = np.array([np.cos(angle), np.sin(angle), 0.0])
    v = np.array([-np.sin(angle), np.cos(angle), 0.0])
    rel = pos - np.asarray(centre)
    blob = np.exp(-0.5 * ((rel @ u) / half_lengths[0]) ** 2 - 0.5 * ((rel @ v) / half_lengths[1]) ** 2)
    frames = sigma * rng.normal(size=(n_frames, len(pos)))
    for i in contact:
        frames[i] += peak * blob
    return np.clip(frames, 0, 65535)


SCENE = """
[scene]
name = "v"
task = "validate"
seed = 2
[layout]
file = "{layout}"
[layer]
thickness = 0.004
grid_spacing = 0.0015
samples_per_taxel = 3
[[objects]]
kind = "fingerpad"
[task]
recordings = {recordings}
[effects.soft_layer]
[effects.gain]
counts_per_pa = 0.7
[effects.noise]
sigma = 150.0
[effects.saturation]
[effects.quantisation]
[output]
plots = {plots}
"""


def _scene(tmp_path, recordings, plots=False):
    p = tmp_path / "v.toml"
    p.write_text(SCENE.format(layout=HEX.as_posix(), recordings=json.dumps([str(r) for r in recordings]),
                              plots=str(plots).lower()))
    return p


def test_validate_writes_matched_arrays_and_metrics(tmp_path):
    lay = load(HEX)
    rng = np.random.default_rng(3)
    rec = tmp_path / "press.txt"
    write_recording(rec, lay, synthetic_press(lay, rng, centre=lay.positions[0] + [0.004, 0.002, 0]))
    out = tmp_path / "out"
    assert main(["validate", str(rec), "--layout", str(HEX), "--scene", str(_scene(tmp_path, [rec], plots=True)),
                 "--out", str(out)]) == 0
    arr = np.load(out / "arrays.npz")
    k = len(arr["real"])
    assert k == 8 and arr["sim"].shape == arr["real"].shape == (k, len(lay))
    assert arr["positions"].shape == (len(lay), 3) and arr["noise_sigma"].shape == (len(lay),)
    assert np.allclose(arr["noise_sigma"], 150.0)
    res = json.loads((out / "result.json").read_text())
    m = res["metrics"]
    for key in ("all_real_ring1_median", "all_sim_ring1_median", "all_real_active_q25", "all_sim_minor_mm_median",
                "all_real_peak_median", "force_n_median", "compression_max"):
        assert key in m and m[key] is not None, key
    # the force rule: the simulated peak follows the recorded one (noise aside)
    assert abs(m["all_sim_peak_median"] / m["all_real_peak_median"] - 1) < 0.15
    assert (out / "footprints.png").exists() and (out / "metrics.png").exists() and (out / "by_force.png").exists()
    # one recording: its strongest frame is the one peak frame, and the rest are the others
    strongest = int(np.argmax(np.nanmax(arr["real"], axis=1)))
    assert m["peak_all_real_peak_median"] == pytest.approx(float(np.nanmax(arr["real"][strongest])))
    assert "rest_all_real_ring1_median" in m and "peak_fitted_sim_ring1_within_real_iqr" in m


def test_peak_frames_and_statistics_by_force():
    from vtcore.calibrate.validate import Validation, by_force, peak_frames

    real = np.array([[1.0, 0.0], [3.0, 1.0], [2.0, 0.0], [5.0, 1.0], [4.0, 4.0]])
    rec = np.array([0, 0, 0, 1, 1])
    force = np.array([0.5, 1.5, 1.0, 3.0, 2.5])
    ring = {"ring1": np.array([0.1, 0.2, 0.3, 0.4, np.nan])}
    v = Validation(real=real, sim=real, pressure=real, force=force, compression=force * 0, recording=rec,
                   frame=np.arange(5), held_out=rec == 1, baselines=np.zeros((2, 2)), paths=["a", "b"],
                   real_metrics=ring, sim_metrics={"ring1": ring["ring1"] * 2})
    assert peak_frames(v).tolist() == [False, True, False, True, False]
    b = by_force(v, ("ring1",), bins=2)
    assert b["frames"].sum() == 5 and np.all(np.diff(b["force_n"]) > 0)
    # the light bin holds 0.5, 1.0 (and 1.5) N: its real median is the median of their ring 1
    lo = force <= b["force_n"][0] * 1.5
    assert b["ring1_real"][0] == pytest.approx(np.median(ring["ring1"][lo]))
    assert np.allclose(b["ring1_sim"], 2 * b["ring1_real"], equal_nan=True)


def test_validate_without_plots_draws_no_figure(tmp_path):
    """``output.plots = false``: the footprints are validated, no figure drawn and left open (the runner
    closes only the figures it saves; drawing them was three quarters of a small validation's time)."""
    from vtcore.plots import pyplot

    plt = pyplot()
    plt.close("all")
    lay = load(HEX)
    rec = tmp_path / "press.txt"
    write_recording(rec, lay, synthetic_press(lay, np.random.default_rng(3), centre=lay.positions[0] + [0.004, 0.002, 0]))
    out = tmp_path / "out"
    assert main(["validate", str(rec), "--layout", str(HEX), "--scene", str(_scene(tmp_path, [rec])),
                 "--out", str(out)]) == 0
    assert plt.get_fignums() == [] and not list(out.glob("*.png"))
    assert (out / "result.json").exists()


def test_the_scene_sets_how_far_the_pad_wraps(tmp_path, capsys):
    """``task.wrap`` (0-1) reaches the matched presses and the result; outside 0-1 it is one error naming it."""
    lay = load(HEX)
    rec = tmp_path / "press.txt"
    write_recording(rec, lay, synthetic_press(lay, np.random.default_rng(5), centre=lay.positions[0]))
    scene = _scene(tmp_path, [rec])
    text = scene.read_text()
    scene.write_text(text.replace("[task]\n", "[task]\nwrap = 0.5\n"))
    assert main(["run", str(scene), "--out", str(tmp_path / "o")]) == 0
    assert json.loads((tmp_path / "o" / "result.json").read_text())["indenter"]["wrap"] == 0.5
    scene.write_text(text.replace("[task]\n", "[task]\nwrap = 1.5\n"))
    capsys.readouterr()
    assert main(["run", str(scene), "--out", str(tmp_path / "o2")]) == 2
    err = capsys.readouterr().err
    assert "task.wrap" in err and err.count("vtcore: error") == 1, err


def test_partly_matching_uids_are_masked_not_guessed(tmp_path, capsys):
    lay = load(HEX)
    rng = np.random.default_rng(4)
    frames = synthetic_press(lay, rng, centre=lay.positions[10])
    keep = np.arange(len(lay)) % 3 != 0                         # a third of the layout not recorded
    uids = np.concatenate([lay.taxel_ids[keep], [9991, 9992]])   # and two UIDs the layout lacks
    data = np.concatenate([frames[:, keep], np.full((len(frames), 2), 500.0)], axis=1)
    rec = tmp_path / "partial.txt"
    write_recording(rec, lay, data, uids=uids)
    out = tmp_path / "out"
    assert main(["validate", str(rec), "--layout", str(HEX), "--scene", str(_scene(tmp_path, [rec])),
                 "--out", str(out)]) == 0
    arr = np.load(out / "arrays.npz")
    assert np.isnan(arr["real"][:, ~keep]).all() and np.isnan(arr["sim"][:, ~keep]).all()
    assert np.isfinite(arr["real"][:, keep]).all() and np.isfinite(arr["sim"][:, keep]).all()
    assert "layout taxels recorded" in capsys.readouterr().err


def test_a_recording_without_contact_is_refused_with_its_name(tmp_path, capsys):
    lay = load(HEX)
    rng = np.random.default_rng(5)
    rec = tmp_path / "idle.txt"
    write_recording(rec, lay, np.clip(150 * rng.normal(size=(30, len(lay))), 0, None))
    rc = main(["validate", str(rec), "--layout", str(HEX), "--scene", str(_scene(tmp_path, [rec])),
               "--out", str(tmp_path / "out")])
    err = capsys.readouterr().err
    assert rc == 2 and "no contact frame" in err and "idle.txt" in err and "Traceback" not in err
    assert not (tmp_path / "out" / "result.json").exists()


def test_a_press_on_the_patch_border(tmp_path):
    lay = load(HEX)
    rng = np.random.default_rng(6)
    far = int(np.argmax(np.linalg.norm(lay.positions, axis=1)))
    rec = tmp_path / "edge.txt"
    write_recording(rec, lay, synthetic_press(lay, rng, centre=lay.positions[far] * 1.08, peak=9000.0))
    out = tmp_path / "out"
    assert main(["validate", str(rec), "--layout", str(HEX), "--scene", str(_scene(tmp_path, [rec])),
                 "--out", str(out)]) == 0
    arr = np.load(out / "arrays.npz")
    peaks = np.nanmax(arr["sim"], axis=1)
    assert (peaks > 3000).all()                        # the finger still meets the skin at its border
    m = footprint_metrics(arr["sim"], arr["positions"], arr["noise_sigma"])
    assert np.isfinite(m["ring1"]).all() and (m["active"] >= 1).all()


def test_no_recording_and_unknown_layout_uids(tmp_path, capsys):
    lay = load(HEX)
    rec = tmp_path / "other_skin.txt"
    write_recording(rec, lay, np.zeros((5, len(lay))), uids=lay.taxel_ids + 100000)
    rc = main(["validate", str(rec), "--layout", str(HEX), "--scene", str(_scene(tmp_path, [rec])),
               "--out", str(tmp_path / "o")])
    assert rc == 2 and "other_skin.txt" in capsys.readouterr().err


def test_calibrate_recovers_the_noise_of_written_recordings(tmp_path):
    lay = load(HEX)
    rng = np.random.default_rng(8)
    recs = []
    for i in range(3):
        p = tmp_path / f"idle_{i}.txt"
        write_recording(p, lay, np.clip(180 * rng.normal(size=(40, len(lay))), 0, None))
        recs.append(p)
    out = tmp_path / "p.toml"
    assert main(["calibrate", *map(str, recs), "--layout", str(HEX), "--out", str(out), "--noise-only"]) == 0
    from vtcore.contact.profile import load_profile

    prof = load_profile(out)
    assert abs(prof.noise_sigma / 180 - 1) < 0.08 and prof.response is None
    assert prof.raw["noise"]["naive_std_counts"] < 0.7 * prof.noise_sigma     # the clipped std is far lower


needs_shared = pytest.mark.skipif(not (SHARED / "1_finger").is_dir(), reason=f"shared recordings not at {SHARED}")


@pytest.fixture(scope="module")
def shipped_validation(tmp_path_factory):
    from vtcore.scene import run_scene

    return run_scene(ROOT / "scenes" / "validate_cyskin_gesture.toml", tmp_path_factory.mktemp("val") / "out")


def _inside(m, name, group="all"):
    return (m[f"{group}_sim_{name}_within_real_iqr"],
            (name, m[f"{group}_sim_{name}_median"], m[f"{group}_real_{name}_q25"], m[f"{group}_real_{name}_q75"]))


@needs_shared
@pytest.mark.slow
@pytest.mark.parametrize("name", ["ring1", "ring2", "active", "minor_mm"])
def test_the_shipped_scene_reproduces_the_real_footprints(shipped_validation, name):
    """Issue 27's 'Done when': the simulated median within the recorded IQR with the shipped profile and
    scene, on all 16 shared one-finger recordings (5 of them held out of the calibration)."""
    m = shipped_validation["metrics"]
    assert m["frames"] > 100 and m["recordings"] == 16 and m["frames_held_out"] > 30
    ok, detail = _inside(m, name)
    assert ok, detail


@needs_shared
@pytest.mark.slow
def test_bench_quick_writes_table_and_plot(tmp_path):
    """``vtcore bench calibrate --quick``: the noise-only calibration and a validation of 4 recordings
    at three grids (at least three points on the curve), accuracy beside time (timings never asserted)."""
    from vtcore.calibrate import bench

    rows = bench.run(tmp_path, quick=True)
    assert [r["step"] for r in rows] == ["calibrate (noise only)"] + ["validate"] * 3
    assert 120 < float(rows[0]["accuracy"].split()[1]) < 260          # the censored noise median, counts
    for row in rows[1:]:
        assert 0 <= row["within"] <= 4 and np.isfinite(row["worst_iqr"]) and row["frames"] > 10
    for name in ("table.md", "table.csv", "accuracy_vs_time.png"):
        assert (tmp_path / name).stat().st_size > 0
