"""vtcore.scene.interactive, the bpy-free glue behind the add-on's operators (no Blender needed)."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from vtcore.errors import InputError
from vtcore.layout import Layout, seed002_curved
from vtcore.scene import interactive as I


@pytest.fixture(scope="module")
def curved():
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        mesh, lay = seed002_curved()
        centre = lay.positions[np.argmin(np.linalg.norm(lay.positions - lay.positions.mean(0), axis=1))]
        edit = I.lay_patch(mesh.vertices, mesh.faces, centre)
    return mesh, centre, edit


def test_lay_patch_and_merge_renumber(curved):
    mesh, centre, edit = curved
    assert len(edit.layout) == 60 and len(edit.triangles) > 0
    assert set(edit.report) >= {"strain_max", "overlaps", "coverage"}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        two = I.lay_patch(mesh.vertices, mesh.faces, centre + [0.035, 0, 0], existing=edit.layout)
    assert len(two.layout) == 120
    np.testing.assert_array_equal(two.layout.positions[:60], edit.layout.positions)
    assert set(two.layout.module_ids[60:]) == set(range(6, 12))
    assert np.all(two.layout.taxel_ids >> 4 == two.layout.module_ids + 1)
    assert len(np.unique(two.layout.taxel_ids)) == 120


def test_remove_modules_errors(curved):
    _, _, edit = curved
    out = I.remove_modules(edit.layout, [0, 1])
    assert len(out.layout) == 40 and not np.isin(out.layout.module_ids, [0, 1]).any()
    with pytest.raises(InputError, match="select"):
        I.remove_modules(edit.layout, [])
    with pytest.raises(InputError, match="no module"):
        I.remove_modules(edit.layout, [99])


def test_simulate_zero_layer_and_no_faces(curved):
    from vtcore.contact import make_object, placement_pose

    _, centre, edit = curved
    s = make_object("sphere", radius=0.015)
    pose = placement_pose(s, xy=centre[:2], top=centre[2] + 0.003, gap=0.001)
    with pytest.raises(InputError, match="thickness"):
        I.simulate(edit.layout, edit.triangles, s.vertices, s.faces, pose, thickness=0.0)
    with pytest.raises(InputError, match="no faces"):
        I.simulate(edit.layout, edit.triangles, s.vertices, np.zeros((0, 3)), pose, thickness=0.003)
    c = I.simulate(edit.layout, edit.triangles, s.vertices, s.faces, pose, thickness=0.003, force=1.0)
    assert c.force == pytest.approx(1.0, rel=1e-3)
    assert np.all(np.isfinite(c.response)) and c.response.max() > 0 and c.edge.any()
    # The edge flags are the filter's, thresholded relative to the frame maximum.
    er, edge = I.edges(edit.layout, edit.triangles, c.response, 0.3)
    np.testing.assert_array_equal(edge, c.edge)
    assert edge.sum() == (er > 0.3 * er.max()).sum()


def test_bake_zero_force_frames_are_empty(curved):
    from vtcore.contact import make_object, placement_pose

    _, centre, edit = curved
    s = make_object("sphere", radius=0.015)
    pose = placement_pose(s, xy=centre[:2], top=centre[2] + 0.003, gap=0.001)
    calls = []
    res = I.bake(edit.layout, edit.triangles, s.vertices, s.faces, np.stack([pose] * 3), thickness=0.003,
                 forces=[0.0, 1.0, 0.5], callback=lambda i, t: calls.append((i, t)))
    assert calls == [(0, 3), (1, 3), (2, 3)]
    assert not res["pressure"][0].any() and not res["edge"][0].any()
    np.testing.assert_allclose(res["force"][1:], [1.0, 0.5], rtol=1e-3)


def test_edges_without_mesh_and_uniform_frame():
    lay = Layout(np.zeros((2, 3)) + [[0, 0, 0], [1e-3, 0, 0]], np.tile([0, 0, 1.0], (2, 1)), [17, 18], [0, 0])
    er, edge = I.edges(lay, np.zeros((0, 3)), np.ones(2))
    assert not edge.any() and np.all(er == 0)


def test_augment_methods_and_bad_input():
    rng = np.random.default_rng(0)
    pts = rng.uniform(size=(50, 3)) * 0.05
    vals, rgb = I.augment(pts, pts[:4], [1.0, 2.0, 3.0, 4.0], method="cluster")
    np.testing.assert_allclose(vals[:4], [1, 2, 3, 4])
    assert rgb.shape == (50, 3) and rgb.min() >= 0 and rgb.max() <= 1
    one, rgb1 = I.augment(pts, pts[:1], [2.0])  # a single probe: constant, finite colours
    assert np.allclose(one, 2.0) and np.isfinite(rgb1).all()
    with pytest.raises(InputError, match="method"):
        I.augment(pts, pts[:4], [1, 2, 3, 4], method="magic")
    with pytest.raises(InputError, match="probe"):
        I.augment(pts, np.zeros((0, 3)), [])


def test_export_roundtrip_with_transform(curved, tmp_path):
    from vtcore.layout import load

    _, _, edit = curved
    t = np.eye(4)
    t[:3, 3] = [0.01, 0.02, 0.03]
    I.export_layout(edit.layout, edit.triangles, tmp_path / "a.json")
    I.export_layout(edit.layout, edit.triangles, tmp_path / "b.json", transform=t)
    a, b = load(tmp_path / "a.json"), load(tmp_path / "b.json")
    np.testing.assert_allclose(a.positions, edit.layout.positions, atol=1e-9)
    np.testing.assert_allclose(b.positions, edit.layout.positions + [0.01, 0.02, 0.03], atol=1e-9)
    with pytest.raises(InputError, match="format"):
        I.export_layout(edit.layout, edit.triangles, tmp_path / "c.json", format="nope")


def test_run_scene_file_missing(tmp_path):
    with pytest.raises(InputError, match="readable"):
        I.run_scene_file(tmp_path / "nope.toml", tmp_path / "out")
