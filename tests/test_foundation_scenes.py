"""Scene validation, the effect pipeline and the results contract (issue: foundation)."""

from __future__ import annotations

import json
import tomllib

import numpy as np
import pytest
import tomli_w

from vtcore.errors import SceneError
from vtcore.scene import EFFECTS, load_scene, registry, run_scene


@pytest.fixture
def demo(scenes_dir):
    return tomllib.loads((scenes_dir / "demo.toml").read_text())


def write_scene(tmp_path, data, name="scene.toml"):
    path = tmp_path / name
    path.write_text(tomli_w.dumps(data))
    return path


def test_demo_writes_results_contract(cli, tmp_path, scenes_dir):
    out = tmp_path / "demo"
    res = cli("run", scenes_dir / "demo.toml", "--out", out)
    assert res.returncode == 0, res.stderr
    result = json.loads((out / "result.json").read_text())
    for key in ("scene", "seed", "effects", "metrics", "versions", "seconds"):
        assert key in result
    assert all(set(e) == {"name", "seconds"} for e in result["effects"])
    assert all(isinstance(v, (int, float)) or v is None for v in result["metrics"].values())
    assert result["versions"]["numpy"] == np.__version__
    pngs = list(out.glob("*.png"))
    assert pngs, "the demo must draw the patch and its responses"
    report = (out / "report.md").read_text()
    assert all(f"]({p.name})" in report for p in pngs)
    with np.load(out / "arrays.npz") as z:
        n = z["positions"].shape[0]
        assert z["positions"].shape == (n, 3) and z["normals"].shape == (n, 3)
        t = z["timestamps"].shape[0]
        assert z["frames"].shape == (t, n) and z["pressure"].shape == (t, n)
        assert np.all(np.isfinite(z["frames"]))
        assert z["frames"].max() > 0


@pytest.mark.parametrize("edit, needle", [
    (lambda d: d["layer"].__setitem__("thicknes", 0.003), "layer.thicknes"),
    (lambda d: d["layer"].__setitem__("thickness", -0.003), "layer.thickness"),
    (lambda d: d["end_effector"].__setitem__("mesh", "missing.stl"), "missing.stl"),
    (lambda d: d["effects"].__setitem__("nosie", {}), "effects.nosie"),
    (lambda d: d["scene"].__setitem__("seed", "one"), "scene.seed"),
    (lambda d: d.__setitem__("lyer", {}), "lyer"),
])
def test_bad_scene_exits_2_with_one_line_naming_the_key(cli, tmp_path, demo, edit, needle):
    edit(demo)
    path = write_scene(tmp_path, demo)
    res = cli("run", path, "--out", tmp_path / "out")
    assert res.returncode == 2
    lines = res.stderr.strip().splitlines()
    assert len(lines) == 1, res.stderr
    assert needle in lines[0] and str(path) in lines[0]
    assert "Traceback" not in res.stderr
    assert not (tmp_path / "out" / "result.json").exists()


def test_misspelled_key_suggests_the_right_one(tmp_path, demo):
    demo["layer"]["thicknes"] = demo["layer"].pop("thickness")
    with pytest.raises(SceneError, match="did you mean 'thickness'"):
        load_scene(write_scene(tmp_path, demo))


def test_invalid_toml_names_the_line(tmp_path):
    path = tmp_path / "broken.toml"
    path.write_text('[scene]\ntask = "press"\nseed = = 3\n')
    with pytest.raises(SceneError) as exc:
        load_scene(path)
    assert exc.value.line == 3 and "broken.toml:3" in str(exc.value)


def test_set_overrides_values_and_validates_them(tmp_path, scenes_dir):
    scene = load_scene(scenes_dir / "demo.toml", ["layer.thickness=0.006", "scene.seed=7"])
    assert scene["layer"]["thickness"] == 0.006 and scene.seed == 7
    with pytest.raises(SceneError, match="layer.thickness"):
        load_scene(scenes_dir / "demo.toml", ["layer.thickness=-1"])
    with pytest.raises(SceneError, match="key=value"):
        load_scene(scenes_dir / "demo.toml", ["layer.thickness"])


def _spy_factories(monkeypatch):
    """Wrap every registered effect so the test sees which are built and applied."""
    registry.discover()
    built, applied = [], []
    for name, spec in list(EFFECTS.items()):
        def factory(params, ctx, _name=name, _orig=spec.factory):
            built.append(_name)
            obj = _orig(params, ctx)
            if hasattr(obj, "apply"):
                orig_apply = obj.apply

                def apply(state, c, _n=_name):
                    applied.append(_n)
                    return orig_apply(state, c)

                obj.apply = apply
            return obj
        monkeypatch.setattr(spec, "factory", factory)
    return built, applied


def test_unlisted_effects_are_never_built_nor_called(monkeypatch, tmp_path, demo):
    built, applied = _spy_factories(monkeypatch)
    demo["effects"] = {"noise": {"sigma": 5.0}, "gain": {}}
    out = tmp_path / "out"
    result = run_scene(write_scene(tmp_path, demo), out)
    assert set(built) == {"gain", "noise"}
    assert set(applied) <= {"gain", "noise"} and "gain" in applied
    assert [e["name"] for e in result["effects"]] == ["gain", "noise"]  # physical order, not file order
    assert [e["name"] for e in json.loads((out / "result.json").read_text())["effects"]] == ["gain", "noise"]


def test_no_effects_listed_means_ideal_sensor(monkeypatch, tmp_path, demo):
    built, applied = _spy_factories(monkeypatch)
    demo["effects"] = {}
    result = run_scene(write_scene(tmp_path, demo), tmp_path / "out")
    assert built == [] and applied == [] and result["effects"] == []
    with np.load(tmp_path / "out" / "arrays.npz") as z:
        np.testing.assert_array_equal(z["frames"], z["pressure"])  # no sensor effect: counts == pascals


def test_same_seed_gives_byte_identical_arrays(tmp_path, scenes_dir):
    run_scene(scenes_dir / "demo.toml", tmp_path / "a")
    run_scene(scenes_dir / "demo.toml", tmp_path / "b")
    assert (tmp_path / "a" / "arrays.npz").read_bytes() == (tmp_path / "b" / "arrays.npz").read_bytes()
    run_scene(scenes_dir / "demo.toml", tmp_path / "c", overrides=["scene.seed=99"])
    with np.load(tmp_path / "a" / "arrays.npz") as a, np.load(tmp_path / "c" / "arrays.npz") as c:
        assert not np.array_equal(a["frames"], c["frames"])  # the noise depends on the seed


def test_pipeline_orders_by_stage_not_by_listing():
    registry.discover()
    sensor = [n for n, s in EFFECTS.items() if s.stage == "sensor"]
    contact = [n for n, s in EFFECTS.items() if s.stage == "contact"]
    listed = {n: EFFECTS[n].params.validate({}, _ctx(), prefix=n) for n in reversed(sensor + contact)}
    pipe = registry.Pipeline(listed)
    stages = [registry.STAGES.index(EFFECTS[n].stage) for n in pipe.names]
    assert stages == sorted(stages)


def _ctx():
    from pathlib import Path

    from vtcore.scene.schema import Context

    return Context(file="t", base=Path("."))
