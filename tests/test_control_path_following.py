"""Eq. 5 set-point and force tracking along a path (seed 000, Sect. 4.2)."""

import numpy as np
import pytest

from vtcore.augment import ClusterPropagation, SmoothPropagation
from vtcore.control.path_following import ForceController, follow_path, force_setpoint
from vtcore.errors import InputError


def test_equation_5():
    np.testing.assert_allclose(force_setpoint([0.0, 5e5, 1e6, 2e6], 2000.0, 1e6), [0, 1000, 2000, 2000])
    with pytest.raises(InputError, match="c_max"):
        force_setpoint(1.0, 2000.0, 0.0)


@pytest.fixture
def line_field():
    # touches along a 6 cm line: stiff, soft, medium (counts/m)
    v = np.array([[0, 0, 0.0], [0, 0, 0.02], [0, 0, 0.04], [0, 0, 0.06]])
    c = np.array([2e6, 8e5, 8e5, 1.2e6])
    truth = lambda x: np.interp(x[:, 2], v[:, 2], c)
    return v, c, truth


def test_cluster_steps_and_smooth_varies_smoothly(line_field):
    v, c, truth = line_field
    ctl = ForceController(noise=0.0)
    runs = {}
    for name, est in (("cluster", ClusterPropagation()), ("smooth", SmoothPropagation())):
        est.fit(v, c)
        runs[name] = follow_path([0, 0, 0], [0, 0, 0.06], est.predict, truth, c_max=c.max(), controller=ctl, rng=0)
    cl, sm = runs["cluster"], runs["smooth"]
    assert cl.setpoint[0] == pytest.approx(2000.0)                 # starts at the stiffest point: p̄*_max
    jumps_cl = np.abs(np.diff(cl.setpoint))
    assert np.sum(jumps_cl > 100) == 2                             # two colour changes -> two steps (1.2e6 > 8e5 too)
    assert np.abs(np.diff(sm.setpoint)).max() < 0.1 * jumps_cl.max()
    for r in runs.values():
        assert r.tracking_error() < 100 and np.all(np.isfinite(r.response))
        late = r.time > r.time[-1] - 1.0                           # settled at the end: tracks the set-point
        assert np.abs(r.response[late] - r.setpoint[late]).mean() < 10


def test_losing_contact_reads_zero(line_field):
    v, c, truth = line_field
    est = ClusterPropagation().fit(v, c)
    gap = lambda x: np.where(np.abs(x[:, 2] - 0.03) < 0.002, 0.01, 0.0)   # a 1 cm deep groove
    r = follow_path([0, 0, 0], [0, 0, 0.06], est.predict, truth, gap=gap, c_max=c.max(),
                    controller=ForceController(noise=0.0), rng=0)
    assert not r.contact.all()
    assert np.all(r.response[~r.contact] == 0.0)


def test_bad_path():
    with pytest.raises(InputError, match="zero length"):
        follow_path([0, 0, 0], [0, 0, 0], lambda x: np.ones(len(x)), lambda x: np.ones(len(x)), c_max=1.0)
