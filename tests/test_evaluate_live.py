"""Live touch without Blender: LiveTouch answers a pose as simulate() does; the worker keeps only the
newest pose; a pose that cannot press reads zero and says why."""

from __future__ import annotations

import time

import numpy as np
import pytest

from vtcore.contact import make_object, placement_pose
from vtcore.layout import make_patch, skin_mesh
from vtcore.scene import interactive


@pytest.fixture(scope="module")
def skin():
    lay = make_patch("hexagon").flat_layout()
    return lay, skin_mesh(lay).triangles, make_object("sphere", radius=0.01)


@pytest.mark.parametrize("model", ["local", "finite_layer"])
def test_live_update_is_the_press_at_that_pose(skin, model):
    lay, tri, sph = skin
    live = interactive.LiveTouch(lay, tri, sph.vertices, sph.faces, thickness=0.003, model=model, force=2.0)
    for x in (-0.01, 0.0, 0.007):
        pose = placement_pose(sph, xy=(x, 0.002), top=0.003, gap=0.001)
        f = live.update(pose)
        ref = interactive.simulate(lay, tri, sph.vertices, sph.faces, pose, thickness=0.003, force=2.0, model=model)
        np.testing.assert_allclose(f.contact.pressure, ref.pressure, rtol=1e-6, atol=1e-6 * ref.pressure.max())
        np.testing.assert_array_equal(f.contact.edge, ref.edge)
        assert f.contact.force == pytest.approx(2.0) and not f.note


def test_pose_beside_the_skin_reads_zero_with_a_note(skin):
    lay, tri, sph = skin
    live = interactive.LiveTouch(lay, tri, sph.vertices, sph.faces, thickness=0.003, force=2.0)
    f = live.update(placement_pose(sph, xy=(0.5, 0.5), top=0.003, gap=0.001))
    assert not f.contact.pressure.any() and "never meets the skin" in f.note
    # the pose as it is, not touching: zero, no note
    free = interactive.LiveTouch(lay, tri, sph.vertices, sph.faces, thickness=0.003, force=None)
    f = free.update(placement_pose(sph, xy=(0.0, 0.0), top=0.003, gap=0.002))
    assert not f.contact.pressure.any() and not f.note


def test_worker_solves_the_newest_pose(skin):
    lay, tri, sph = skin
    live = interactive.LiveTouch(lay, tri, sph.vertices, sph.faces, thickness=0.003, model="local", force=1.0)
    w = interactive.LiveWorker(live)
    try:
        poses = [placement_pose(sph, xy=(x, 0.0), top=0.003, gap=0.001) for x in np.linspace(-0.01, 0.01, 6)]
        for p in poses:
            w.request(p)
        frame, t0 = None, time.time()
        while time.time() - t0 < 60:
            got = w.take()
            frame = got or frame
            if frame is not None and np.allclose(frame.pose, poses[-1]) and not w.busy():
                break
            time.sleep(0.01)
        assert frame is not None and np.allclose(frame.pose, poses[-1])
        ref = live.update(poses[-1])
        np.testing.assert_allclose(frame.contact.pressure, ref.contact.pressure, rtol=1e-6,
                                   atol=1e-6 * ref.contact.pressure.max())
    finally:
        w.close()
    with pytest.raises(ValueError, match="model"):
        interactive.LiveTouch(lay, tri, sph.vertices, sph.faces, thickness=0.003, model="magic")
