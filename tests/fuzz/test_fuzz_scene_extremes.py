"""Fuzz of scene values at the extremes, run to the end (issue 28): ``vtcore run`` of a small scene
with one to three of its values set to 0, negative, 1e-320, 1e308, NaN, infinity, strings, lists,
tables, huge integers, or deleted.

``test_fuzz_scenes.py`` checks what the scene reader refuses (``--check``); this driver runs what it
accepts, so every value that reaches the physics, the sensor effects and the writers does. The keys
come from the schema itself: every field of the sections, the task and every registered effect
(an effect not listed in the seed is added by setting its key), so a new field is fuzzed without an
edit here. The seeds are a small press (a 10-taxel triangle patch, three readings, no plots), about
0.3 s a run, and the same press as a trajectory (five contact frames); each run is held to a 256 MiB memory budget (``VTCORE_MEMORY_BUDGET``) and a 2 s time
budget (``VTCORE_TIME_BUDGET``: a trajectory of at most ~200 contact frames), which bound what a large
valid value can ask for, and to the suite's 60 s alarm. Setting a keyframe's key
(``objects[0].keyframes[0].t``) turns the press into a trajectory.

Every run must end in exit 2 with one ``vtcore: error:`` line naming the scene, or exit 0 with a
``result.json`` of finite numbers (``null`` for an undefined metric) and an ``arrays.npz`` whose
float arrays are finite (docs/inputs.md lists the arrays whose NaN is documented; this scene has
none). Runs that end in exit 0 with ``vtcore: warning:`` lines are counted as ``warned``.
"""

from __future__ import annotations

import copy
import json
import shutil
from pathlib import Path

import numpy as np
import pytest
from hypothesis import strategies as st

from fuzzing import EXTREME_VALUES, OUTCOMES, assert_clean_exit, fuzz, run_cli

ROOT = Path(__file__).resolve().parents[2]
SCENE = {
    "scene": {"name": "fuzz_press", "task": "press", "seed": 1},
    "end_effector": {"shape": "plane", "size": [0.05, 0.05]},
    "layout": {"patch": "triangle"},
    "layer": {"thickness": 0.003, "material": "ecoflex_00_20", "grid_spacing": 0.0015, "samples_per_taxel": 3},
    "objects": [{"name": "ball", "kind": "sphere", "radius": 0.01, "position": [0.0, 0.0]}],
    "task": {"force": 2.0, "readings": 3, "rate": 20.0},
    "effects": {"soft_layer": {}, "gain": {}, "baseline": {}, "drift": {}, "noise": {}, "saturation": {},
                "quantisation": {}, "sampling": {"rate": 10.0}},
    "output": {"plots": False},
}
#: The same press as a trajectory: the ball follows two keyframes (5 contact frames at 20 Hz).
TRAJECTORY = {**SCENE, "objects": [{**SCENE["objects"][0], "keyframes": [
    {"t": 0.0}, {"t": 0.2, "offset": [0.0, 0.0, -0.002]}]}]}
#: TOML has no null: "delete the key" stands for it
DELETE = object()


def scene_keys() -> list[tuple[str, ...]]:
    """Every settable path of the seed's scene, from the schema (sections, the press task, all effects)."""
    from vtcore.scene import registry
    from vtcore.scene.loader import OUTPUT_SECTION, SCENE_SECTION

    registry.discover()

    def fields(section, prefix):
        out = []
        for name, f in section.fields.items():
            out.append((prefix + (name,), f.kind))
            if f.kind == "table" and f.section is not None:
                out += fields(f.section, prefix + (name,))
            elif f.kind == "tables" and f.section is not None:
                out += fields(f.section, prefix + (name, 0))
        return out

    # output.plots stays off: a figure takes seconds (a minute, on a loaded machine: the 60 s alarm
    # would call it a hang); the plot code runs in the scene tests
    keys = fields(SCENE_SECTION, ("scene",)) + [k for k in fields(OUTPUT_SECTION, ("output",))
                                                 if k[0] != ("output", "plots")]
    keys += fields(registry.TASKS["press"].params, ("task",))
    for name, spec in registry.SECTIONS.items():
        if spec.kind == "table" and spec.section is not None:
            keys += fields(spec.section, (name,))
        elif spec.kind == "tables" and spec.section is not None:
            keys += fields(spec.section, (name, 0))
    for name, eff in registry.EFFECTS.items():
        keys.append((("effects", name), "table"))
        keys += fields(eff.params, ("effects", name))
    return sorted(set(keys), key=str)


#: Extremes of each kind of value: most are valid, so the run reaches the physics with them.
BY_KIND = {
    "float": [0.0, -1.0, -1e308, 1e-320, 4.9e-324, 1e308, 1e-9, 1e9, 1e3, 0.5, float("nan"), float("inf")],
    "int": [0, -1, 1, 2, 1000, 10 ** 6, 10 ** 9, 2 ** 31, 2 ** 63 - 1],
    "vec": [[0.0, 0.0, 0.0], [1e308, 0.0, 0.0], [1e-320, 1e-320, 1e-320], [-1e308, 1e308], [0.0, 0.0], [1e3, 1e3],
            [float("nan"), 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, -1.0]],
    "str": ["", "x", "triangle", "hexagon", "strip:1000", "strip:1", "fill", "auto", "sphere", "cube", "plane",
            "mesh", "unrolled", "halfspace", "local", "numpy", "frictionless", "logmap", "project"],
    "bool": [True, False],
    "table": [{}],
}


def _toml_value(v):
    if isinstance(v, float) and v != v:
        return float("nan")
    return v


def apply(scene: dict, path: tuple, value) -> None:
    node = scene
    for i, p in enumerate(path[:-1]):
        if isinstance(p, int):
            if not isinstance(node, list):
                return  # the array of tables was replaced by something else: nothing to address
            if not node:
                node.append({})
            node = node[0]
            continue
        if not isinstance(node.get(p), (dict, list)):
            # an array of tables where the path goes on by index (objects[0].keyframes[0].t)
            node[p] = [] if isinstance(path[i + 1], int) else {}
        node = node[p]
    if not isinstance(node, dict):
        return
    if value is DELETE:
        node.pop(path[-1], None)
    else:
        node[path[-1]] = _toml_value(copy.deepcopy(value))  # the value lists are shared between examples


def _finite_json(text: str) -> None:
    def refuse(token):
        raise AssertionError(f"result.json holds {token}")

    json.loads(text, parse_constant=refuse)


@pytest.fixture(scope="module")
def keys():
    return scene_keys()


def test_fuzz_scene_values_at_the_extremes(keys, tmp_path, pytestconfig, monkeypatch):
    import tomli_w

    monkeypatch.setenv("VTCORE_MEMORY_BUDGET", "256M")
    monkeypatch.setenv("VTCORE_TIME_BUDGET", "2s")  # at most ~200 contact frames of a trajectory
    monkeypatch.setenv("VTCORE_PROGRESS", "0")
    src, out = tmp_path / "scene.toml", tmp_path / "out"
    generic = st.sampled_from([v for v in EXTREME_VALUES if v is not None] + [DELETE])

    def edit(key):
        path, kind = key
        own = BY_KIND.get(kind)
        value = st.one_of(st.sampled_from(own), st.sampled_from(own), st.sampled_from(own), generic) if own else generic
        return st.tuples(st.just(path), value)

    edits = st.tuples(st.sampled_from([SCENE, SCENE, TRAJECTORY]),
                      st.lists(st.sampled_from(keys).flatmap(edit), min_size=1, max_size=3))

    def check(example):
        seed, pairs = example
        scene = json.loads(json.dumps(seed))
        for path, value in pairs:
            apply(scene, path, value)
        try:
            text = tomli_w.dumps(scene)
        except (TypeError, ValueError):
            return  # not expressible as TOML (a key made a list of mixed tables): no file to try
        src.write_text(text, encoding="utf-8")
        if out.exists():
            shutil.rmtree(out)
        rc, so, se = run_cli("scene extremes", ["run", src, "--out", out])
        assert_clean_exit(rc, so, se)
        if rc == 2:
            assert str(src) in se, se
            return
        if "vtcore: warning:" in se:
            OUTCOMES["scene extremes"]["warned"] += 1
        _finite_json((out / "result.json").read_text(encoding="utf-8"))
        if (out / "arrays.npz").exists():
            with np.load(out / "arrays.npz") as z:
                for name in z.files:
                    a = z[name]
                    if a.dtype.kind in "fc":
                        assert np.isfinite(a).all(), f"arrays.npz {name} holds NaN or infinity"

    fuzz(pytestconfig, edits, check)
