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
    assert soft.taxels.shape == (3, 4, 10) and np.allclose(soft.taxels.mean(axis=2), soft.p)
    np.testing.assert_allclose(soft.taxel_response(0.02, soft.u[1, 2]).mean(), soft.response(0.02, soft.u[1, 2]),
                               rtol=1e-9)


def _result(s, setpoint, true, contact=None):
    from vtcore.control.path_following import PathFollowingResult

    n = len(s)
    return PathFollowingResult(time=np.arange(n) * 1.0, s=np.asarray(s, float), setpoint=np.asarray(setpoint, float),
                               response=np.asarray(true, float), colour=np.zeros(n), indentation=np.zeros(n),
                               contact=np.asarray(true, float) > 0 if contact is None else contact,
                               response_true=np.asarray(true, float))


def test_overshoot_is_the_excursion_past_the_setpoint_not_the_step():
    s = np.linspace(0, 0.06, 601)
    sp = np.where(s < 0.02, 2000.0, 500.0)
    k = np.clip((s - 0.02) / 0.002, 0, None)
    lag = np.where(s < 0.02, 2000.0, 500.0 + 1500.0 * np.exp(-k))                 # a first-order lag: no crossing
    assert _result(s, sp, lag).overshoots(100.0) == []
    below = np.where(s < 0.02, 1840.0, 500.0 + 1340.0 * np.exp(-k))  # 160 under p̄* when the step comes
    assert _result(s, sp, below).overshoots(100.0) == []           # the set-point jumping over it is not one
    ring = np.where(s < 0.02, 2000.0, 500.0 + 1500.0 * np.exp(-k) * np.cos(1.5 * k))   # it rings below 500
    shoots = _result(s, sp, ring).overshoots(100.0)
    assert len(shoots) >= 1 and shoots[0][0] > 0.02
    assert shoots[0][1] == pytest.approx(np.max(500.0 - ring[s > 0.02]), rel=1e-9)
    # a contact lost and regained: the response comes back from 0 and overshoots the set-point
    back = np.full_like(s, 800.0)
    back[(s > 0.03) & (s < 0.032)] = 0.0
    after = s >= 0.032
    back[after] = 800.0 + 300.0 * np.sin(np.clip((s[after] - 0.032) / 0.001, 0, np.pi))
    r = _result(s, np.full_like(s, 800.0), back)
    assert r.contact_loss_intervals() == [(pytest.approx(0.0301), pytest.approx(0.032))]
    assert r.contact_lost_length() == pytest.approx(0.0019)
    assert r.overshoots(100.0)[0][1] == pytest.approx(300.0, rel=1e-3)
    assert r.tracking_error(in_contact_only=True) < r.tracking_error()


def test_per_taxel_noise_is_clipped_at_zero_like_the_real_readout(line_field):
    """With the taxels' readings, the loop adds noise per taxel and clips at 0: an unloaded taxel reads
    the positive half of its noise, so the measured mean is above the true one by ~sigma/sqrt(2 pi) x
    the unloaded fraction, and the controller settles the true response that much below its set-point."""
    from vtcore.control.path_following import ResponseTable

    v, c, _ = line_field
    s = np.linspace(0, 0.06, 7)
    u = np.linspace(0, 0.01, 6)[None, :].repeat(len(s), axis=0)
    load = np.r_[np.ones(5), np.zeros(5)]                          # five taxels loaded, five not
    taxels = (2e6 * u)[:, :, None] * load[None, None, :] * 2
    table = ResponseTable(s=s, u=u, p=taxels.mean(axis=2), taxels=taxels)
    est = ClusterPropagation().fit(v, np.full(4, 1e6))
    sigma = 180.0
    r = follow_path([0, 0, 0], [0, 0, 0.06], est.predict, response=table, c_max=1e6, p_max=1000.0,
                    controller=ForceController(noise=sigma), rng=0)
    late = r.time > 5.0
    bias = 0.5 * sigma / np.sqrt(2 * np.pi)                        # half the taxels, each E[max(N, 0)]
    assert np.mean(r.response[late]) == pytest.approx(1000.0, abs=5.0)
    assert np.mean(r.response_true[late]) == pytest.approx(1000.0 - bias, abs=8.0)
    np.testing.assert_allclose(r.response_expected[late], r.response_true[late] + bias, atol=1.0)


def test_ring_stations_resolve_the_bottle_groove():
    from vtcore.augment.objects import BOTTLE, bottle_radius_at
    from vtcore.augment.probing import cyskin_module_layout
    from vtcore.scene.tasks.path_following import stations

    p = {"length": 0.065, "stations": 27, "ring_stations": 1e-3, "groove_width": None}
    st = stations(p, 0.123, cyskin_module_layout())
    ring = 0.123 - BOTTLE["groove_z"]
    assert np.all(np.diff(st) > 0) and st[0] == 0 and st[-1] == pytest.approx(0.065)
    near = st[np.abs(st - ring) < 0.01]
    assert len(near) >= 20 and np.diff(near).max() <= 1e-3 + 1e-9
    assert len(stations({**p, "ring_stations": 0.0}, 0.123, cyskin_module_layout())) == 27
    # a rib stands out of the body, a groove dips into it
    z = np.array([BOTTLE["groove_z"]])
    assert bottle_radius_at(z, groove_depth=-0.001)[0] > BOTTLE["radius"] > bottle_radius_at(z)[0]
