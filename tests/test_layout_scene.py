"""The ``[end_effector]`` and ``[layout]`` scene tables, build_layout / build_end_effector, the bench."""

import numpy as np
import pytest
import trimesh

from vtcore.errors import SceneError
from vtcore.layout import save, seed002_planar
from vtcore.scene.loader import load_scene
from vtcore.scene.sections.layout import build_end_effector, build_layout

BASE = """
[scene]
name = "t"
task = "press"
[[objects]]
name = "sphere"
kind = "sphere"
radius = 0.03
"""


def scene(tmp_path, tables: str, name="s.toml"):
    f = tmp_path / name
    f.write_text(BASE + tables)
    return load_scene(f)


@pytest.mark.parametrize("shape,extra", [("sphere", "radius = 0.05"), ("cylinder", "radius = 0.02"),
                                         ("plane", "size = [0.1, 0.08]"), ("disc", "radius = 0.04")])
def test_primitives_default_patch_is_on_the_skin(tmp_path, shape, extra):
    s = scene(tmp_path, f'[end_effector]\nshape = "{shape}"\n{extra}\n[layout]\npatch = "hexagon"\n')
    lay = build_layout(s)
    mesh = build_end_effector(s)
    assert len(lay) == 60 and mesh.is_watertight
    _, d, _ = trimesh.proximity.closest_point(mesh, lay.positions)
    assert d.max() < 2e-4  # the analytic exp map vs the meshed surface
    assert mesh.bounds[1, 2] == pytest.approx(0.0, abs=1e-9)  # skin through the origin, facing +z
    assert lay.normals[:, 2].min() > 0.05  # outward, towards +z
    # outside the body along the normal, inside against it
    assert not mesh.contains(lay.positions + 1e-3 * lay.normals).any()


def test_mesh_file_placement_offset_and_module(tmp_path):
    m = trimesh.creation.icosphere(3, radius=50.0)  # millimetres
    m.export(tmp_path / "ball.stl")
    s = scene(tmp_path, '[end_effector]\nshape = "mesh"\nmesh = "ball.stl"\nscale = 0.001\n'
                        '[layout]\npatch = "strip:2"\nmodule = "icub12"\nat = [0.0, 0.0, 0.05]\n'
                        'direction = [1.0, 0.0, 0.0]\noffset = 0.001\n')
    lay = build_layout(s)
    assert len(lay) == 24
    np.testing.assert_allclose(np.linalg.norm(lay.positions, axis=1), 0.051, atol=3e-4)
    assert build_end_effector(s).bounds[1, 2] == pytest.approx(0.05)


def test_seed_end_effectors_by_name(tmp_path):
    for name, n in (("seed001_disc", 60), ("seed002_planar", 20), ("seed002_curved", 210)):
        s = scene(tmp_path, f'[end_effector]\nshape = "{name}"\n')
        assert len(build_layout(s)) == n
        assert build_end_effector(s).is_watertight


def test_layout_file_and_fill(tmp_path):
    _, lay = seed002_planar()
    save(lay, tmp_path / "skin.csv")
    s = scene(tmp_path, '[layout]\nfile = "skin.csv"\n')
    np.testing.assert_allclose(build_layout(s).positions, lay.positions, atol=1e-12)
    s = scene(tmp_path, '[end_effector]\nshape = "plane"\nsize = [0.1, 0.1]\n[layout]\npatch = "fill"\n'
                        'radius = 0.035\n')
    f = build_layout(s)
    assert f.n_modules >= 4 and np.abs(f.positions[:, 2]).max() < 1e-9


@pytest.mark.parametrize("tables,key", [
    ('[end_effector]\nshape = "mesh"\n', "end_effector.mesh"),
    ('[end_effector]\nshape = "torus"\n', "end_effector.shape"),
    ('[layout]\npatch = "strip:0"\n', "layout.patch"),
    ('[layout]\nmodule = "nope"\n', "layout.module"),
    ('[layout]\nfile = "missing.json"\n', "layout.file"),
    ('[layout]\nat = [0.0, 1.0]\n', "layout.at"),
    ('[layout]\nradius = -1.0\n', "layout.radius"),
])
def test_scene_errors_name_the_key(tmp_path, tables, key):
    with pytest.raises(SceneError) as exc:
        scene(tmp_path, tables)
    assert key in str(exc.value)


def test_demo_uses_the_real_hexagon():
    from pathlib import Path

    demo = Path(__file__).resolve().parents[1] / "scenes" / "demo.toml"
    lay = build_layout(load_scene(demo))
    assert len(lay) == 60 and lay.meta["module_type"] == "cyskin10" and lay.meta["patch"] == "hexagon"
    assert np.ptp(lay.positions[:, 2]) > 1e-3  # curved end-effector


def test_bench_quick(tmp_path):
    from vtcore.layout import bench

    rows = bench.run(tmp_path, quick=True)
    for f in ("table.md", "table.csv", "accuracy_vs_time.png"):
        assert (tmp_path / f).stat().st_size > 0
    by = {(r["case"], r["method"]): r for r in rows}
    assert by[("place_100", "logmap")]["accuracy"] < by[("place_100", "project")]["accuracy"]
    assert all(np.isfinite(r["accuracy"]) for r in rows)
    # issue 34: every row has a time and an error against a closed form (never the method itself)
    assert all(np.isfinite([r["seconds"], r["error"]]).all() and r["error_vs"] for r in rows)
    place = [r for r in rows if r["case"] == "place_100"]
    assert len(place) >= 3 and max(r["error"] for r in place if r["method"] == "logmap") < 1.0  # mm off the wrap
    assert by[("place_100", "project")]["error"] > 10  # projection shrinks the wrapped patch: tens of mm
    fills = [r for r in rows if r["case"] == "fill_faces" and r["method"] == "grow"]
    # the taxels lie on the facets: their distance to the true cylinder is the facets' sag, which halves
    # as the faces double
    assert len(fills) >= 3 and fills[0]["error"] > fills[-1]["error"] > 0
