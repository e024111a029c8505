"""Real errors reach the user: the three places that caught ``Exception`` now let them through.

Each test fails on the old code: a layout that cannot be read became a flat skin
(``sections/objects.py``, then ``sections/contact.py``), a failing skin mesh became a
NaN metric (``tasks/press.py``), and any failure of the log map became a silent
plane projection (``filters/image.py``).
"""

from __future__ import annotations

import json
import sys
import types

import numpy as np
import pytest

from vtcore.errors import InputError
from vtcore.scene import load_scene, run_scene

PRESS = """
[scene]
name = "t"
task = "press"
[end_effector]
shape = "plane"
[layout]
{layout}
[layer]
grid_spacing = 0.0015
samples_per_taxel = 3
[[objects]]
kind = "sphere"
radius = 0.03
[task]
readings = 2
[output]
plots = false
"""


def test_an_unreadable_layout_file_is_not_a_flat_skin_when_placing_objects(tmp_path):
    from vtcore.scene.sections.objects import build_objects, object_pose

    bad = tmp_path / "skin.json"
    bad.write_text(json.dumps({"taxels": "not a list"}))
    p = tmp_path / "s.toml"
    p.write_text(PRESS.format(layout=f'file = "{bad.name}"'))
    scene = load_scene(p)  # the file exists; its content is read when the layout is built
    for call in (lambda: object_pose(scene, 0), lambda: build_objects(scene)):
        with pytest.raises(InputError) as err:
            call()
        assert "skin.json" in str(err.value)


def test_a_failing_skin_mesh_stops_the_press_run_instead_of_a_nan_metric(tmp_path, monkeypatch):
    import vtcore.layout

    def broken(layout, **kw):
        raise RuntimeError("skin mesh failed")

    monkeypatch.setattr(vtcore.layout, "skin_mesh", broken)
    p = tmp_path / "s.toml"
    p.write_text(PRESS.format(layout='patch = "hexagon"'))
    with pytest.raises(RuntimeError, match="skin mesh failed"):
        run_scene(p, tmp_path / "out")
    assert not (tmp_path / "out" / "result.json").exists()


def _grid(n=6, pitch=0.005):
    """A flat n x n grid of taxels and its triangles."""
    x, y = np.meshgrid(np.arange(n) * pitch, np.arange(n) * pitch, indexing="ij")
    pos = np.column_stack([x.ravel(), y.ravel(), np.zeros(n * n)])
    i = np.arange(n - 1)[:, None] * n + np.arange(n - 1)[None, :]
    i = i.ravel()
    tri = np.concatenate([np.column_stack([i, i + n, i + 1]), np.column_stack([i + 1, i + n, i + n + 1])])
    return pos, tri


def test_flatten_rejects_triangles_that_index_no_taxel():
    from vtcore.filters import flatten

    pos, tri = _grid()
    tri[3, 1] = len(pos) + 4  # used to vanish into a silent best-fit-plane projection
    with pytest.raises(InputError, match="triangles must index the 36 taxels") as err:
        flatten(pos, tri)
    assert err.value.key == "triangles"


def test_flatten_lets_an_unexpected_log_map_error_through(monkeypatch):
    from vtcore.filters import flatten

    class Solver:
        def __init__(self, positions, triangles):
            raise TypeError("positions must be float64")

    monkeypatch.setitem(sys.modules, "potpourri3d", types.SimpleNamespace(MeshVectorHeatSolver=Solver))
    pos, tri = _grid()
    with pytest.raises(TypeError, match="positions must be float64"):
        flatten(pos, tri)


def test_flatten_still_projects_what_the_log_map_cannot_take(monkeypatch):
    """The documented fallbacks stay: no potpourri3d, a non-manifold mesh, no triangles."""
    from vtcore.filters import flatten

    pos, tri = _grid()
    expected = pos[:, :2] - pos[:, :2].mean(axis=0)  # the plane itself, up to a rotation
    bowtie = np.vstack([tri, [[0, 1, 7], [0, 1, 8]]])  # edge 0-1 in four triangles: not a manifold
    for t in (bowtie, np.zeros((0, 3), int)):
        f = flatten(pos, t)
        assert f.shape == (len(pos), 2) and np.all(np.isfinite(f))
        assert np.allclose(np.linalg.norm(f, axis=1), np.linalg.norm(expected, axis=1))
    monkeypatch.setitem(sys.modules, "potpourri3d", None)  # import fails: not installed
    f = flatten(pos, tri)
    assert np.allclose(np.linalg.norm(f, axis=1), np.linalg.norm(expected, axis=1))
