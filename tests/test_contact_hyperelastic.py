"""The large-compression layer (issue 35): the fast Seth-Hill model in press(), its hard cases, and the
finite-element reference it is fitted to (slow)."""

import warnings

import numpy as np
import pytest

from vtcore.contact import SoftLayer, make_object, placement_pose, press
from vtcore.contact.elastic import compliance_operator, solve_pk
from vtcore.contact.hyperelastic import BOTTOM_OUT, elongation, solve_large, strain
from vtcore.contact.indenters import CASES, Indenter
from vtcore.errors import InputError, UnreachableTargetError
from vtcore.layout import Layout, hexagon_flat, wrap_on_sphere


def _layout():
    flat, mod = hexagon_flat()
    pos, nrm = wrap_on_sphere(flat, np.inf)
    return Layout(pos, nrm, np.arange(len(pos)), mod, flat=flat)


FLAT = _layout()


def _grid_gap(ind, n, half):
    dx = 2 * half / n
    x = (np.arange(n) - n / 2 + 0.5) * dx
    X, Y = np.meshgrid(x, x, indexing="ij")
    return ind.gap(X, Y), dx


def test_strain_is_seth_hill_and_finite_everywhere():
    c = np.linspace(-3, 2, 501)
    for m in (-1.0, 0.0, 0.5, 1.0):
        phi = strain(c, m)
        assert np.isfinite(phi).all() and (np.diff(phi) > 0).all()
    assert strain(0.3, 1.0) == pytest.approx(0.3)
    assert strain(0.3, 0.0) == pytest.approx(-np.log(0.7))
    assert strain(0.3, -2.0) == pytest.approx((1 - 0.7**-2) / -2)
    small = 1e-4
    assert strain(small, 0.4) == pytest.approx(small, rel=1e-3)  # the linear layer at small compression


def test_small_compression_equals_the_linear_layer():
    lay = SoftLayer(thickness=0.003)
    g, dx = _grid_gap(CASES["sphere"], 48, 0.012)
    op = compliance_operator(g.shape, dx, dx, lay, "finite_layer")
    d = 0.01 * lay.thickness
    lin = solve_pk(g, op, dx * dx, approach=d)
    big = solve_large(g, op, dx * dx, lay.thickness, approach=d)
    assert big.pressure.sum() == pytest.approx(lin.pressure.sum(), rel=0.01)
    assert big.pressure.sum() > lin.pressure.sum()  # and stiffer, never softer


def test_press_selects_the_model_and_reaches_the_force():
    m = make_object("sphere")
    pose = placement_pose(m, top=0.003, gap=1e-3)
    lay = SoftLayer(thickness=0.003, extent=0.04)
    lin = press(FLAT, m, pose, lay, force=5.0)
    big = press(FLAT, m, pose, lay, force=5.0, model="hyperelastic")
    assert big.force == pytest.approx(5.0, rel=1e-6) and big.model == "hyperelastic"
    assert big.indentation < lin.indentation  # the layer stiffens with compression
    assert np.isfinite(big.pressure).all() and big.max_compression < 0.003
    with pytest.raises(InputError, match="model"):
        press(FLAT, m, pose, lay, force=5.0, model="neo_hooke")


@pytest.mark.parametrize("c", [0.0, 0.3, 0.6, 0.8])
def test_compression_0_to_80_percent_is_finite(c):
    lay = SoftLayer(thickness=0.003)
    g, dx = _grid_gap(CASES["sphere"], 48, 0.012)
    op = compliance_operator(g.shape, dx, dx, lay, "finite_layer")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        s = solve_large(g, op, dx * dx, lay.thickness, approach=c * lay.thickness)
    assert any("fitted" in str(w.message) for w in caught) == (c > 0.6)
    assert np.isfinite(s.pressure).all() and (s.pressure >= 0).all()
    assert (s.displacement < lay.thickness).all()
    assert (s.pressure.sum() > 0) == (c > 0)


@pytest.mark.parametrize("h", [0.0005, 0.03])
def test_thin_and_thick_layers(h):
    lay = SoftLayer(thickness=h)
    g, dx = _grid_gap(CASES["sphere"], 64, max(0.012, 2 * h))
    op = compliance_operator(g.shape, dx, dx, lay, "finite_layer")
    s = solve_large(g, op, dx * dx, h, force=1.0)
    assert s.pressure.sum() * dx * dx == pytest.approx(1.0, rel=1e-6)
    assert s.displacement.max() < BOTTOM_OUT * h * 1.01


def test_edge_sharper_than_the_grid_and_nearly_incompressible():
    lay = SoftLayer(thickness=0.003, poisson=0.4999)
    ind = Indenter("punch", 0.005, 0.0001)  # a 0.1 mm edge on a 0.5 mm grid
    g, dx = _grid_gap(ind, 48, 0.012)
    op = compliance_operator(g.shape, dx, dx, lay, "finite_layer")
    s = solve_large(g, op, dx * dx, lay.thickness, force=2.0)
    assert np.isfinite(s.pressure).all() and s.pressure.sum() * dx * dx == pytest.approx(2.0, rel=1e-6)


def test_bottoming_out_is_refused_not_a_negative_thickness():
    lay = SoftLayer(thickness=0.001)
    g, dx = _grid_gap(CASES["punch"], 48, 0.012)
    op = compliance_operator(g.shape, dx, dx, lay, "finite_layer")
    with pytest.raises(UnreachableTargetError, match="bottoms out"):
        solve_large(g, op, dx * dx, lay.thickness, force=1e5)


def test_compression_past_the_fitted_range_warns():
    m = make_object("sphere")
    pose = placement_pose(m, top=0.002, gap=1e-3)
    lay = SoftLayer(thickness=0.002, extent=0.04)
    with pytest.warns(UserWarning, match="fitted"):
        r = press(FLAT, m, pose, lay, indentation=0.0016, model="hyperelastic")
    assert np.isfinite(r.pressure).all() and r.max_compression < 0.002


@pytest.mark.slow
def test_reference_matches_the_linear_layer_at_small_compression_and_fast_model_at_large():
    """The finite-element reference (scikit-fem) against the FFT layer: a sphere into 3 mm."""
    from vtcore.contact.fem_reference import reference_press

    lay = SoftLayer(thickness=0.003)
    ref = reference_press(CASES["sphere"], lay.thickness, lay.young_modulus, lay.poisson, [0.05, 0.3])
    g, dx = _grid_gap(CASES["sphere"], 128, 0.015)
    op = compliance_operator(g.shape, dx, dx, lay, "finite_layer")
    lin = solve_pk(g, op, dx * dx, approach=0.05 * lay.thickness).pressure.sum() * dx * dx
    assert lin == pytest.approx(ref.force[0], rel=0.03)
    big = solve_large(g, op, dx * dx, lay.thickness, approach=0.3 * lay.thickness).pressure.sum() * dx * dx
    assert big == pytest.approx(ref.force[1], rel=0.10)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert np.isfinite(ref.peak_pressure).all() and (np.diff(ref.contact_radius) > 0).all()


def test_scene_selects_the_model_and_refuses_an_unknown_one(tmp_path):
    from vtcore.errors import SceneError
    from vtcore.scene import run_scene

    text = """
[scene]
name = "t"
task = "press"
seed = 3
[end_effector]
shape = "plane"
[layout]
patch = "hexagon"
[layer]
thickness = 0.003
extent = 0.04
grid_spacing = 0.0015
samples_per_taxel = 3
model = "{model}"
[[objects]]
name = "ball"
kind = "sphere"
radius = 0.03
[task]
force = 5.0
[output]
plots = false
"""
    p = tmp_path / "s.toml"
    p.write_text(text.format(model="hyperelastic"))
    run_scene(p, tmp_path / "o")
    assert any("hyperelastic" in f.read_text(errors="ignore") for f in (tmp_path / "o").rglob("*.md"))
    p.write_text(text.format(model="neo_hooke"))
    with pytest.raises(SceneError, match=r"layer\.model"):
        run_scene(p, tmp_path / "p")


def lane_presses(want: dict, **solve):
    """Press each of ``want``'s indenters (kind -> (approach, peak, sum of p^2)) with 3 N into 3 mm on a
    48 x 48 grid of 0.5 mm and compare with those numbers to 1e-9 (the lanes' agreement). The finger pad
    is cut to 16 mm long: an elongated footprint."""
    lay = SoftLayer(thickness=0.003)
    n = 48
    dx = 0.024 / n
    x = (np.arange(n) - n / 2 + 0.5) * dx
    X, Y = np.meshgrid(x, x, indexing="ij")
    for kind, (d, peak, p2) in want.items():
        g = CASES[kind].gap(X, Y)
        if kind == "finger":
            g = np.where(np.abs(Y) < 0.008, g, np.inf)
        s = solve_large(g, compliance_operator(g.shape, dx, dx, lay, "finite_layer"), dx * dx, 0.003, force=3.0,
                        **solve)
        assert s.pressure.sum() * dx * dx == pytest.approx(3.0, rel=1e-6)
        assert (s.approach, s.pressure.max(), (s.pressure**2).sum()) == pytest.approx((d, peak, p2), rel=1e-9)


def test_same_numbers_in_both_python_lanes():
    """The py311 and py313 lanes (numpy 1.26 / 2, scipy's FFTs) agree to 1e-9: the values were computed
    in the py311 lane (order 0.4, the single-order model ``order=`` still selects) and agree there and in
    py313 to ~1e-15."""
    lane_presses({"sphere": (0.0010296683392950958, 55832.031617437424, 445398590155.81433),
                  "punch": (0.0007221370591799151, 50508.11602705082, 493112461166.36487)}, order=0.4)


def test_same_numbers_in_both_python_lanes_with_the_fitted_law():
    """The round/strip law with its local stiffening: computed in the py311 lane, equal in py313 to ~1e-15."""
    lane_presses({"sphere": (0.0010555061950975068, 53720.96614879233, 434255572438.2581),
                  "punch": (0.0007535381547990421, 50345.13177496441, 489303414353.88354),
                  "finger": (0.0007468251555403661, 59361.1895116487, 402614030904.57385)})


def test_elongation_of_discs_ellipses_and_strips():
    """0 for a disc (on square or oblong cells), 1 - b/a for an ellipse, near 1 for a long strip; each
    connected contact its own (two discs side by side are two round contacts, not one long one)."""
    x = (np.arange(200) - 99.5) * 1e-4
    X, Y = np.meshgrid(x, x, indexing="ij")
    assert elongation(np.hypot(X, Y) < 5e-3, (1e-4, 1e-4)).max() < 0.02
    Xs, Ys = np.meshgrid(x, x[::2], indexing="ij")  # cells twice as long along y
    assert elongation(np.hypot(Xs, Ys) < 5e-3, (1e-4, 2e-4)).max() < 0.02  # a disc in metres
    e = elongation(np.hypot(X / 2, Y) < 4e-3, (1e-4, 1e-4))
    assert e.max() == pytest.approx(0.5, abs=0.02) and e[0, 0] == 0
    assert elongation(np.abs(X) < 5e-4, (1e-4, 1e-4)).max() > 0.9
    two = (np.hypot(X - 5e-3, Y) < 3e-3) | (np.hypot(X + 5e-3, Y) < 3e-3)
    assert elongation(two, (1e-4, 1e-4)).max() < 0.02


def test_unrolled_geometry_takes_the_model_too():
    """On a flat patch the unrolled solve equals the plane one (as for the linear models)."""
    m = make_object("sphere")
    pose = placement_pose(m, top=0.003, gap=1e-3)
    lay = SoftLayer(thickness=0.003, extent=0.04)
    plane = press(FLAT, m, pose, lay, force=5.0, model="hyperelastic")
    flat = press(FLAT, m, pose, lay, force=5.0, model="hyperelastic", geometry="unrolled")
    assert flat.force == pytest.approx(5.0, rel=1e-3)
    assert flat.indentation == pytest.approx(plane.indentation, rel=0.02)


def test_reference_cache_merges_finer_meshes_and_holds_the_fitted_cases(tmp_path):
    """The cached FE sweeps: a rerun on a finer mesh replaces the h/8 values at its compressions (and
    says so), and the shipped file holds every case the law was fitted on, to 60 %."""
    from vtcore.contact.layer_bench import FIT_CASES, load_references, mesh_label, store_reference

    f = tmp_path / "refs.json"
    base = {"c": [0.05, 0.1, 0.2], "f": [1.0, 2.0, 3.0], "p": [10.0, 20.0, 30.0], "a": [1e-3, 2e-3, 3e-3]}
    store_reference("sphere_0.003", base, f, "test")
    store_reference("sphere_0.003@h/16", {"c": [0.05, 0.1], "f": [1.1, 2.1], "p": [9.0, 19.0], "a": [1e-3, 2e-3],
                                          "fine": 0.003 / 16}, f, "test")
    ref = load_references(f)["sphere_0.003"]
    assert ref["p"] == [9.0, 19.0, 30.0] and ref["f"] == [1.1, 2.1, 3.0] and ref["refined"] == [0.05, 0.1]
    assert mesh_label(ref) == "h/16 5-10 %, h/8 20 %" and set(load_references(f)) == {"sphere_0.003"}
    assert load_references(tmp_path / "none.json") == {}
    shipped = load_references()
    for key in FIT_CASES:
        assert shipped[key]["c"][-1] == pytest.approx(0.6) and np.isfinite(shipped[key]["p"]).all()
