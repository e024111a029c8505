"""Seed 002's tapping contour follower (Eq. 9) against analytic contacts."""

from __future__ import annotations

import numpy as np
import pytest

from vtcore.control import (AnalyticContact, CircleContour, ContourFollower, LineContour, control_frame,
                            facing_down, motion, motion_matrix, summarize)
from vtcore.errors import InputError
from vtcore.filters import MeshEdgeDetector, SubtaxelEdgeDetector, features
from vtcore.layout import Layout, mesh_from_triangles


def planar_skin(rings=3, pitch=7.5e-3):
    from scipy.spatial import Delaunay

    i, j = np.meshgrid(np.arange(-rings, rings + 1), np.arange(-rings, rings + 1), indexing="ij")
    i, j = i.ravel(), j.ravel()
    keep = np.maximum(np.maximum(np.abs(i), np.abs(j)), np.abs(i + j)) <= rings
    flat = pitch * np.column_stack([i[keep] + 0.5 * j[keep], np.sqrt(3) / 2 * j[keep]])
    pos = np.column_stack([flat, np.zeros(len(flat))])
    nrm = np.tile([0.0, 0.0, 1.0], (len(flat), 1))
    mesh = mesh_from_triangles(pos, nrm, Delaunay(flat).simplices)
    return Layout(pos, nrm, np.arange(len(flat)), np.zeros(len(flat), int), flat=flat), mesh


def test_eq9_motion_and_pose_update():
    f = features(np.array([[0.0, 2e-3, 0.0], [10e-3, 2e-3 + 10e-3 * np.tan(0.2), 0.0]]), [0, 0])
    dx, dy, th = motion(f, 5e-3)
    assert th == pytest.approx(0.2)
    assert dx == pytest.approx(5e-3 * np.cos(0.2))
    assert dy == pytest.approx(f.centroid[1])
    m = motion_matrix(dx, dy, th)
    np.testing.assert_allclose(m[:3, 3], [dx, dy, 0.0])  # x_R moves by (dx, dy) in the control frame
    np.testing.assert_allclose(m[:3, 0], [np.cos(0.2), np.sin(0.2), 0.0])
    # an edge without orientation (one point) keeps the heading
    one = features(np.array([[1e-3, -1e-3, 0.0]]), [0])
    assert motion(one, 5e-3) == (pytest.approx(5e-3), pytest.approx(-1e-3), 0.0)


def test_facing_down_frame_points_the_skin_at_the_table():
    w = facing_down([0.01, 0.02], 0.3, 0.005)
    np.testing.assert_allclose(w[:3, 2], [0, 0, -1.0], atol=1e-12)
    np.testing.assert_allclose(w[:3, 0], [np.cos(0.3), np.sin(0.3), 0], atol=1e-12)
    assert np.linalg.det(w[:3, :3]) == pytest.approx(1.0)


def test_control_frame_of_flat_and_curved_skins():
    lay, _ = planar_skin()
    f = control_frame(lay)
    np.testing.assert_allclose(f[:3, :3], np.eye(3), atol=1e-12)
    # a skin curved about y: the control x axis is the curvature axis
    th = np.linspace(-0.6, 0.6, 9)
    yy = np.linspace(-0.02, 0.02, 5)
    t, y = np.meshgrid(th, yy)
    r = 0.05
    pos = np.column_stack([r * np.sin(t.ravel()), y.ravel(), r * np.cos(t.ravel()) - r])
    nrm = np.column_stack([np.sin(t.ravel()), np.zeros(t.size), np.cos(t.ravel())])
    lay2 = Layout(pos, nrm, np.arange(len(pos)), np.zeros(len(pos), int),
                  meta={"reference_taxel": int(np.argmin(np.abs(t.ravel() - 0.3) + np.abs(y.ravel())))})
    f2 = control_frame(lay2)
    assert abs(abs(f2[:3, 0] @ [0, 1.0, 0]) - 1) < 1e-9
    np.testing.assert_allclose(f2[:3, 2], nrm[lay2.meta["reference_taxel"]], atol=1e-12)


def test_contour_metrics_follow_seed002():
    line = LineContour(offset=0.001)
    xr = np.array([[0, 5.0, 0], [0, 0.003, 0], [0.005, -0.001, 0]])
    np.testing.assert_allclose(line.distances(xr), [0.002, 0.002])  # the first tap is not counted
    circ = CircleContour(centre=(0.01, 0.0), reference=0.0395)
    xr = np.array([[0.0, 0.0, 0.0], [0.01 + 0.04, 0.0, 0.0], [0.01, -0.039, 0.0]])
    np.testing.assert_allclose(circ.distances(xr), [0.0005, 0.0005], atol=1e-15)
    s = summarize([np.array([1.0, 3.0]), np.array([2.0]), np.array([])])
    assert s["d_mean"] == pytest.approx(2.0) and s["d_std"] == pytest.approx(0.5) and s["d_max"] == 3.0
    assert summarize([]) == {"d_mean": 0.0, "d_std": 0.0, "d_max": 0.0, "taps": 0}


@pytest.mark.parametrize("make", [lambda m: MeshEdgeDetector(m), lambda m: SubtaxelEdgeDetector(m, levels=1)])
def test_follows_a_straight_edge_from_an_offset_start(make):
    lay, mesh = planar_skin()
    line = LineContour(offset=0.0, x_start=-0.1, x_end=0.1)
    sense = AnalyticContact(lay.positions, line, force=15.0)
    run = ContourFollower(make(mesh), step=5e-3, max_taps=100).run(
        sense, facing_down([-0.08, 2e-3], 0.15), line.explored(0.01))
    assert run.stop_reason == "explored"
    assert len(run) >= 30
    d = line.distances(run.x_ref)
    assert d.mean() < 2e-3 and d.max() < 4e-3
    assert run.pressure.shape == (len(run), len(lay)) and run.edge.shape == run.pressure.shape


def test_follows_a_circle_all_the_way_round():
    lay, mesh = planar_skin()
    circ = CircleContour()
    sense = AnalyticContact(lay.positions, circ, force=15.0)
    a0 = 1.0
    start = facing_down(circ.reference * np.array([np.cos(a0), np.sin(a0)]), a0 - np.pi / 2)
    run = ContourFollower(MeshEdgeDetector(mesh), max_taps=150).run(sense, start, circ.explored())
    assert run.stop_reason == "explored"
    assert circ.swept_angle(run.x_ref) >= 2 * np.pi
    assert circ.distances(run.x_ref).mean() < 3e-3


def test_no_contact_and_no_edge_end_a_run_cleanly():
    lay, mesh = planar_skin()
    det = MeshEdgeDetector(mesh)
    run = ContourFollower(det).run(lambda pose: None, np.eye(4))
    assert len(run) == 0 and run.stop_reason == "no contact"
    assert run.pressure.shape == (0, len(lay))
    run = ContourFollower(det).run(lambda pose: np.full(len(lay), 3.0), np.eye(4))
    assert len(run) == 1 and run.stop_reason == "no edge"
    run = ContourFollower(det, max_taps=3).run(
        lambda pose: AnalyticContact(lay.positions, LineContour())(pose), facing_down([0, 0], 0))
    assert len(run) == 3 and run.stop_reason == "max taps"
    with pytest.raises(InputError):
        ContourFollower(det, step=0.0)


@pytest.mark.parametrize("model", ["module", "taxel"])
def test_position_error_has_the_requested_rms(model):
    from vtcore.control.contour import control_skin, taxel_position_error

    _, lay, _ = control_skin("seed002_curved")
    e = np.concatenate([taxel_position_error(lay, 1e-3, np.random.default_rng(s), model) for s in range(40)])
    assert np.sqrt(np.mean(np.sum(e**2, axis=1))) == pytest.approx(1e-3, rel=0.06)
    assert np.all(np.isfinite(e))


def test_module_error_keeps_the_distances_on_each_module():
    """CySkin taxels sit on rigid PCBs: hand placement moves whole modules, not single taxels."""
    from vtcore.control.contour import control_skin, taxel_position_error

    _, lay, _ = control_skin("seed002_curved")
    rng = np.random.default_rng(3)
    mod = taxel_position_error(lay, 1e-3, rng, "module")
    ind = taxel_position_error(lay, 1e-3, rng, "taxel")
    m = lay.module_ids == lay.module_ids[0]
    assert m.sum() >= 3

    def dists(p):
        return np.linalg.norm(p[:, None] - p[None], axis=-1)

    d0 = dists(lay.positions[m])
    assert np.abs(dists(lay.positions[m] + mod[m]) - d0).max() < 1e-12  # rigid

    assert np.abs(dists(lay.positions[m] + ind[m]) - d0).max() > 2e-4
    # the translation lies in the module's tangent plane (the module is glued onto the surface)
    n = lay.normals[m].mean(axis=0)
    n /= np.linalg.norm(n)
    assert abs(mod[m].mean(axis=0) @ n) < 0.1 * np.linalg.norm(mod[m].mean(axis=0))
    with pytest.raises(InputError, match="model"):
        taxel_position_error(lay, 1e-3, rng, "gaussian")


def test_believed_control_frame_sits_on_the_believed_reference_taxel():
    from vtcore.control.contour import believed_skin, control_skin, taxel_position_error

    _, lay, _ = control_skin("seed002_curved")
    err = taxel_position_error(lay, 1e-3, np.random.default_rng(1))
    true, belief, f = believed_skin(lay, err)
    ref = lay.meta["reference_taxel"]
    assert np.allclose(belief.positions[ref], 0.0, atol=1e-12)  # x_R is where the robot thinks it is
    assert np.linalg.norm(true.positions[ref]) == pytest.approx(np.linalg.norm(err[ref]), rel=0.05)
    # both skins move together: the believed minus the true positions is the error, rotated into F
    assert np.allclose(belief.positions - true.positions, err @ f[:3, :3], atol=1e-12)
    assert np.allclose(true.normals, lay.normals @ f[:3, :3], atol=1e-12)
