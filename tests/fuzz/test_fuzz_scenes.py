"""Fuzz of the scene reader: mutated scene files and ``--set`` overrides through ``vtcore run --check``.

``--check`` reads, overrides and validates the scene and checks the output folder,
exactly as ``vtcore run`` does before it starts work; running every mutant would take
seconds each (the run-time guards have their own tests in test_inputs_guards.py).
Seeds: a few of the repository's scenes. Scene errors may list several keys, one per
line, under one ``vtcore: error:``.
"""

from __future__ import annotations

from pathlib import Path

import pytest
from hypothesis import strategies as st

from fuzzing import NASTY_NUMBERS, assert_clean_exit, fuzz, mutated, run_cli

ROOT = Path(__file__).resolve().parents[2]
SEEDS = ["press_cube_3mm.toml", "category_3mm.toml", "replay_icub_press.toml", "demo.toml",
         "augment_sponge_ball.toml", "contour_mug_curved.toml"]


@pytest.fixture(scope="module")
def scene_dir(tmp_path_factory):
    """The seed scenes copied next to copies of the files they refer to (relative paths keep working)."""
    import shutil

    d = tmp_path_factory.mktemp("scenes")
    for sub in ("data", "layouts"):
        shutil.copytree(ROOT / "scenes" / sub, d / sub)
    return d


def test_fuzz_scene_files(scene_dir, tmp_path, pytestconfig):
    blobs = [(ROOT / "scenes" / s).read_bytes() for s in SEEDS]
    src = scene_dir / "fuzzed.toml"

    def check(data):
        src.write_bytes(data)
        rc, so, se = run_cli("scene file", ["run", src, "--check", "--out", tmp_path / "out"])
        assert_clean_exit(rc, so, se, lines=None)

    fuzz(pytestconfig, mutated(blobs), check)


_KEYS = ["scene", "scene.seed", "scene.task", "task", "task.force", "task.readings", "layer", "layer.thickness",
         "layer.young_modulus", "layer.samples_per_taxel", "layer.grid_spacing", "layout.patch", "layout",
         "effects", "effects.quantisation", "effects.quantisation.step", "effects.noise.sigma", "output",
         "objects", "end_effector.radius", "x.y.z", "scene.seed.x", ""]
_VALUES = st.one_of(st.sampled_from(NASTY_NUMBERS + ['"strip:100000"', '"strip:0"', '"strip:x"', "5", "[1, 2]",
                                                     "{a = 1}", "'", "\"unterminated", "1e9", "1000000"]),
                    st.text(max_size=12))


def test_fuzz_scene_overrides(scene_dir, tmp_path, pytestconfig):
    import shutil

    src = scene_dir / "press.toml"
    shutil.copy(ROOT / "scenes" / "press_cube_3mm.toml", src)

    def check(pairs):
        argv = ["run", src, "--check", "--out", tmp_path / "out"]
        for k, v in pairs:
            argv += ["--set", f"{k}={v}"]
        rc, so, se = run_cli("scene --set", argv)
        assert_clean_exit(rc, so, se, lines=None)

    fuzz(pytestconfig, st.lists(st.tuples(st.sampled_from(_KEYS), _VALUES), min_size=1, max_size=3), check)
