"""Contact simulation (issue 4): objects, proximity back-ends, elastic models, press, probe, sensor."""

import numpy as np
import pytest

from vtcore.contact import (MATERIALS, ContactGrid, SoftLayer, layer_factor, lower_envelope, make_object,
                            placement_pose, prepare_mesh, press, probe, sensor, signed_distance)
from vtcore.contact.elastic import compliance_operator, layer_transfer, solve_pk
from vtcore.errors import FormatError, InputError, UnreachableTargetError
from vtcore.layout import Layout, hexagon_flat, skin_mesh, wrap_on_sphere


def _layout(radius=np.inf):
    flat, mod = hexagon_flat()
    pos, nrm = wrap_on_sphere(flat, radius)
    return Layout(pos, nrm, np.arange(len(pos)), mod, flat=flat)


FLAT = _layout()


def _press(kind, h, force=10.0, layout=FLAT, base="bonded", **kw):
    m = make_object(kind)
    return press(layout, m, placement_pose(m, top=h, gap=1e-3), SoftLayer(thickness=h, extent=0.04, base=base),
                 force=force, **kw)


# --- materials and objects ---------------------------------------------------------------

def test_materials_have_sources_and_layer_validates():
    for name, m in MATERIALS.items():
        assert m["young_modulus"] > 0 and 0 <= m["poisson"] < 0.5 and m["source"], name
    lay = SoftLayer()
    assert lay.material == "ecoflex_00_20" and lay.young_modulus == pytest.approx(55158, rel=1e-3)
    assert "Smooth-On" in lay.source
    assert SoftLayer(young_modulus=1e5).source == "user value"
    with pytest.raises(InputError, match="unknown material"):
        SoftLayer(material="jelly")
    with pytest.raises(InputError):
        SoftLayer(thickness=-1e-3)
    with pytest.raises(InputError):
        SoftLayer(base="glued")


@pytest.mark.parametrize("kind", ["cube", "cuboid", "box", "sphere", "halfcylinder", "cylinder", "ruler", "mug"])
def test_objects_are_closed_and_rest_on_the_table(kind):
    m = make_object(kind)
    assert m.is_watertight and m.volume > 0
    assert m.bounds[0, 2] == pytest.approx(0.0, abs=1e-12)
    assert prepare_mesh(m).is_watertight  # still closed once duplicate vertices are merged


def test_object_dimensions_are_checked():
    assert make_object("cuboid").extents == pytest.approx([0.08, 0.03, 0.03])
    with pytest.raises(InputError, match="side"):
        make_object("cube", side=-0.01)
    with pytest.raises(InputError, match="unknown dimension"):
        make_object("sphere", side=0.01)
    with pytest.raises(InputError, match="unknown object kind"):
        make_object("teapot")


# --- proximity ---------------------------------------------------------------------------

def test_backends_agree_within_a_micrometre_on_float32_mesh():
    m = make_object("sphere", subdivisions=3)
    m32 = type(m)(m.vertices.astype(np.float32), m.faces, process=False)
    rng = np.random.default_rng(0)
    pts = rng.uniform(-0.04, 0.04, (600, 3)) + [0, 0, 0.03]
    e_o3d = lower_envelope(pts, [0.1, 0.2, 1.0], m32, "open3d")
    e_np = lower_envelope(pts, [0.1, 0.2, 1.0], m32, "numpy")
    assert np.array_equal(np.isfinite(e_o3d), np.isfinite(e_np)) and np.isfinite(e_np).sum() > 100
    fin = np.isfinite(e_np)
    assert np.abs(e_o3d[fin] - e_np[fin]).max() < 1e-6
    s_o3d, s_np = signed_distance(pts, m32, "open3d"), signed_distance(pts, m32, "numpy")
    assert np.abs(s_o3d - s_np).max() < 1e-6
    inside = np.linalg.norm(pts - [0, 0, 0.03], axis=1) < 0.029
    assert np.all(s_np[inside] > 0) and np.all(s_np[~inside & (np.linalg.norm(pts - [0, 0, 0.03], axis=1) > 0.031)] < 0)


def test_press_gives_the_same_gap_with_either_backend():
    m = make_object("halfcylinder")
    pose = placement_pose(m, xy=(0.003, -0.002), yaw=0.3, top=3e-3, gap=0.5e-3)
    a = press(FLAT, m, pose, SoftLayer(), indentation=0.5e-3, backend="open3d")
    b = press(FLAT, m, pose, SoftLayer(), indentation=0.5e-3, backend="numpy")
    fa, fb = np.isfinite(a.field.gap), np.isfinite(b.field.gap)
    assert np.array_equal(fa, fb) and fa.sum() > 100
    assert np.abs(a.field.gap[fa] - b.field.gap[fa]).max() < 1e-6
    assert np.allclose(a.pressure, b.pressure, rtol=1e-4, atol=1e-3)


def test_inverted_normals_are_turned_right_way_out():
    m = make_object("cube")
    inv = m.copy()
    inv.invert()
    assert inv.volume < 0
    fixed = prepare_mesh(inv)
    assert fixed.volume > 0
    p = np.array([[0, 0, 0.015], [0, 0, 0.05]])
    for b in ("open3d", "numpy"):
        assert np.allclose(signed_distance(p, fixed, b), [0.015, -0.02], atol=1e-7)
    r1, r2 = _press("cube", 3e-3), press(FLAT, inv, placement_pose(m, top=3e-3, gap=1e-3),
                                        SoftLayer(thickness=3e-3, extent=0.04), force=10.0)
    assert np.allclose(r1.pressure, r2.pressure, rtol=1e-6, atol=1e-6)


def test_open_mesh_is_an_error_unless_the_scene_says_otherwise():
    m = make_object("cube")
    openm = type(m)(m.vertices, m.faces[:-2], process=False)
    with pytest.raises(FormatError, match="open"):
        prepare_mesh(openm)
    assert prepare_mesh(openm, open_mesh="fill").is_watertight
    env = prepare_mesh(openm, open_mesh="envelope")
    pose = placement_pose(m, top=3e-3, gap=1e-3)
    r = press(FLAT, env, pose, SoftLayer(), force=5.0, open_mesh="envelope")
    assert r.force == pytest.approx(5.0, rel=1e-6)
    with pytest.raises(FormatError):
        press(FLAT, openm, pose, SoftLayer(), force=5.0)


# --- elastic models ------------------------------------------------------------------------

@pytest.mark.parametrize("base", ["bonded", "frictionless"])
@pytest.mark.parametrize("nu", [0.3, 0.49])
def test_layer_formula_matches_airy_solution_and_limits(base, nu):
    t = np.array([1e-3, 0.05, 0.3, 1.0, 3.0, 8.0])
    c_num, tr = layer_transfer(t, nu, base)
    assert np.allclose(layer_factor(t, nu, base), c_num, rtol=1e-8, atol=1e-12)
    assert layer_factor(25.0, nu, base) == 1.0 and tr[0] == pytest.approx(1.0, abs=1e-4)
    thin = layer_factor(1e-3, nu, base)
    if base == "bonded":  # thin bonded layer: confined modulus, w = p h / M
        expect = 1e-3 * (1 - 2 * nu) / (2 * (1 - nu) ** 2)
    else:  # thin sliding layer: Winkler, w = p h / E*
        expect = 1e-3 / 2
    assert thin == pytest.approx(expect, rel=1e-2)


def test_halfspace_bem_matches_hertz():
    lay = SoftLayer()
    R, F, dx, n = 0.03, 1.0, 0.25e-3, 96
    x = (np.arange(n) - n / 2 + 0.5) * dx
    X, Y = np.meshgrid(x, x, indexing="ij")
    gap = R - np.sqrt(R**2 - X**2 - Y**2)
    sol = solve_pk(gap, compliance_operator((n, n), dx, dx, lay, "halfspace"), dx * dx, force=F)
    a = (3 * F * R / (4 * lay.e_star)) ** (1 / 3)
    assert sol.converged and sol.pressure.min() >= 0
    assert sol.pressure.sum() * dx * dx == pytest.approx(F, rel=1e-9)
    assert sol.pressure.max() == pytest.approx(3 * F / (2 * np.pi * a * a), rel=0.02)
    assert sol.approach == pytest.approx(a * a / R, rel=0.01)
    # no interpenetration: the deformed gap is >= 0 everywhere, 0 in contact
    g = gap + sol.displacement - sol.approach
    assert g.min() > -1e-9 * R and np.abs(g[sol.pressure > 0]).max() < 1e-6 * a


def test_flat_punch_edges_concentrate_only_with_nonlocal_models():
    """A rigid flat punch: elasticity puts the pressure peaks at its edges; Winkler cannot."""
    ratios = {}
    for model in ("local", "halfspace", "finite_layer"):
        r = _press("cube", 0.01, model=model, spread=False, grid=ContactGrid(spacing=1e-3))
        p = r.field.pressure
        i0, j0 = np.unravel_index(np.argmax(p), p.shape)
        row = p[:, p.shape[1] // 2]
        ratios[model] = row.max() / row[len(row) // 2]
    assert ratios["local"] == pytest.approx(1.0, abs=1e-6)
    assert ratios["halfspace"] > 1.5 and ratios["finite_layer"] > 1.1


# --- press: the "Done when" ---------------------------------------------------------

@pytest.mark.parametrize("base", ["bonded", "frictionless"])
@pytest.mark.parametrize("spreading", ["layer", "boussinesq"])
def test_sphere_through_10mm_is_wider_and_lower_than_through_3mm(base, spreading):
    from vtcore.scene.tasks.press import halfmax_diameter

    thin = _press("sphere", 0.003, base=base, spreading=spreading)
    thick = _press("sphere", 0.010, base=base, spreading=spreading)
    for r in (thin, thick):
        assert r.force == pytest.approx(10.0, rel=0.01)
    assert halfmax_diameter(thick.field) > halfmax_diameter(thin.field)
    assert thick.pressure.max() < thin.pressure.max()


@pytest.mark.parametrize("base", ["bonded", "frictionless"])
def test_cube_edge_is_sharper_through_3mm_than_10mm(base):
    edges = skin_mesh(FLAT).edges

    def step(r):
        v = r.pressure
        return np.abs(v[edges[:, 0]] - v[edges[:, 1]]).max()

    assert step(_press("cube", 0.003, base=base)) > step(_press("cube", 0.010, base=base))


def test_oblique_press_direction():
    m = make_object("sphere")
    d = np.array([np.sin(0.3), 0.0, -np.cos(0.3)])
    pose = placement_pose(m, top=3e-3, gap=2e-3)
    r = press(FLAT, m, pose, SoftLayer(), force=5.0, direction=d)
    assert r.force == pytest.approx(5.0, rel=1e-6) and np.allclose(r.direction, d)
    assert np.allclose(r.pose[:3, 3] - pose[:3, 3], r.travel * d)


# --- hard cases ------------------------------------------------------------------------------

def test_touching_gives_zero_force_and_no_nan():
    m = make_object("sphere")
    r = press(FLAT, m, placement_pose(m, top=3e-3, gap=0.0), SoftLayer(), indentation=0.0)
    assert r.force == 0 and np.all(r.pressure == 0) and np.all(np.isfinite(r.pressure))


def test_object_pushed_through_the_whole_layer():
    m = make_object("sphere")
    pose = placement_pose(m, top=3e-3, gap=1e-3)
    r = press(FLAT, m, pose, SoftLayer(), indentation=4e-3, model="local")
    assert r.bottomed_out and np.all(np.isfinite(r.pressure)) and r.max_compression > 3e-3
    with pytest.raises(UnreachableTargetError, match="bottoms out"):
        press(FLAT, m, pose, SoftLayer(), force=500.0)


def test_object_larger_than_the_patch():
    r = _press("ruler", 0.003, force=15.0)
    assert r.force == pytest.approx(15.0, rel=1e-6) and np.all(np.isfinite(r.pressure))
    big = make_object("box", extents=(0.2, 0.2, 0.02))
    r = press(FLAT, big, placement_pose(big, top=3e-3), SoftLayer(), force=15.0)
    assert r.force == pytest.approx(15.0, rel=1e-6) and (r.pressure > 0).all()


@pytest.mark.parametrize("h", [1e-4, 0.05])
def test_extreme_layer_thicknesses(h):
    r = _press("sphere", h, force=2.0, grid=ContactGrid(spacing=1e-3))
    assert r.force == pytest.approx(2.0, rel=1e-6)
    assert np.all(np.isfinite(r.pressure)) and r.pressure.max() > 0


def test_strongly_curved_patch():
    lay = _layout(radius=0.02)  # the 30 mm patch wraps 86 degrees round
    m = make_object("sphere", radius=0.01)
    pose = placement_pose(m, top=float((lay.positions[:, 2] + 3e-3 * lay.normals[:, 2]).max()), gap=1e-3)
    r = press(lay, m, pose, SoftLayer(), force=2.0)
    assert r.force == pytest.approx(2.0, rel=1e-6) and np.all(np.isfinite(r.pressure))
    centre = np.argmin(np.linalg.norm(lay.flat, axis=1))
    assert r.pressure.argmax() in np.argsort(np.linalg.norm(lay.flat - lay.flat[centre], axis=1))[:7]


def test_float32_mesh_gives_the_same_press():
    m = make_object("halfcylinder")
    m32 = type(m)(m.vertices.astype(np.float32), m.faces, process=False)
    pose = placement_pose(m, top=6e-3, gap=1e-3)
    a = press(FLAT, m, pose, SoftLayer(thickness=6e-3), force=10.0)
    b = press(FLAT, m32, pose, SoftLayer(thickness=6e-3), force=10.0)
    assert np.allclose(a.pressure, b.pressure, rtol=1e-3, atol=1.0)


def test_far_object_reads_zero_and_unreachable_force_is_clear():
    m = make_object("cube")
    far = placement_pose(m, xy=(1.0, 1.0), top=3e-3, gap=0.5)
    r = press(FLAT, m, far, SoftLayer())  # pose as is
    assert r.force == 0 and np.all(r.pressure == 0) and np.all(np.isfinite(r.surface_pressure))
    with pytest.raises(UnreachableTargetError, match="never meets"):
        press(FLAT, m, far, SoftLayer(), force=10.0)


def test_trajectory_warm_start_matches_cold_start():
    m = make_object("sphere")
    base = placement_pose(m, top=3e-3, gap=0.0)
    poses = np.repeat(base[None], 3, axis=0)
    poses[:, 2, 3] -= np.array([0.2e-3, 0.4e-3, 0.6e-3])
    from vtcore.contact import press_sequence

    seq = press_sequence(FLAT, m, poses, SoftLayer())
    cold = press(FLAT, m, poses[2], SoftLayer())
    assert seq[-1].force == pytest.approx(cold.force, rel=1e-4)
    assert seq[0].force < seq[1].force < seq[2].force


# --- probe (force control on the mean response) -----------------------------------------------

def test_probe_reaches_target_and_softer_object_moves_further():
    m = make_object("sphere")
    pose = placement_pose(m, top=3e-3, gap=2e-3)
    stiff = probe(FLAT, m, pose, SoftLayer(), target=400.0, counts_per_pa=0.1, compliance=1e5)
    soft = probe(FLAT, m, pose, SoftLayer(), target=400.0, counts_per_pa=0.1, compliance=1e3)
    for pr in (stiff, soft):
        assert pr.mean_response == pytest.approx(400.0, rel=1e-3) and pr.steps <= 60
    assert soft.force == pytest.approx(stiff.force, rel=1e-3)
    assert soft.displacement > stiff.displacement and soft.compliance < stiff.compliance
    with pytest.raises(UnreachableTargetError, match="not reachable"):
        probe(FLAT, m, pose, SoftLayer(), target=4e6, counts_per_pa=0.1)
    with pytest.raises(UnreachableTargetError):  # saturating sensor never reaches the target
        probe(FLAT, m, pose, SoftLayer(), target=4000.0, sensor=lambda p: sensor.gain(p, 0.1, 1000.0))


# --- sensor functions ---------------------------------------------------------------------------

def test_sensor_functions():
    p = np.array([[0.0, 1e3, 1e6]])
    assert np.allclose(sensor.gain(p, 0.1), [[0, 100, 1e5]])
    g = sensor.gain(p, 0.1, p_half=1e3)
    assert g[0, 1] == pytest.approx(50.0) and g[0, 2] < 100.0
    assert sensor.saturate(sensor.gain(p, 0.1)).max() == 65535
    assert np.array_equal(sensor.quantise([[1.4, 2.6]]), [[1.0, 3.0]])
    a = sensor.add_noise(np.zeros((50, 4)), 2.0, np.random.default_rng(3))
    b = sensor.add_noise(np.zeros((50, 4)), 2.0, np.random.default_rng(3))
    assert np.array_equal(a, b) and 1.5 < a.std() < 2.5
    t = np.arange(5) * 0.05
    assert np.allclose(sensor.drift(np.zeros((5, 2)), t, 2.0)[:, 0], 2.0 * t)
    f, clock = sensor.sample_clock(np.arange(10.0)[:, None], np.arange(10) * 0.01, rate=20.0)
    assert np.allclose(clock, [0.0, 0.05]) and np.allclose(f[:, 0], [0, 5])
    with pytest.raises(InputError):
        sensor.sample_clock(np.zeros((3, 2)), [0.0, 0.2, 0.1])


def test_thick_finite_layer_tends_to_the_halfspace_and_thin_to_its_limit():
    """The real-space layer kernel (Love + tabulated correction) against its two limits."""
    m = make_object("sphere")
    pose = placement_pose(m, top=0.0, gap=1e-3)
    thick = SoftLayer(thickness=0.3)
    hs = press(FLAT, m, placement_pose(m, top=0.3, gap=1e-3), thick, force=1.0, model="halfspace", spread=False)
    fl = press(FLAT, m, placement_pose(m, top=0.3, gap=1e-3), thick, force=1.0, model="finite_layer", spread=False)
    assert fl.indentation == pytest.approx(hs.indentation, rel=0.03)
    assert fl.field.pressure.max() == pytest.approx(hs.field.pressure.max(), rel=0.03)
    # a thin sliding pad is a Winkler layer of stiffness E*/h: same pressure as the local model
    thin = SoftLayer(thickness=2e-4, base="frictionless")
    pose = placement_pose(m, top=2e-4, gap=1e-4)
    a = press(FLAT, m, pose, thin, force=0.2, model="finite_layer", spread=False, grid=ContactGrid(spacing=1e-3))
    b = press(FLAT, m, pose, thin, force=0.2, model="local", spread=False, grid=ContactGrid(spacing=1e-3))
    assert a.indentation == pytest.approx(b.indentation, rel=0.01)


def test_circular_flat_punch_matches_boussinesq():
    """Rigid flat circular punch on a half-space: d = F / (2 a E*), p(0) = F / (2 pi a^2),
    and the pressure rises towards the rim as 1 / sqrt(a^2 - r^2) (Johnson 1985, eq. 3.36)."""
    a, F = 0.01, 1.0
    m = make_object("cylinder", radius=a, height=0.02, sections=256)
    lay = SoftLayer(thickness=0.2)
    r = press(FLAT, m, placement_pose(m, top=0.2, gap=1e-3), lay, force=F, model="halfspace", spread=False,
              grid=ContactGrid(spacing=0.5e-3))
    assert r.indentation == pytest.approx(F / (2 * a * lay.e_star), rel=0.03)
    fld = r.field
    X, Y = np.meshgrid(fld.x, fld.y, indexing="ij")
    rr = np.hypot(X, Y)
    centre = fld.pressure[rr < 0.2 * a].mean()
    assert centre == pytest.approx(F / (2 * np.pi * a * a) / np.sqrt(1 - 0.01), rel=0.05)
    ring = fld.pressure[(rr > 0.8 * a) & (rr < 0.9 * a)].mean()
    expect = np.mean(F / (2 * np.pi * a * np.sqrt(a * a - rr[(rr > 0.8 * a) & (rr < 0.9 * a)] ** 2)))
    assert ring == pytest.approx(expect, rel=0.08) and ring > 1.5 * centre


# --- precomputed taxel sampling (performance, issue 4) -----------------------------------------

def test_sparse_taxel_sampler_equals_bilinear_sampling_and_is_reused():
    """taxel_means reads the grid through a cached sparse matrix; it must equal the per-frame
    bilinear interpolation (map_coordinates, zero outside the grid) it replaced, including discs
    that hang over the grid's border and taxels facing away, and be built once per layout."""
    from scipy.ndimage import map_coordinates

    from vtcore.contact.grid import ContactField, _SAMPLER_CACHE, disc_offsets, taxel_means, taxel_sampler

    lay = _layout(radius=0.02)  # curved: some taxels face away from the grid normal
    rng = np.random.default_rng(4)
    x = np.arange(-12, 12) * 1.1e-3 + 0.3e-3   # the grid ends inside the patch: discs cross its border
    y = np.arange(-15, 15) * 1.1e-3
    fld = ContactField(x, y, np.array([0.0, 0.0, 0.001]), np.array([1.0, 0, 0]), np.array([0, 1.0, 0]),
                       np.array([0, 0, 1.0]), np.zeros((24, 30)), np.zeros((24, 30)), np.zeros((24, 30)),
                       thickness=2e-3)
    vals = rng.random((24, 30))
    for samples in (1, 7):
        pos = lay.positions + 2e-3 * lay.normals - fld.origin
        pts = pos[:, None, :2] + disc_offsets(samples)[None]
        ref = map_coordinates(vals, [((pts[..., 0] - x[0]) / 1.1e-3).ravel(), ((pts[..., 1] - y[0]) / 1.1e-3).ravel()],
                              order=1, mode="constant", cval=0.0).reshape(pts.shape[:2]).mean(axis=1)
        ref = np.where(lay.normals[:, 2] > 0.1, ref, 0.0)
        assert (lay.normals[:, 2] <= 0.1).any() and (ref == 0).any() and (ref > 0).any()
        np.testing.assert_allclose(taxel_means(lay, fld, vals, samples), ref, rtol=0, atol=1e-13)
    a = taxel_sampler(lay, fld, 7)
    assert taxel_sampler(lay, fld, 7) is a and a.shape == (len(lay), vals.size)
    assert any(v is a for v in _SAMPLER_CACHE.values())
