"""Issue 13: resource guards before allocation and finite-in/finite-out at the public edges."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from test_inputs import SCENE, cli, one_error_line
from vtcore.errors import InputError

CATEGORY = SCENE.parent / "category_3mm.toml"


@pytest.mark.parametrize("setting, needle", [
    ("layout.patch=\"strip:100000\"", "layout.patch: a strip of 100000 modules"),
    ("effects.quantisation.step=1e-320", "effects.quantisation.step: must be >= 1e-06"),
    ("task.force=1e308", "task.force: must be <= 10000.0 N"),
    ("layer.young_modulus=1e-300", "layer.young_modulus: must be >= 1.0 Pa"),
])
def test_scene_values_out_of_range_are_refused_up_front(setting, needle):
    rc, _, err = cli("run", SCENE, "--check", "--set", setting)
    one_error_line(rc, err, needle)


@pytest.mark.parametrize("scene, setting, needle", [
    (SCENE, "task.readings=1000000", "task.readings: 1000000 readings x 60 taxels would need"),
    (SCENE, "layer.samples_per_taxel=1000000", "layer.samples_per_taxel: 1000000 samples per taxel x 60 taxels"),
    (CATEGORY, "task.readings=1000000", "task.readings: 12000000 readings x 60 taxels"),
])
def test_sizes_past_the_memory_budget_are_refused_before_the_work(tmp_path, scene, setting, needle):
    rc, _, err = cli("run", scene, "--set", setting, "--out", tmp_path / "o")
    one_error_line(rc, err, needle, "VTCORE_MEMORY_BUDGET")
    assert not (tmp_path / "o").exists()


def test_budget_is_a_setting(monkeypatch):
    from vtcore.scene import load_scene
    from vtcore.scene.budget import check_run_sizes

    scene = load_scene(SCENE, ["task.readings=100000"])
    check_run_sizes(scene, 60)
    monkeypatch.setenv("VTCORE_MEMORY_BUDGET", "64M")
    with pytest.raises(InputError, match="task.readings: 100000 readings x 60 taxels would need 732 MiB"):
        check_run_sizes(scene, 60)


@pytest.fixture
def strict():
    with warnings.catch_warnings():
        warnings.simplefilter("error", RuntimeWarning)
        yield


def test_propagation_far_from_the_origin(strict):
    from vtcore.augment import ClusterPropagation, SmoothPropagation

    rng = np.random.default_rng(0)
    v = rng.normal(size=20)
    x = rng.normal(size=(20, 3)) * 3e149
    for k in (None, 5):
        assert np.isfinite(SmoothPropagation(k_nearest=k).fit(x, v).predict(x * 1.01)).all()
    assert np.isfinite(ClusterPropagation().fit(x, v).predict(x)).all()
    for k in (None, 5):                                 # IndexError (k=5) and all-NaN before
        with pytest.raises(InputError, match=r"within \+-1e\+150"):
            SmoothPropagation(k_nearest=k).fit(x * 1e150, v)


def test_edge_filter_is_finite_or_says_why(strict):
    from test_can_helpers import hexagon_layout
    from vtcore.filters import EdgeFilter, edge_filter
    from vtcore.layout import skin_mesh

    mesh = skin_mesh(hexagon_layout())
    p = np.random.default_rng(1).random((3, 60))
    ref = edge_filter(mesh, p)
    for s in (2.0 ** 300, 2.0 ** -300):                 # homogeneous of degree 2, exactly
        np.testing.assert_array_equal(edge_filter(mesh, p * s), ref * s * s)
    np.testing.assert_allclose(EdgeFilter(mesh, np.float32)(p * 1e18), ref * 1e36, rtol=1e-5)
    with pytest.raises(InputError, match="values must stay below"):
        edge_filter(mesh, p * 1e160)                     # returned inf before


def test_accuracy_of_nothing_and_tiny_objects(strict):
    from vtcore.categorize import accuracy
    from vtcore.contact.objects import make_object

    with pytest.raises(InputError, match="at least one label"):
        accuracy([], [])                                 # NaN before
    with pytest.raises(InputError, match=r"radius must be in \[1e-06, 1000\] m"):
        make_object("sphere", radius=1e-200)             # NaN vertices before
    assert np.isfinite(make_object("sphere", radius=1e-6).vertices).all()


def test_press_refuses_a_force_it_cannot_solve(strict):
    from test_can_helpers import hexagon_layout
    from vtcore.contact import SoftLayer, press
    from vtcore.contact.objects import make_object

    pose = np.eye(4)
    pose[2, 3] = 0.005
    with pytest.raises(InputError, match=r"force in \[0, 1e\+09\] N"):    # returned force 0 before
        press(hexagon_layout(), make_object("sphere", radius=0.03), pose, SoftLayer(thickness=0.003, extent=0.04),
              force=1e300)
