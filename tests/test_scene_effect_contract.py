"""The effect contract (issue 34; docs/inputs.md, "The effect contract"), task by task.

- *Remove one*: for every effect a shipped scene lists, the run without it changes an output
  (``arrays.npz`` or a metric), or the effect was reported as not applied, or the task refuses
  to run without it (naming the effect).
- *Add one*: an effect the scene does not list is refused in one line naming the effect and the
  task (tasks that cannot apply it), or it is applied and changes an output, or it is reported in
  ``effects_not_applied`` (never reported as applied while changing nothing).
- ``effects`` in result.json lists exactly the applied effects.

Each task runs on a small version of one of its shipped scenes (few frames, runs, taxels).
"""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import pytest

from vtcore.errors import VtError
from vtcore.scene import load_scene, run_scene
from vtcore.scene import registry

ROOT = Path(__file__).resolve().parents[1]
NOPLOT = ["output.plots=false"]

#: task -> (shipped scene, cheap overrides, effects to add: name -> parameters over the defaults)
CASES = {
    "press": ("press_cube_3mm", ["task.readings=2", "layer.grid_spacing=0.002"],
              {"object_compliance": {}, "drift": {"rate": 50.0}}),
    "edge_press": ("two_finger_press", ["task.readings=2"], {"object_compliance": {}, "drift": {"rate": 50.0}}),
    "contour": ("contour_ruler_planar", ["task.runs=1", "task.max_taps=4"], {"object_compliance": {}}),
    "replay": ("replay_cyskin16_slide", [], {"noise": {"sigma": 500.0}, "can": {}}),
    "evaluate": ("evaluate_hexagon", ["task.spacing=0.006", "task.draws=2", "task.two_point=false"],
                 {"noise": {"sigma": 50.0}}),
    "augment": ("augment_empty_bottle", ['task.probe="series"'], {"drift": {"rate": 50.0}, "can": {}}),
    "reach": ("reach_clutter", [], {"can": {}}),
    # one reading of one trial, no jitter or resolution study: the tactile images still pass every effect
    "categorize": ("category_3mm", ["task.readings=1", "task.trials=1", "task.jitter_seeds=0",
                                    "task.resolution_runs=0", "task.kmeans_runs=1"], {"object_compliance": {}}),
    # two objects, 5 contact probes each (10 distinct 3-touch clouds per subsample), one epoch
    "classify": ("classify_touches", ['task.objects=["empty_bottle","tennis_ball"]', "task.probes_bottle=5",
                                      "task.probes_other=5", "task.points=500", "task.touches=[3]",
                                      'task.propagations=["cluster"]', "task.geometry_only=false",
                                      "task.per_object=10", "task.subsamples=2", "task.cloud_points=32",
                                      "task.epochs=1", "task.active=false", "task.quick=true", 'task.device="cpu"'],
                 {"can": {}}),
    # 4 probes, 3 contact stations along 1 cm of the bottle
    "path_following": ("path_following_bottle", ["task.touches=4", "task.stations=3", "task.points=2000",
                                                 "task.readings=2", "task.length=0.01", "task.dt=0.01",
                                                 "task.setpoint_period=0.02", "task.speed=0.005"], {"can": {}}),
    # one recording, a 2 mm grid and one sample per taxel
    "validate": ("validate_cyskin_gesture",
                 ['task.recordings=["../../shared/data/cyskin_gesture/1_finger/sample_01.txt"]',
                  "layer.grid_spacing=0.002", "layer.samples_per_taxel=1"], {"baseline": {}}),
}

#: what a task needs beyond the checkout: (python module, why)
NEEDS = {"classify": ("torch", "PointNet needs the optional extra vtcore[learn]")}


def _run(scene, out):
    """(result, outputs): the run's result.json and what it wrote that a user reads (arrays, metrics)."""
    res = run_scene(scene, out)
    # timings are not outputs of the model ("cluster_ms", "..._s")
    metrics = {k: v for k, v in res["metrics"].items() if not k.endswith(("_ms", "_s", "seconds"))}
    return res, ((out / "arrays.npz").read_bytes() if (out / "arrays.npz").exists() else b"",
                 json.dumps(metrics, sort_keys=True))


def _scene(task):
    name, sets, _ = CASES[task]
    if task in NEEDS:
        pytest.importorskip(NEEDS[task][0], reason=NEEDS[task][1])
    try:
        return load_scene(ROOT / "scenes" / f"{name}.toml", NOPLOT + sets)
    except VtError as exc:  # validate's recordings are beside the repository (shared/), not in it
        if "shared" not in str(exc):
            raise
        pytest.skip(f"{name} does not load here: {exc}")


def _with_effects(scene, effects):
    return dataclasses.replace(scene, effects=effects)


class _Baselines(dict):
    """task -> (result, outputs) of its unchanged small scene, run on first use (a task that
    cannot run here skips only its own tests)."""

    def __init__(self, tmp_path_factory):
        super().__init__()
        self.tmp = tmp_path_factory

    def __missing__(self, task):
        self[task] = _run(_scene(task), self.tmp.mktemp(task) / "base")
        return self[task]


@pytest.fixture(scope="module")
def baselines(tmp_path_factory):
    return _Baselines(tmp_path_factory)


@pytest.mark.parametrize("task", list(CASES))
def test_effects_reports_exactly_the_applied_ones(task, baselines):
    res, _ = baselines[task]
    listed = list(_scene(task).effects)
    applied = [e["name"] for e in res["effects"]]
    assert sorted(applied + res["effects_not_applied"]) == sorted(listed)
    assert all(e["seconds"] >= 0 for e in res["effects"])


@pytest.mark.slow
@pytest.mark.parametrize("task", list(CASES))
def test_removing_each_listed_effect_changes_an_output(task, baselines, tmp_path):
    scene = _scene(task)
    res0, out0 = baselines[task]
    for name in scene.effects:
        fewer = {k: v for k, v in scene.effects.items() if k != name}
        try:
            _, out1 = _run(_with_effects(scene, fewer), tmp_path / f"no_{name}")
        except VtError as exc:  # the task needs it: refused, naming it
            assert f"effects.{name}" in str(exc) or f"[effects.{name}]" in str(exc), str(exc)
            continue
        if name in res0["effects_not_applied"]:
            assert out1 == out0, f"{name} was reported not applied, yet removing it changed an output"
        else:
            assert out1 != out0, f"{task}: removing the applied effect {name} changed no output"


@pytest.mark.parametrize("task", list(CASES))
def test_adding_an_unlisted_effect_is_refused_or_accounted(task, baselines, tmp_path):
    scene = _scene(task)
    _, out0 = baselines[task]
    for name, params in CASES[task][2].items():
        assert name not in scene.effects
        more = {**scene.effects, name: {**registry.EFFECTS[name].params.defaults(), **params}}
        spec = registry.TASKS[scene.task]
        if name not in spec.effects:
            with pytest.raises(VtError) as exc:
                run_scene(_with_effects(scene, more), tmp_path / f"plus_{name}")
            msg = str(exc.value)
            assert f"effects.{name}" in msg and f"'{scene.task}'" in msg and "\n" not in msg
            continue
        res1, out1 = _run(_with_effects(scene, more), tmp_path / f"plus_{name}")
        if name in res1["effects_not_applied"]:
            assert out1 == out0
        else:
            assert name in [e["name"] for e in res1["effects"]] and out1 != out0


def test_replay_refuses_noise_in_one_line(tmp_path):
    with pytest.raises(VtError) as exc:
        run_scene(ROOT / "scenes" / "replay_cyskin16_slide.toml", tmp_path,
                  overrides=NOPLOT + ["effects.noise.sigma=500"])
    msg = str(exc.value)
    assert "effects.noise" in msg and "'replay'" in msg and "\n" not in msg


def test_spreading_inside_the_press_is_timed_under_soft_layer(baselines):
    # edge_press spreads inside press(): the time is the soft_layer effect's, not 0
    res, _ = baselines["edge_press"]
    secs = {e["name"]: e["seconds"] for e in res["effects"]}
    assert secs["soft_layer"] > 0


def test_no_task_spreads_without_soft_layer(tmp_path):
    scene = _scene("edge_press")
    fewer = {k: v for k, v in scene.effects.items() if k != "soft_layer"}
    res = run_scene(_with_effects(scene, fewer), tmp_path)
    assert not any(w["key"] == "effects.soft_layer" for w in res["warnings"]), res["warnings"]
    assert "soft_layer" not in [e["name"] for e in res["effects"]]


def test_every_task_declares_its_effects():
    registry.discover()
    known = set(registry.EFFECTS)
    for name, spec in registry.TASKS.items():
        assert set(spec.effects) <= known, name


@pytest.mark.parametrize("scene_name, effect", [
    ("category_3mm", "object_compliance"),      # categorize reads no displacement
    ("classify_touches", "can"),                # no transport stage
    ("path_following_bottle", "can"),
    ("evaluate_hexagon", "gain"),               # its sensor is the task's own noise model
    ("validate_cyskin_gesture", "baseline"),    # it was reported, and changed nothing
    ("validate_cyskin_gesture", "drift"),
])
def test_tasks_refuse_what_they_cannot_apply_before_running(scene_name, effect, tmp_path):
    path = ROOT / "scenes" / f"{scene_name}.toml"
    try:
        scene = load_scene(path, NOPLOT)
    except VtError as exc:  # the recordings' folder is not in this checkout (shared/)
        pytest.skip(f"{scene_name} does not load here: {exc}")
    more = {**scene.effects, effect: registry.EFFECTS[effect].params.defaults()}
    with pytest.raises(VtError) as exc:
        run_scene(_with_effects(scene, more), tmp_path / "o")
    msg = str(exc.value)
    assert f"effects.{effect}" in msg and f"task '{scene.task}' cannot apply" in msg and "\n" not in msg
    assert not (tmp_path / "o").exists()


def test_validate_needs_soft_layer(tmp_path):
    path = ROOT / "scenes" / "validate_cyskin_gesture.toml"
    try:
        scene = load_scene(path, NOPLOT)
    except VtError as exc:
        pytest.skip(f"validate_cyskin_gesture does not load here: {exc}")
    fewer = {k: v for k, v in scene.effects.items() if k != "soft_layer"}
    with pytest.raises(VtError, match=r"effects\.soft_layer"):
        run_scene(_with_effects(scene, fewer), tmp_path / "o")
