"""Contact scenes: press task modes, effects only when listed, the 12 seed-001 scenes, the benchmark."""

import json

import numpy as np
import pytest

from vtcore.scene import EFFECTS, registry, run_scene


def _write(tmp_path, text):
    p = tmp_path / "s.toml"
    p.write_text(text)
    return p


BASE = """
[scene]
name = "t"
task = "press"
seed = 3
[end_effector]
shape = "plane"
[layout]
patch = "hexagon"
[layer]
thickness = 0.003
extent = 0.04
grid_spacing = 0.0015
samples_per_taxel = 3
[[objects]]
name = "ball"
kind = "sphere"
radius = 0.03
stiffness = 2000.0
{extra_obj}
[task]
{task}
[output]
plots = false
"""


def _spy(monkeypatch):
    registry.discover()
    built = []
    for name, spec in list(EFFECTS.items()):
        def factory(params, ctx, _n=name, _orig=spec.factory):
            built.append(_n)
            return _orig(params, ctx)
        monkeypatch.setattr(spec, "factory", factory)
    return built


def test_all_contact_and_sensor_effects_run_in_order(tmp_path, monkeypatch):
    built = _spy(monkeypatch)
    text = BASE.format(extra_obj="", task="force = 10.0\nreadings = 6") + """
[effects.soft_layer]
[effects.object_compliance]
[effects.gain]
[effects.baseline]
offset = 100.0
spread = 5.0
[effects.drift]
rate = 2.0
[effects.noise]
sigma = 3.0
[effects.saturation]
[effects.quantisation]
[effects.sampling]
rate = 10.0
"""
    res = run_scene(_write(tmp_path, text), tmp_path / "o")
    names = [e["name"] for e in res["effects"]]
    # saturation runs but changes nothing here (counts from a 100 offset, far below the ceiling):
    # the effect contract reports it as not applied (docs/inputs.md)
    assert names == ["soft_layer", "object_compliance", "gain", "baseline", "drift", "noise",
                     "quantisation", "sampling"]
    assert res["effects_not_applied"] == ["saturation"]
    assert set(built) == set(names) | {"saturation"}
    m = res["metrics"]
    assert m["force_n"] == pytest.approx(10.0, rel=1e-6)
    # series compliance: the object's own deflection is F / k on top of the layer's indentation
    assert m["displacement_mm"] == pytest.approx(m["indentation_mm"] + 10.0 / 2000.0 * 1e3, rel=1e-6)
    with np.load(tmp_path / "o" / "arrays.npz") as z:
        t, n = z["frames"].shape
        assert t == 3 and n == 60  # 6 readings at 20 Hz sampled at 10 Hz
        assert z["pressure"].shape == (t, n) and z["timestamps"].shape == (t,)
        assert np.all(z["frames"] == np.round(z["frames"])) and z["frames"].min() >= 0
        assert "grid_stress" in z.files


def test_unlisted_contact_effects_are_never_built(tmp_path, monkeypatch):
    built = _spy(monkeypatch)
    res = run_scene(_write(tmp_path, BASE.format(extra_obj="", task="force = 5.0\nreadings = 2")), tmp_path / "o")
    assert built == [] and res["effects"] == []
    assert "displacement_mm" not in res["metrics"]
    with np.load(tmp_path / "o" / "arrays.npz") as z:
        np.testing.assert_array_equal(z["frames"], z["pressure"])  # no spreading, no sensor
        np.testing.assert_array_equal(z["pressure"], z["surface_pressure"])
        assert "grid_stress" not in z.files


def test_keyframed_trajectory_and_target_response(tmp_path):
    kf = """keyframes = [{t = 0.0, offset = [0.0, 0.0, 0.0]}, {t = 0.2, offset = [0.0, 0.0, -0.0025]},
             {t = 0.4, offset = [0.004, 0.0, -0.0025]}]"""
    res = run_scene(_write(tmp_path, BASE.format(extra_obj=kf, task="rate = 20.0")), tmp_path / "o")
    with np.load(tmp_path / "o" / "arrays.npz") as z:
        f = z["force"]
        assert len(f) == 9 and f[0] == 0 and f[4] > 0 and np.all(np.diff(f[:5]) >= 0)
    assert res["metrics"]["solver_converged"]
    text = BASE.format(extra_obj="", task="target_response = 300.0\nreadings = 1") + "[effects.gain]\n"
    res = run_scene(_write(tmp_path, text), tmp_path / "p")
    assert res["metrics"]["response_mean"] == pytest.approx(300.0, rel=1e-3)


def test_scene_errors_name_the_object_key(tmp_path):
    from vtcore.errors import SceneError

    text = BASE.format(extra_obj='open_mesh = "sometimes"', task="force = 1.0")
    with pytest.raises(SceneError, match=r"objects\[0\]\.open_mesh"):
        run_scene(_write(tmp_path, text), tmp_path / "o")


@pytest.mark.slow
def test_seed001_scenes_validate_and_one_runs(tmp_path, scenes_dir):
    from vtcore.scene import load_scene

    files = sorted(scenes_dir.glob("press_*mm.toml"))
    assert len(files) == 12
    for f in files:
        s = load_scene(f)
        assert s["task"]["force"] == 10.0 and s["layer"]["extent"] == 0.04
    res = run_scene(scenes_dir / "press_cube_3mm.toml", tmp_path / "c")
    assert res["metrics"]["force_n"] == pytest.approx(10.0, rel=1e-6)
    assert json.loads((tmp_path / "c" / "result.json").read_text())["figures"]


def test_bench_quick(tmp_path):
    from vtcore.contact import bench

    rows = bench.run(tmp_path, quick=True)
    assert rows and {"model", "grid_mm", "samples", "error", "ms_per_frame"} <= set(rows[0])
    for name in ("table.md", "table.csv", "accuracy_vs_time.png"):
        assert (tmp_path / name).exists()


@pytest.mark.parametrize("codec", ["icub", "cyskin16"])
def test_can_transport_runs_after_the_sensor_stage(tmp_path, codec):
    """[effects.can] in a press scene: listed in result.json, frames stay (T, N) and equal the
    codec's quantisation of the counts the sensor stage produced (same seed, no noise)."""
    sensor = "[effects.gain]\ncounts_per_pa = 0.3\n[effects.baseline]\noffset = -21.5\nspread = 0.0\n"
    text = BASE.format(extra_obj="", task="force = 3.0\nreadings = 4") + sensor
    ref = run_scene(_write(tmp_path, text), tmp_path / "ref")
    can = f'[effects.can]\ncodec = "{codec}"\nperiod = 0.05\n'
    res = run_scene(_write(tmp_path, text + can), tmp_path / "can")
    assert [e["name"] for e in res["effects"]] == ["gain", "baseline", "can"]
    assert [e["name"] for e in ref["effects"]] == ["gain", "baseline"]
    with np.load(tmp_path / "ref" / "arrays.npz") as z:
        counts = z["frames"]
    with np.load(tmp_path / "can" / "arrays.npz") as z:
        frames, pressure = z["frames"], z["pressure"]
    assert frames.shape == counts.shape == pressure.shape == (4, 60)
    assert counts.max() > 960 and counts.min() < 0  # both ends of the iCub wire range are exercised
    if codec == "icub":  # 8-bit inverted: steps of 4 counts, -60..960 around the baseline
        want = np.clip(np.floor(counts / 4.0) * 4.0, -60.0, 960.0)
        assert np.all(frames % 4 == 0)
    else:  # 16-bit counts, rounded and clipped at 0
        want = np.clip(np.rint(counts), 0.0, 65535.0)
    np.testing.assert_array_equal(frames, want)
    assert res["metrics"]["response_max"] == pytest.approx(float(want.mean(axis=0).max()))


@pytest.mark.parametrize("angle", [0.0, 30.0])
def test_profile_cuts_through_the_contact_centre_and_matches_the_taxels(tmp_path, angle):
    """The profile is a cut through the pressure's centre along the stated direction, and the taxels
    drawn on it are their own readings of the field whose taxel-disc mean the plot draws (the old
    plot cut along the row of largest total pressure, an edge row of the cube, and drew counts)."""
    text = BASE.format(extra_obj="", task=f"force = 6.0\nreadings = 1\nprofile_angle = {angle}")
    text = text.replace('kind = "sphere"\nradius = 0.03', 'kind = "cube"\nside = 0.02\nposition = [0.003, 0.0]')
    text = text.replace("plots = false", "plots = true") + "[effects.soft_layer]\n"
    run_scene(_write(tmp_path, text), tmp_path / "o")
    assert (tmp_path / "o" / "profile.png").exists()
    with np.load(tmp_path / "o" / "arrays.npz") as z:
        gx, gy, gp = z["grid_x"], z["grid_y"], z["grid_pressure"]
        X, Y = np.meshgrid(gx, gy, indexing="ij")
        centre = np.array([(X * gp).sum(), (Y * gp).sum()]) / gp.sum()
        c, d = z["profile_centre"], z["profile_direction"]
        np.testing.assert_allclose(c[:2], centre, atol=1e-9)  # flat patch: grid axes = end-effector x, y
        assert abs(c[0] - 0.003) < 3e-4 and abs(c[1]) < 3e-4
        np.testing.assert_allclose(d, [np.cos(np.deg2rad(angle)), np.sin(np.deg2rad(angle)), 0.0], atol=1e-12)
        s, line = z["profile_s"], z["profile_disc_mean"]
        ts, off, val = z["profile_taxel_s"], z["profile_taxel_offset"], z["profile_taxel_pressure"]
        idx = z["profile_taxel_index"]
        np.testing.assert_array_equal(val, z["pressure"][-1][idx])
        assert len(idx) and np.all(np.abs(off) < 2e-3) and np.all(np.diff(ts) >= 0)
        # a taxel centred on the cut reads the disc-mean curve at its position
        near = np.abs(off) < 3e-4
        if angle == 0.0:
            assert near.sum() >= 5  # the hexagon's middle row (y = 0) lies on the cut
        scale = z["pressure"][-1].max()
        np.testing.assert_allclose(val[near], np.interp(ts[near], s, line), atol=0.03 * scale)
        # the cut crosses the middle of the contact, not an edge row
        k = np.argmin(np.abs(s))
        assert z["profile_surface_pressure"][k] > 0 and z["profile_stress"].max() > 0.5 * z["grid_stress"].max()


def test_layer_geometry_unrolled_on_the_curved_end_effector(tmp_path):
    """[layer] geometry = "unrolled" reaches press: the grid is the layout's flat domain (profile in
    flat coordinates), force on target, taxels on the curved patch read the pressure."""
    text = """
[scene]
name = "curved"
task = "press"
seed = 1
[end_effector]
shape = "seed002_curved"
[layer]
thickness = 0.003
grid_spacing = 0.001
samples_per_taxel = 3
geometry = "unrolled"
[[objects]]
name = "cube"
kind = "cube"
side = 0.02
position = [-0.03, 0.0]
[task]
force = 4.0
readings = 1
[effects.soft_layer]
[output]
plots = false
"""
    res = run_scene(_write(tmp_path, text), tmp_path / "o")
    assert res["metrics"]["force_n"] == pytest.approx(4.0, rel=1e-6) and res["metrics"]["solver_converged"]
    with np.load(tmp_path / "o" / "arrays.npz") as z:
        assert z["profile_centre"][2] == 0.0 and z["profile_centre"][0] == pytest.approx(-0.03, abs=1e-3)
        assert len(z["profile_taxel_index"]) >= 2 and z["pressure"][0].max() > 0
        # the flat grid spans the unrolled patch (136 mm long), not its 110 mm projection
        assert np.ptp(z["grid_x"]) > 0.13
