"""Fuzz of ``vtcore validate`` (a validate scene) with mutated recordings and mutated sensor profiles,
and of ``vtcore evaluate`` with mutated layouts (issue 37).

- validate: a small scene (the 28-taxel CySkin hexagon, one written recording of 14 frames with one
  elongated press, no plots) whose gain and noise profile is a copy of the shipped CySkin profile
  (its ``[taxels]`` cut to 24 entries). A recording is mutated byte by byte (:func:`fuzzing.mutated`);
  a profile field by field (a value set to an extreme, a table made a list, keys deleted, copied, added:
  :func:`fuzzing.mutated_toml`) or byte by byte.
- evaluate: ``vtcore evaluate LAYOUT --mesh BOX`` with a coarse probe grid, the layout our JSON of a
  triangle patch placed on the box, edited field by field or byte by byte, or the iCub text of it.

Each run must end in exit 2 with one ``vtcore: error:`` line and nothing left where its output would
have gone (the folder not made), or exit 0 with a ``result.json`` of finite numbers and arrays that
are finite except where the task documents NaN (``arrays_nan``).
"""

from __future__ import annotations

import json
import shutil
import tomllib
from pathlib import Path

import numpy as np
import pytest
from hypothesis import strategies as st

from fuzzing import (OUTCOMES, assert_clean_exit, finite_json_text, fuzz, listing, mutated, mutated_doc,
                     mutated_toml, run_cli, warm_up)

ROOT = Path(__file__).resolve().parents[2]
HEX = ROOT / "scenes" / "layouts" / "seed001_hexagon.cyskin.json"
SCENE = """
[scene]
name = "v"
task = "validate"
seed = 2
[layout]
file = "{layout}"
[layer]
thickness = 0.004
grid_spacing = 0.003
samples_per_taxel = 1
[[objects]]
kind = "fingerpad"
[task]
recordings = ["rec.txt"]
[effects.soft_layer]
[effects.gain]
profile = "{profile}"
[effects.noise]
profile = "{profile}"
[effects.saturation]
[effects.quantisation]
[output]
plots = false
"""


def _check_result(out: Path) -> None:
    """result.json finite; its float arrays finite except the NaN it documents."""
    res = finite_json_text((out / "result.json").read_text(encoding="utf-8"))
    documented = res.get("arrays_nan") or {}
    if (out / "arrays.npz").exists():
        with np.load(out / "arrays.npz") as z:
            for name in z.files:
                a = z[name]
                if a.dtype.kind in "fc" and name not in documented:
                    assert np.isfinite(a).all(), f"arrays.npz {name} holds NaN or infinity"


@pytest.fixture(scope="module")
def validate_case(tmp_path_factory):
    """(folder with v.toml, rec.txt, p.toml; recording bytes; profile document)."""
    from test_calibrate_validate import synthetic_press, write_recording

    from vtcore.contact.profile import PROFILES_DIR
    from vtcore.layout import load

    d = tmp_path_factory.mktemp("validate_case")
    lay = load(HEX)
    rng = np.random.default_rng(3)
    write_recording(d / "rec.txt", lay, synthetic_press(lay, rng, centre=lay.positions.mean(0), n_frames=14,
                                                        contact=range(5, 9)))
    doc = tomllib.loads((PROFILES_DIR / "cyskin.toml").read_text(encoding="utf-8"))
    doc["taxels"] = {k: v[:24] for k, v in doc["taxels"].items()}
    doc["response"]["held_out"] = ["rec.txt"]
    return d, (d / "rec.txt").read_bytes(), json.loads(json.dumps(doc))


def _run_validate(folder: Path, reader: str) -> None:
    (folder / "v.toml").write_text(SCENE.format(layout=HEX.as_posix(), profile=(folder / "p.toml").as_posix()),
                                   encoding="utf-8")
    out = folder / "out"
    shutil.rmtree(out, ignore_errors=True)
    rc, so, se = run_cli(reader, ["run", folder / "v.toml", "--out", out])
    assert_clean_exit(rc, so, se)
    if rc == 2:
        assert listing(out) == [] and not out.exists(), listing(out)
        return
    if "vtcore: warning:" in se:
        OUTCOMES[reader]["warned"] += 1
    _check_result(out)


def _run_validate_warm(folder: Path) -> None:
    (folder / "v.toml").write_text(SCENE.format(layout=HEX.as_posix(), profile=(folder / "p.toml").as_posix()),
                                   encoding="utf-8")
    warm_up(["run", folder / "v.toml", "--out", folder / "warm"])
    shutil.rmtree(folder / "warm", ignore_errors=True)


@pytest.fixture()
def quiet(monkeypatch):
    monkeypatch.setenv("VTCORE_MEMORY_BUDGET", "512M")
    monkeypatch.setenv("VTCORE_PROGRESS", "0")


def test_fuzz_validate_recordings(validate_case, tmp_path, quiet, pytestconfig):
    """The validate scene with its recording mutated byte by byte (the profile as shipped, cut)."""
    from fuzzing import toml_text

    folder, rec, doc = validate_case
    work = tmp_path / "case"
    shutil.copytree(folder, work)
    (work / "p.toml").write_text(toml_text(doc), encoding="utf-8")

    _run_validate_warm(work)

    def check(data):
        (work / "rec.txt").write_bytes(data)
        _run_validate(work, "validate recording")

    fuzz(pytestconfig, mutated([rec]), check)


def _profile_names():
    from vtcore.contact import profile as P

    tables = {"profile": P._PROFILE, "noise": P._NOISE, "detection": P._DETECTION,
              "response": {**P._RESPONSE, **P._RESPONSE_REPORT}}
    return [f"{t}.{k}" for t, spec in tables.items() for k in spec] + ["taxels.uid", "taxels.sigma_counts"]


def test_fuzz_validate_profiles(validate_case, tmp_path, quiet, pytestconfig):
    """The validate scene with its sensor profile edited field by field or byte by byte."""
    from fuzzing import toml_text

    folder, _, doc = validate_case
    work = tmp_path / "case"
    shutil.copytree(folder, work)

    (work / "p.toml").write_text(toml_text(doc), encoding="utf-8")
    _run_validate_warm(work)

    def check(data):
        (work / "p.toml").write_bytes(data)
        _run_validate(work, "validate profile")

    fuzz(pytestconfig, mutated_toml([doc], _profile_names()), check)


# ----------------------------------------------------------------------------- evaluate
@pytest.fixture(scope="module")
def evaluate_case(tmp_path_factory):
    """(folder with box.stl; our JSON of a triangle on the box as a document; its iCub text)."""
    import trimesh

    from vtcore.layout import load, place, save

    d = tmp_path_factory.mktemp("evaluate_case")
    box = trimesh.creation.box((0.08, 0.08, 0.03))
    box.export(d / "box.stl")
    lay, _ = place(box, "triangle", [0.0, 0.0, 0.015])
    save(lay, d / "t.json")
    save(lay, d / "t.txt", "icub")
    return d, json.loads((d / "t.json").read_text()), (d / "t.txt").read_bytes()


#: a coarse probe grid, few noise draws, no two-point map, no plots: about a second a design
SETS = ["--set", "task.spacing=0.01", "--set", "task.draws=4", "--set", "task.two_point=false",
        "--set", "task.table_forces=3", "--set", "output.plots=false"]


def test_fuzz_evaluate_layouts(evaluate_case, tmp_path, quiet, pytestconfig):
    """``vtcore evaluate LAYOUT --mesh box.stl --out DIR`` with a mutated layout (a coarse probe grid)."""
    from test_fuzz_writers import _names

    folder, doc, icub = evaluate_case
    out = tmp_path / "out"
    names = _names()
    warm_up(["evaluate", folder / "t.json", "--mesh", folder / "box.stl", "--out", tmp_path / "warm", *SETS])

    def check(example):
        kind, data = example
        src = tmp_path / ("in.txt" if kind == "icub" else "in.json")
        src.write_bytes(data if isinstance(data, bytes) else json.dumps(data, indent=1).encode())
        shutil.rmtree(out, ignore_errors=True)
        rc, so, se = run_cli("evaluate layout", ["evaluate", src, "--mesh", folder / "box.stl", "--out", out, *SETS])
        assert_clean_exit(rc, so, se)
        if rc == 2:
            assert listing(out) == [] and not out.exists(), listing(out)
            return
        _check_result(out)

    strategy = st.one_of(st.tuples(st.just("doc"), mutated_doc([doc], names)),
                         st.tuples(st.just("json"), mutated([json.dumps(doc, indent=1).encode()])),
                         st.tuples(st.just("icub"), mutated([icub])))
    fuzz(pytestconfig, strategy, check)
