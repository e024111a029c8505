"""Sensor profiles (issue 27): the shipped CySkin profile, the loader's checks, the censored noise fit,
the contact rule and the finger-pad indenter."""

import json
from pathlib import Path

import numpy as np
import pytest

from vtcore.calibrate.noise import censored_normal_fit
from vtcore.calibrate.recordings import contact_frames, idle_mask
from vtcore.contact.objects import make_object, placement_pose
from vtcore.contact.profile import PROFILES_DIR, load_profile, profile_toml, save_profile
from vtcore.errors import FormatError, InputError

ROOT = Path(__file__).resolve().parents[1]


def test_shipped_cyskin_profile_loads_with_measured_noise():
    p = load_profile("cyskin")
    # measured on shared/data/cyskin_gesture (median ~180-190 counts, IQR ~100-310): the censored fit
    assert 120 < p.noise_sigma < 260
    assert p.noise_sigma_iqr[0] < p.noise_sigma < p.noise_sigma_iqr[1]
    assert p.noise_sigma_ci95[0] <= p.noise_sigma <= p.noise_sigma_ci95[1]
    assert p.detection_k == 5.0
    assert p.taxel_ids is not None and len(p.taxel_ids) == len(p.taxel_sigma) > 600
    assert load_profile(PROFILES_DIR / "cyskin.toml").noise_sigma == p.noise_sigma


def test_per_taxel_values_fall_back_to_the_median_for_unknown_uids():
    p = load_profile("cyskin")
    known = p.taxel_ids[np.isfinite(p.taxel_sigma)][:3]
    sig = p.per_taxel(np.concatenate([known, [1, 2]]))
    assert np.allclose(sig[:3], p.taxel_sigma[np.isfinite(p.taxel_sigma)][:3])
    assert np.allclose(sig[3:], p.noise_sigma)
    assert np.allclose(p.threshold([1]), 5.0 * p.noise_sigma)


GOOD = {"profile": {"name": "t"}, "noise": {"sigma_counts": 100.0}, "detection": {"k": 4.0}}


def _doc(**patch):
    d = json.loads(json.dumps(GOOD))
    for key, value in patch.items():
        table, k = key.split("__")
        if value is None:
            d[table].pop(k, None)
        else:
            d.setdefault(table, {})[k] = value
    return d


@pytest.mark.parametrize("patch, key", [
    ({"noise__sigma_counts": None}, "noise.sigma_counts"),
    ({"detection__k": None}, "detection.k"),
    ({"noise__sigma_counts": -5.0}, "noise.sigma_counts"),
    ({"noise__sigma_counts": 1e6}, "noise.sigma_counts"),
    ({"detection__k": 0.0}, "detection.k"),
    ({"noise__sigma_counts_iqr": [300.0, 100.0]}, "noise.sigma_counts_iqr"),
    ({"noise__sigmaa": 3.0}, "noise.sigmaa"),
    ({"response__thickness_m": 0.5, "response__young_modulus_pa": 5e4, "response__counts_per_pa": 1.0},
     "response.thickness_m"),
    ({"response__thickness_m": 0.003, "response__counts_per_pa": 1.0}, "response.young_modulus_pa"),
    ({"response__thickness_m": 0.005, "response__young_modulus_pa": 5e4, "response__counts_per_pa": 1.0,
      "response__indenter": {"kind": "fingerpad", "radius": 0.007, "wrap": 1.5}}, "response.indenter.wrap"),
    ({"response__thickness_m": 0.005, "response__young_modulus_pa": 5e4, "response__counts_per_pa": 1.0,
      "response__indenter": {"kind": "finger", "radius": 0.007}}, "response.indenter.kind"),
    ({"response__thickness_m": 0.005, "response__young_modulus_pa": 5e4, "response__counts_per_pa": 1.0,
      "response__indenter": {"kind": "fingerpad", "radius": "7 mm"}}, "response.indenter.radius"),
    ({"taxels__uid": [17, 18], "taxels__sigma_counts": [100.0]}, "taxels.sigma_counts"),
    ({"taxels__uid": [17, 18], "taxels__sigma_counts": [100.0, -1.0]}, "taxels.sigma_counts"),
])
def test_missing_or_out_of_range_values_name_the_file_and_key(tmp_path, patch, key):
    path = tmp_path / "bad.toml"
    path.write_text(profile_toml(_doc(**patch)))
    with pytest.raises(InputError) as e:
        load_profile(path)
    assert e.value.key == key and "bad.toml" in str(e.value)


def test_missing_table_and_broken_toml_and_unknown_name(tmp_path):
    path = tmp_path / "p.toml"
    path.write_text("[profile]\nname = 't'\n[noise]\nsigma_counts = 10.0\n")
    with pytest.raises(InputError, match="detection"):
        load_profile(path)
    path.write_text("[profile]\nname = 't'\n[noise\n")
    with pytest.raises(FormatError) as e:
        load_profile(path)
    assert e.value.line == 3
    with pytest.raises(InputError, match="cyskin"):
        load_profile("no_such_profile")


def test_save_profile_refuses_what_load_would_refuse(tmp_path):
    with pytest.raises(InputError):
        save_profile(tmp_path / "x.toml", _doc(detection__k=-1.0))
    assert not (tmp_path / "x.toml").exists()
    p = save_profile(tmp_path / "y.toml", _doc(taxels__uid=[17, 18], taxels__sigma_counts=[50.0, float("nan")]))
    assert np.allclose(p.per_taxel([18, 17]), [100.0, 50.0])   # nan: not identified -> the median


def _clipped(rng, sigma, offset, t=150):
    y = offset + sigma * rng.normal(size=(t, len(sigma)))
    return np.rint(np.maximum(y, 0.0))


def test_clipped_at_zero_noise_needs_the_censored_fit():
    rng = np.random.default_rng(7)
    sigma = rng.uniform(60, 400, 500)
    offset = rng.normal(0, 0.3, 500) * sigma
    y = _clipped(rng, sigma, offset)
    fit = censored_normal_fit([(y[:75], np.arange(75) * 0.1, True), (y[75:], np.arange(75) * 0.1, True)])
    assert fit.converged
    ratio = fit.sigma / sigma
    assert abs(np.median(ratio) - 1) < 0.03             # unbiased over taxels
    assert np.median(np.abs(ratio - 1)) < 0.1           # each within its sampling error (~8 % at n = 150)
    assert abs(np.median(y.std(axis=0) / sigma) - 1) > 0.3   # the naive std of clipped data is far off
    assert np.median(np.abs(fit.offset - offset) / sigma) < 0.1
    assert 0.3 < np.median(fit.censored) < 0.7
    assert abs(np.median(fit.lag1)) < 0.05               # white noise


def test_a_taxel_that_reads_zero_throughout_is_not_identified():
    rng = np.random.default_rng(1)
    y = _clipped(rng, np.array([100.0, 100.0]), np.array([0.0, -1000.0]))
    fit = censored_normal_fit([(y, np.arange(len(y)) * 0.1, True)])
    assert np.isfinite(fit.sigma[0]) and np.isnan(fit.sigma[1])


def test_contact_rule_and_idle_guard():
    pos = np.column_stack([np.arange(10) * 0.007, np.zeros(10), np.zeros(10)])
    sigma = np.full(10, 100.0)
    c = np.zeros((6, 10))
    c[2, 3:6] = [800, 2000, 900]      # three neighbours above 5 sigma: contact
    c[4, 0] = 5000                    # one lone spike: not a contact
    got = contact_frames(c, sigma, pos)
    assert got.tolist() == [False, False, True, False, False, False]
    assert idle_mask(got, guard=2).tolist() == [False, False, False, False, False, True]


def test_fingerpad_is_a_closed_capsule_lying_along_x():
    m = make_object("fingerpad", radius=0.008, length=0.04)
    assert m.is_watertight and m.volume > 0
    assert np.allclose(m.bounds, [[-0.02, -0.008, 0.0], [0.02, 0.008, 0.016]], atol=1e-9)
    assert np.isclose(m.volume, np.pi * 0.008**2 * 0.024 + 4 / 3 * np.pi * 0.008**3, rtol=0.01)
    with pytest.raises(InputError, match="twice the radius"):
        make_object("fingerpad", radius=0.01, length=0.015)
    pose = placement_pose(m, xy=(0.01, 0.0), yaw=np.pi / 2, top=0.003)
    v = m.vertices @ pose[:3, :3].T + pose[:3, 3]
    assert np.isclose(v[:, 2].min(), 0.003) and np.ptp(v[:, 1]) > np.ptp(v[:, 0])   # yawed: long along y


def test_a_finger_pad_wraps_a_convex_skin_by_its_wrap():
    """``wrap`` (the fitted pad's, issue 27): the fraction of the curvature of the arc concentric with the
    skin that the pad's axis follows; 1 wraps it, 0 is straight, and a value outside 0-1 names the key."""
    from vtcore.calibrate.simulate import MatchedPress, check_wrap
    from vtcore.contact import SoftLayer
    from vtcore.layout import load

    lay = load(ROOT / "scenes" / "layouts" / "seed001_hexagon.cyskin.json")
    layer = SoftLayer(thickness=0.005, material="ecoflex_00_20")
    pad = {"kind": "fingerpad", "radius": 0.007, "length": 0.06}
    kappa = 1 / 0.076                                          # the shared patch's radius

    def sag(wrap):           # how far the pad's pressed line lies lower at its middle than where its caps begin
        v = MatchedPress(lay, layer, {**pad, "wrap": wrap}).mesh(kappa).vertices
        line = v[(np.abs(v[:, 1]) < 1e-4) & (v[:, 2] < 0.007)]
        mid = line[np.argmin(np.abs(line[:, 0]))]
        end = line[np.argmin(np.abs(np.abs(line[:, 0]) - 0.023))]
        return end[2] - mid[2]

    full, part, none = sag(1.0), sag(0.5), sag(0.0)
    r_full = 0.076 + 0.005 + 0.007
    assert none == pytest.approx(0.0, abs=1e-4)                # straight
    assert part == pytest.approx(full / 2, rel=0.15)           # half the curvature: half the sag
    assert full == pytest.approx(r_full - np.sqrt(r_full**2 - 0.023**2), rel=0.15)   # the concentric arc
    assert MatchedPress(lay, layer, pad).wrap == 1.0           # the default: wrap fully
    for bad in (1.5, -0.1, "a", None, True, float("nan")):
        with pytest.raises(InputError) as e:
            check_wrap(bad)
        assert e.value.key == "wrap"


PRESS = """
[scene]
name = "p"
task = "press"
seed = 4
[end_effector]
shape = "plane"
[layout]
patch = "hexagon"
[layer]
thickness = 0.003
extent = 0.04
grid_spacing = 0.002
samples_per_taxel = 1
[[objects]]
kind = "fingerpad"
[task]
force = 1.0
readings = 400
[effects.gain]
{gain}
[effects.noise]
{noise}
[output]
plots = false
"""


def test_fingerpad_in_a_scene_presses_an_elongated_footprint(tmp_path):
    from vtcore.scene import run_scene

    p = tmp_path / "s.toml"
    p.write_text(PRESS.format(gain="counts_per_pa = 1.0", noise="sigma = 0.0").replace("readings = 400", "readings = 1")
                 .replace('kind = "fingerpad"', 'kind = "fingerpad"\nradius = 0.008\nlength = 0.04\nyaw = 0.0')
                 .replace("force = 1.0", "force = 2.0"))
    res = run_scene(p, tmp_path / "out")
    arr = np.load(tmp_path / "out" / "arrays.npz")
    pres, pos = arr["pressure"][-1], arr["positions"]
    on = pres > 0.05 * pres.max()
    assert np.isclose(res["metrics"]["force_n"], 2.0, rtol=1e-3)
    assert np.ptp(pos[on, 0]) > 2 * np.ptp(pos[on, 1])   # long along x (yaw 0)


def test_scene_effects_take_the_profile(tmp_path):
    from vtcore.scene import run_scene

    p = tmp_path / "s.toml"
    p.write_text(PRESS.format(gain='profile = "cyskin"', noise='profile = "cyskin"'))
    res = run_scene(p, tmp_path / "out")
    prof = load_profile("cyskin")
    arr = np.load(tmp_path / "out" / "arrays.npz")
    counts = arr["frames"]
    clean = arr["pressure"][0] * prof.response.counts_per_pa
    # the hexagon's UIDs are not the recorded skin's: every taxel gets the profile's median sigma
    assert abs(np.std(counts - clean[None], axis=0).mean() / prof.noise_sigma - 1) < 0.1
    assert res["metrics"]["force_n"] > 0


@pytest.mark.parametrize("gain, noise, key", [
    ('profile = "cyskin"\ncounts_per_pa = 2.0', "sigma = 5.0", "effects.gain.counts_per_pa"),
    ("counts_per_pa = 1.0", 'profile = "cyskin"\nsigma = 5.0', "effects.noise.sigma"),
    ('profile = "nope"', "sigma = 5.0", "effects.gain.profile"),
])
def test_a_profile_and_a_number_for_the_same_value_is_an_error(tmp_path, gain, noise, key):
    from vtcore.scene import run_scene

    p = tmp_path / "s.toml"
    p.write_text(PRESS.format(gain=gain, noise=noise))
    with pytest.raises(InputError) as e:
        run_scene(p, tmp_path / "out")
    assert key in str(e.value)


def test_nan_quartiles_are_nanpercentiles():
    """The calibration's vectorised quartiles (its bootstrap's hot path) give numpy's nanpercentile,
    linear interpolation, with NaN gaps, a slice with one value and a slice with none."""
    from vtcore.calibrate.response import nan_quartiles

    rng = np.random.default_rng(0)
    a = rng.normal(size=(3, 4, 37, 2))
    a[rng.random(a.shape) < 0.3] = np.nan
    a[0, 0, :, 0] = np.nan
    a[1, 1, 1:, 1] = np.nan
    with pytest.warns(RuntimeWarning):
        ref = np.nanpercentile(a, [25, 50, 75], axis=-2)
    got = nan_quartiles(a, axis=-2)
    assert got.shape == (3, 3, 4, 2) and np.isnan(got[:, 0, 0, 0]).all() and (got[:, 1, 1, 1] == a[1, 1, 0, 1]).all()
    np.testing.assert_allclose(got, ref, rtol=1e-12, atol=1e-15, equal_nan=True)
