"""Eq. 1 (compliance from probing), recorded probes, the probe model and the seed-000 objects."""

import numpy as np
import pytest

from vtcore.augment import (OBJECTS, ProbeModel, TactilePointCloud, compliance, load_probes,
                            make_seed000_object)
from vtcore.errors import FormatError, InputError


def test_equation_1():
    assert compliance(4000.0, [0, 0, -0.004], [0, 0, 0]) == pytest.approx(1e6)
    c = compliance([4000.0, 2000.0], [[0, 0, -0.002], [0.003, 0, 0.004]], [[0, 0, 0], [0, 0, 0]])
    np.testing.assert_allclose(c, [2e6, 2000.0 / 0.005])


def test_zero_displacement_is_a_clear_error():
    with pytest.raises(InputError, match="probe 1: the end-effector displacement is zero"):
        compliance([4000.0, 4000.0], [[0, 0, -1e-3], [1, 2, 3]], [[0, 0, 0], [1, 2, 3]])


def test_negative_displacement_along_the_push_is_a_clear_error():
    # the end-effector ended 1 mm *behind* its start: the norm would hide it, the direction does not
    with pytest.raises(InputError, match="negative"):
        compliance(4000.0, [0, 0, 1e-3], [0, 0, 0], direction=[0, 0, -1])
    assert compliance(4000.0, [0, 0, -1e-3], [0, 0, 0], direction=[0, 0, -2]) == pytest.approx(4e6)


def test_non_positive_response_rejected_and_never_inf():
    with pytest.raises(InputError, match="p_mean"):
        compliance(0.0, [0, 0, -1e-3], [0, 0, 0])
    with pytest.raises(InputError):
        compliance(4000.0, [np.nan, 0, 0], [0, 0, 0])


def test_load_probes_csv_and_npz(tmp_path):
    csv = tmp_path / "probes.csv"
    csv.write_text("x,y,z,p_mean,x_ss,y_ss,z_ss,nx,ny,nz\n"
                   "0,0,0.1,4000,0,0,0.096,0,0,1\n"
                   "# a comment\n"
                   "0.01,0,0.05,4010,0.008,0,0.05,1,0,0\n")
    t = load_probes(csv)
    np.testing.assert_allclose(t.values, [4000 / 0.004, 4010 / 0.002])
    np.savez(tmp_path / "p.npz", contact_points=t.points, p_mean=t.p_mean, steady_state=t.points - [0, 0, 0.002])
    np.testing.assert_allclose(load_probes(tmp_path / "p.npz").values, t.p_mean / 0.002)


@pytest.mark.parametrize("text,match", [
    ("x,y,z,p_mean\n0,0,0,1\n", "header lacks"),
    ("x,y,z,p_mean,x_ss,y_ss,z_ss\n0,0,0,4000,0,0\n", "fields"),
    ("x,y,z,p_mean,x_ss,y_ss,z_ss\n0,0,0,4000,0,0,abc\n", "non-numeric"),
    ("x,y,z,p_mean,x_ss,y_ss,z_ss\n0,0,0,4000,0,0,0\n", "zero"),
])
def test_bad_probe_files_name_file_and_line(tmp_path, text, match):
    f = tmp_path / "bad.csv"
    f.write_text(text)
    with pytest.raises(FormatError, match=match) as exc:
        load_probes(f)
    assert "bad.csv" in str(exc.value)


def test_probe_model_recovers_the_series_stiffness():
    pm = ProbeModel(response_noise=0.0, position_noise=0.0)
    pts = np.zeros((3, 3))
    nrm = np.tile([0, 0, 1.0], (3, 1))
    k = np.array([400.0, 2500.0, 1e9])
    p, vss = pm.probe(pts, nrm, k, rng=0)
    t = TactilePointCloud.from_probes(pts, vss, p, direction=-nrm)
    np.testing.assert_allclose(t.values, pm.true_c(k))
    assert t.values[2] == pytest.approx(pm.counts_per_newton * pm.layer_stiffness, rel=1e-5)  # layer-limited
    with pytest.raises(InputError):
        pm.probe(pts[:1], nrm[:1], [0.0])


def test_objects_follow_the_paper():
    eb, fb = make_seed000_object("empty_bottle"), make_seed000_object("full_bottle")
    assert eb.mesh.is_watertight and np.allclose(eb.mesh.vertices, fb.mesh.vertices)   # identical shape
    side = lambda z: np.array([[0.032, 0.0, z]])
    body, shoulder, bottom, cap = side(0.09), side(0.119), side(0.02), np.array([[0.0, 0.0, 0.19]])
    for b in (eb, fb):
        k = lambda q: float(b.stiffness(q)[0])
        assert k(shoulder) > 1.5 * k(body) and k(bottom) > 1.2 * k(body) and k(cap) > 10 * k(body)
    assert fb.stiffness(body)[0] > 3 * eb.stiffness(body)[0]
    lo, hi = make_seed000_object("cube_low_shore"), make_seed000_object("cube_high_shore")
    face, edge, vertex = [[0.0, 0.0, 0.06]], [[0.0, 0.0299, 0.06]], [[0.0299, 0.0299, 0.06]]
    for cube in (lo, hi):
        assert cube.stiffness(vertex)[0] > cube.stiffness(edge)[0] > 1.3 * cube.stiffness(face)[0]
    ratio = lambda cb: cb.stiffness(edge)[0] / cb.stiffness(face)[0]
    assert ratio(hi) > ratio(lo)                                          # more evident on high shore
    tb, sb = make_seed000_object("tennis_ball"), make_seed000_object("sponge_ball")
    pts = tb.mesh.vertices
    assert np.ptp(tb.stiffness(pts)) == 0 and tb.stiffness(pts)[0] > 10 * sb.stiffness(pts)[0]
    assert set(OBJECTS) == {"empty_bottle", "full_bottle", "tennis_ball", "sponge_ball", "cube_low_shore",
                            "cube_high_shore"}
    with pytest.raises(InputError, match="unknown object"):
        make_seed000_object("teapot")


def test_contact_prober_orders_soft_and_stiff():
    """The contact simulator's probe (one CySkin module, force control to p̄*) through Eq. 1."""
    from vtcore.augment.probing import ContactProber, probe_pose
    from vtcore.contact import SoftLayer

    layer = SoftLayer(thickness=0.003)
    ball = make_seed000_object("tennis_ball")
    v, n = np.array([[0.0335, 0.0, 0.0335]]), np.array([[1.0, 0.0, 0.0]])
    pose = probe_pose(v[0], n[0], layer.thickness)
    np.testing.assert_allclose(pose[:3, :3] @ n[0], [0, 0, -1], atol=1e-12)   # normal faces the skin
    np.testing.assert_allclose(pose[:3, :3] @ v[0] + pose[:3, 3], [0, 0, layer.thickness], atol=1e-12)

    def effect(k_field, mesh, result):          # stands in for the object_compliance effect
        return float(k_field(result.contact_point_object[None, :])[0])

    out = {}
    for name in ("tennis_ball", "sponge_ball"):
        obj = make_seed000_object(name)
        vv = v * (obj.meta["radius"] / 0.0335)
        prober = ContactProber(obj, layer, stiffness=effect)
        p, vss = prober(vv, n)
        assert p[0] == pytest.approx(4000.0, rel=2e-3)
        out[name] = compliance(p, vss, vv, direction=-n)[0]
        r = prober.results[0]
        disp = np.linalg.norm(vss[0] - vv[0])
        assert disp == pytest.approx(r.result.indentation + r.force / obj.stiffness(vv)[0], rel=1e-6)
    assert out["sponge_ball"] < 0.2 * out["tennis_ball"]
