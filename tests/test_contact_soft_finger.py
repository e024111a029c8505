"""A soft indenter (vtcore.contact.soft_finger): the two bodies' compliances in series."""

import numpy as np
import pytest

from vtcore.contact import ContactGrid, SoftLayer, make_object, press
from vtcore.contact.elastic import compliance_operator, solve_pk
from vtcore.contact.soft_finger import finger_pad, soft_indenter
from vtcore.errors import InputError


def _sphere_gap(n, dx, R):
    x = (np.arange(n) - n / 2 + 0.5) * dx
    X, Y = np.meshgrid(x, x, indexing="ij")
    return R - np.sqrt(R**2 - X**2 - Y**2)


@pytest.mark.parametrize("ratio", [0.5, 1.0, 4.0])
def test_two_elastic_half_spaces_follow_hertz_with_the_combined_modulus(ratio):
    """Hertz for two elastic bodies (Johnson, Contact Mechanics, 1985, eqs. 4.22-4.23): a sphere of
    modulus E1 on a flat of E2 behaves as a rigid sphere on 1/E* = 1/E1* + 1/E2*."""
    skin = SoftLayer()
    lay = soft_indenter(skin, finger_pad(ratio * skin.young_modulus, 1.0, skin.poisson))
    R, F, dx, n = 0.03, 1.0, 0.25e-3, 96
    sol = solve_pk(_sphere_gap(n, dx, R), compliance_operator((n, n), dx, dx, lay, "halfspace"), dx * dx, force=F)
    e_star = 1.0 / (1.0 / skin.e_star + 1.0 / lay.pad.e_star)
    a = (3 * F * R / (4 * e_star)) ** (1 / 3)
    assert sol.converged and sol.pressure.min() >= 0
    assert sol.pressure.max() == pytest.approx(3 * F / (2 * np.pi * a * a), rel=0.02)
    assert sol.approach == pytest.approx(a * a / R, rel=0.01)


def _fingertip(layer, pad=None, force=2.0):
    from vtcore.layout import Layout

    xs = np.arange(-20, 21, 2.0) * 1e-3
    X, Y = np.meshgrid(xs, xs, indexing="ij")
    pos = np.stack([X.ravel(), Y.ravel(), np.zeros(X.size)], axis=1)
    lay = Layout(positions=pos, normals=np.tile([0.0, 0.0, 1.0], (len(pos), 1)), taxel_ids=np.arange(len(pos)),
                 module_ids=np.zeros(len(pos), int))
    mesh = make_object("sphere", radius=0.008)
    pose = np.eye(4)
    pose[2, 3] = layer.thickness + 1e-4
    use = layer if pad is None else soft_indenter(layer, pad)
    return press(lay, mesh, pose, use, force=force, spread=False, grid=ContactGrid(spacing=0.5e-3))


def test_a_soft_pad_spreads_the_press_and_lowers_its_peak():
    skin = SoftLayer(thickness=0.005)
    rigid = _fingertip(skin)
    soft = _fingertip(skin, finger_pad(skin.young_modulus, 0.004))
    stiff = _fingertip(skin, finger_pad(1e3 * skin.young_modulus, 0.004))
    pr, ps = rigid.field.pressure, soft.field.pressure
    assert soft.force == pytest.approx(2.0, rel=1e-6)
    assert soft.contact_area > 1.3 * rigid.contact_area
    assert ps.max() < 0.8 * pr.max()         # the same force over a larger footprint
    # a pad 1000 times stiffer than the layer is the rigid indenter again
    assert stiff.field.pressure.max() == pytest.approx(pr.max(), rel=0.02)


def test_without_a_pad_the_layer_solves_as_before():
    skin = SoftLayer(thickness=0.005)
    a = _fingertip(skin)
    b = _fingertip(SoftLayer(thickness=0.005))
    assert np.array_equal(a.field.pressure, b.field.pressure)


@pytest.mark.parametrize("kw, key", [({"pad_modulus": 0.0, "core_depth": 0.004}, "pad_modulus"),
                                      ({"pad_modulus": 5e4, "core_depth": -1.0}, "core_depth"),
                                      ({"pad_modulus": "soft", "core_depth": 0.004}, "pad_modulus")])
def test_a_bad_pad_is_refused_by_name(kw, key):
    with pytest.raises(InputError) as e:
        finger_pad(**kw)
    assert e.value.key == key


def test_the_calibration_s_soft_finger_is_a_finger_pad_through_a_padded_layer():
    from vtcore.calibrate.simulate import soft_finger_parts

    skin = SoftLayer(thickness=0.005)
    ind, lay = soft_finger_parts({"kind": "softfinger", "radius": 0.008, "length": 0.05, "pad_modulus": 3e4,
                                  "core_depth": 0.003}, skin)
    assert ind == {"kind": "fingerpad", "radius": 0.008, "length": 0.05}
    assert lay.pad.young_modulus == 3e4 and lay.pad.thickness == 0.003 and lay.thickness == skin.thickness
    same = {"kind": "fingerpad", "radius": 0.008}
    assert soft_finger_parts(dict(same), skin) == (same, skin)        # a rigid pad passes as given
    with pytest.raises(InputError) as e:                              # the bone inside the finger
        soft_finger_parts({"kind": "softfinger", "radius": 0.006, "core_depth": 0.006}, skin)
    assert e.value.key == "core_depth"
