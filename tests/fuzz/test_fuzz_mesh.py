"""Fuzz of the mesh reader (``vtcore layout place MESH``: trimesh, then vtcore.layout.meshinput).

Seeds: a 60 x 60 x 20 mm box written here in millimetres (as CAD exports are; placed with
``--scale 0.001``) as OBJ, ASCII STL, binary STL and PLY: 12 triangles, so an accepted mutant places
in about a second. (A mutant of metres, where a coordinate of -1 makes the box a metre long, places
in some 16 s: the log map refines the whole surface; millimetres keep the default run short.)
A success must write a layout that ``vtcore.layout.load`` reads back with finite positions and
normals. See fuzzing.py for the mutations and the contract.
"""

from __future__ import annotations

import numpy as np
import pytest

from fuzzing import assert_clean_exit, fuzz, mutated, run_cli

SUFFIXES = (".obj", ".stl", ".ply")


@pytest.fixture(scope="module")
def seeds(tmp_path_factory):
    import trimesh

    d = tmp_path_factory.mktemp("mesh_seeds")
    box = trimesh.creation.box((60.0, 60.0, 20.0))  # millimetres
    out = {s: [] for s in SUFFIXES}
    for name, suffix, kw in (("a.obj", ".obj", {}), ("a.stl", ".stl", {"file_type": "stl_ascii"}),
                             ("b.stl", ".stl", {}), ("a.ply", ".ply", {"encoding": "ascii"})):
        box.export(d / name, **kw)
        out[suffix].append((d / name).read_bytes())
    return out


@pytest.mark.parametrize("suffix", SUFFIXES)
def test_fuzz_layout_place_mesh(suffix, seeds, tmp_path, pytestconfig):
    from vtcore.layout import load

    src, out = tmp_path / f"in{suffix}", tmp_path / "out.json"

    def check(data):
        src.write_bytes(data)
        out.unlink(missing_ok=True)
        rc, so, se = run_cli(f"layout place {suffix[1:]}", ["layout", "place", src, "--scale", "0.001",
                                                            "--at", "0", "0", "0.01", "--patch", "triangle",
                                                            "--out", out])
        # placement warnings (taxels off a mangled surface) are lines of their own before the summary
        assert_clean_exit(rc, so, se)
        if rc == 0:
            back = load(out)
            assert np.isfinite(back.positions).all() and np.isfinite(back.normals).all()

    fuzz(pytestconfig, mutated(seeds[suffix]), check)
