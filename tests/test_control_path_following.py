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


def test_response_table_plant_matches_the_series_plant(line_field):
    """A tabulated linear contact (the contact simulator's format) behaves like the series model."""
    from vtcore.control.path_following import ResponseTable

    v, c, truth = line_field
    s = np.linspace(0, 0.06, 31)
    u = np.linspace(0, 0.01, 6)[None, :].repeat(len(s), axis=0)
    table = ResponseTable(s=s, u=u, p=truth(np.c_[np.zeros((31, 2)), s])[:, None] * u)
    est = SmoothPropagation().fit(v, c)
    ctl = ForceController(noise=0.0)
    a = follow_path([0, 0, 0], [0, 0, 0.06], est.predict, truth, c_max=c.max(), controller=ctl)
    b = follow_path([0, 0, 0], [0, 0, 0.06], est.predict, response=table, c_max=c.max(), controller=ctl)
    np.testing.assert_allclose(b.response, a.response, rtol=0.02, atol=2.0)
    assert table.displacement_for(0.0, 2000.0) == pytest.approx(2000.0 / 2e6)
    assert table.response(0.0, 0.02) == pytest.approx(2e6 * 0.02)      # extrapolated with the last slope
    with pytest.raises(InputError, match="plant"):
        follow_path([0, 0, 0], [0, 0, 0.06], est.predict, c_max=1.0)


def test_contact_response_table_on_the_bottle():
    from vtcore.augment import make_seed000_object
    from vtcore.contact import SoftLayer
    from vtcore.control.path_following import contact_response_table

    o = make_seed000_object("empty_bottle")
    start, end = np.array([0.032, 0, 0.11]), np.array([0.032, 0, 0.07])
    stiff = lambda r: float(o.stiffness(r.contact_point_object[None])[0])
    soft = contact_response_table(o.mesh, start, end, [1.0, 0, 0], SoftLayer(thickness=0.003), stiffness=stiff,
                                  stations=3, forces=(0.1, 0.5, 1.0))
    rigid = contact_response_table(o.mesh, start, end, [1.0, 0, 0], SoftLayer(thickness=0.003), stations=3,
                                   forces=(0.1, 0.5, 1.0))
    assert np.all(np.diff(soft.p, axis=1) > 0) and np.all(np.diff(soft.u, axis=1) > 0)
    np.testing.assert_allclose(soft.p, rigid.p, rtol=1e-6)           # same force, same pressure ...
    assert np.all(soft.u[:, -1] > rigid.u[:, -1] + 1e-3)             # ... but the soft wall deflects
