"""Fuzz of the layout readers (``vtcore layout import``), one seed corpus per read format.

Seeds: the repository's iCub positions file and CySkin calibration JSON (scenes/layouts, from
the formats in ../shared/formats/), and our JSON, CSV and PLY written here from the hexagon.
A success must write a layout that ``vtcore.layout.load`` reads back with finite positions
and normals. See fuzzing.py for the mutations and the contract.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from fuzzing import assert_clean_exit, fuzz, mutated, run_cli

ROOT = Path(__file__).resolve().parents[2]
LAYOUTS = ROOT / "scenes" / "layouts"


@pytest.fixture(scope="module")
def seeds(tmp_path_factory):
    from vtcore.layout import load, save

    d = tmp_path_factory.mktemp("layout_seeds")
    small = load(LAYOUTS / "icub_two_triangles.txt")
    out = {"icub": (".txt", [(LAYOUTS / "icub_two_triangles.txt").read_bytes()]),
           "cyskin": (".json", [(LAYOUTS / "seed001_hexagon.cyskin.json").read_bytes()])}
    for fmt, suffix in (("json", ".json"), ("csv", ".csv"), ("ply", ".ply")):
        save(small, d / f"s{suffix}", fmt)
        out[fmt] = (suffix, [(d / f"s{suffix}").read_bytes()])
    return out


@pytest.mark.parametrize("fmt", ["icub", "cyskin", "json", "csv", "ply"])
def test_fuzz_layout_import(fmt, seeds, tmp_path, pytestconfig):
    from vtcore.layout import load

    suffix, blobs = seeds[fmt]
    src, out = tmp_path / f"in{suffix}", tmp_path / "out.json"

    def check(data):
        src.write_bytes(data)
        out.unlink(missing_ok=True)
        rc, so, se = run_cli(f"layout import {fmt}", ["layout", "import", src, "--format", fmt, "--out", out])
        assert_clean_exit(rc, so, se)
        if rc == 0:
            back = load(out)
            assert np.isfinite(back.positions).all() and np.isfinite(back.normals).all()

    fuzz(pytestconfig, mutated(blobs), check)
