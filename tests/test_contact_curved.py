"""Strongly curved patches (issue 4): the plane solve's error, the unrolled solve, the mug rim that
bottoms out the layer."""

import numpy as np
import pytest

from vtcore.contact import ContactGrid, SoftLayer, make_object, press
from vtcore.errors import InputError, UnreachableTargetError
from vtcore.layout import Layout, hexagon_flat, seed002_curved
from vtcore.layout.endeffectors import _profile_point

_, CURVED = seed002_curved()
REF = CURVED.meta["reference_taxel"]  # mid-arc, normal 45 degrees from z


def _pose_on(mesh, tax, h, gap, direction):
    """The object's pressed face towards the skin along -normal at taxel ``tax``, backed off along
    ``-direction`` so that it is ``gap`` clear of the layer."""
    nr = CURVED.normals[tax]
    a = np.arctan2(nr[0], nr[2])
    c, s = np.cos(a), np.sin(a)
    r = np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]]) @ np.diag([1.0, -1.0, -1.0])
    v = np.asarray(mesh.vertices) @ r.T
    pose = np.eye(4)
    pose[:3, :3] = r
    pose[:3, 3] = CURVED.positions[tax] + h * nr - nr * (v @ nr).min()
    pose[:3, 3] -= direction * gap / max(-direction @ nr, 0.2)
    return pose


def _reference(mesh, pose, layer, force, u, du=0.5e-3):
    """Local (Winkler) layer along the TRUE normals on the exactly unrolled seed-002 surface: every
    point of a fine flat grid is compressed along its own normal by the object's penetration along
    that normal (open3d rays per point), pushes back along it; the travel is bisected to the force."""
    import open3d as o3d

    h, k = layer.thickness, layer.e_star / layer.thickness
    rad, fl = CURVED.meta["radius_m"], CURVED.meta["flat_length_m"]
    lo, hi = CURVED.flat.min(0) - 6e-3, CURVED.flat.max(0) + 6e-3
    gu, gv = np.arange(lo[0], hi[0], du), np.arange(lo[1], hi[1], du)
    U, V = np.meshgrid(gu, gv, indexing="ij")
    pz, nz = _profile_point(U.ravel(), fl, rad)
    nrm = np.column_stack([nz[:, 0], 0 * U.ravel(), nz[:, 1]])
    pts = np.column_stack([pz[:, 0], V.ravel(), pz[:, 1]]) + h * nrm
    area = du * du * (1 + h * (U.ravel() > 0) / rad)  # the outer surface of the arc is longer
    cos = nrm @ (-u)
    verts = np.asarray(mesh.vertices) @ pose[:3, :3].T + pose[:3, 3]
    o = verts.mean(0)
    sc = o3d.t.geometry.RaycastingScene()
    sc.add_triangles(o3d.core.Tensor((verts - o).astype(np.float32)),
                     o3d.core.Tensor(np.asarray(mesh.faces, np.uint32)))

    def state(d):
        rays = np.hstack([pts - o - d * u - 0.2 * nrm, nrm]).astype(np.float32)
        t = sc.cast_rays(o3d.core.Tensor(rays))["t_hit"].numpy().astype(float) - 0.2
        p = k * np.clip(-t, 0, None)
        p[~np.isfinite(p)] = 0
        return p, float((p * cos * area).sum())

    a, b = 0.0, 0.02
    for _ in range(40):
        m = 0.5 * (a + b)
        a, b = (m, b) if state(m)[1] < force else (a, m)
    p, _ = state(0.5 * (a + b))
    return p.reshape(U.shape), 0.5 * (a + b)


@pytest.mark.parametrize("kind,direction", [("cube", "z"), ("sphere", "z")])
def test_unrolled_solve_follows_the_true_normals_where_the_plane_solve_does_not(kind, direction):
    """Pressing straight down (-z) on the 45-degree middle of seed 002's arc: the plane solve
    over-compresses the tilted layer (peak +12-20 %, travel -10 %); the unrolled solve keeps the
    travel within 1 % and the peak within 5 % of a local model along the true normals."""
    mesh = make_object(kind, side=0.03) if kind == "cube" else make_object(kind, radius=0.03)
    u = np.array([0.0, 0.0, -1.0])
    layer = SoftLayer(thickness=3e-3)
    pose = _pose_on(mesh, REF, 3e-3, 1e-3, u)
    ref_p, ref_d = _reference(mesh, pose, layer, 5.0, u)
    kw = dict(force=5.0, direction=u, model="local", spread=False, grid=ContactGrid(spacing=0.5e-3))
    plane = press(CURVED, mesh, pose, layer, **kw)
    unrolled = press(CURVED, mesh, pose, layer, geometry="unrolled", **kw)
    assert unrolled.force == pytest.approx(5.0, rel=1e-9) and plane.force == pytest.approx(5.0, rel=1e-9)
    assert unrolled.travel == pytest.approx(ref_d, rel=0.01)
    assert abs(plane.travel / ref_d - 1) > 0.05
    peak = ref_p.max()
    assert unrolled.field.pressure.max() == pytest.approx(peak, rel=0.05)
    assert plane.field.pressure.max() > 1.10 * peak
    assert unrolled.field.domain == "flat" and np.all(np.isfinite(unrolled.pressure))


def test_unrolled_equals_plane_on_a_flat_patch():
    flat, mod = hexagon_flat()
    lay = Layout(np.column_stack([flat, np.zeros(len(flat))]), np.tile([0, 0, 1.0], (len(flat), 1)),
                 np.arange(len(flat)), mod, flat=flat)
    m = make_object("sphere", radius=0.03)
    from vtcore.contact import placement_pose

    pose = placement_pose(m, xy=(0.002, -0.001), top=3e-3, gap=1e-3)
    layer = SoftLayer(thickness=3e-3, extent=0.04)
    for model in ("local", "finite_layer"):
        a = press(lay, m, pose, layer, force=4.0, model=model)
        b = press(lay, m, pose, layer, force=4.0, model=model, geometry="unrolled")
        assert b.force == pytest.approx(4.0, rel=1e-6) and b.converged
        assert b.travel == pytest.approx(a.travel, rel=2e-3)
        np.testing.assert_allclose(b.pressure, a.pressure, rtol=0, atol=0.01 * a.pressure.max())
        np.testing.assert_allclose(b.contact_point, a.contact_point, atol=0.2e-3)


def test_unrolled_finite_layer_on_the_curved_patch_and_bad_input():
    m = make_object("cube", side=0.03)
    u = -CURVED.normals.mean(0)
    u /= np.linalg.norm(u)
    layer = SoftLayer(thickness=3e-3)
    pose = _pose_on(m, REF, 3e-3, 1e-3, u)
    r = press(CURVED, m, pose, layer, force=5.0, direction=u, geometry="unrolled", grid=ContactGrid(spacing=1e-3))
    assert r.force == pytest.approx(5.0, rel=1e-6) and r.converged and not r.bottomed_out
    assert np.all(np.isfinite(r.pressure)) and r.pressure.max() > 0
    # the pressure sits where the cube is: around the reference taxel, on the arc
    assert np.linalg.norm(CURVED.flat[r.pressure.argmax()] - CURVED.flat[REF]) < 0.02
    # the same query on either proximity back-end (Blender has no open3d)
    r_np = press(CURVED, m, pose, layer, force=5.0, direction=u, geometry="unrolled", grid=ContactGrid(spacing=1e-3),
                 backend="numpy")
    assert r_np.travel == pytest.approx(r.travel, abs=1e-8)
    np.testing.assert_allclose(r_np.pressure, r.pressure, rtol=0, atol=1e-3 * r.pressure.max())
    seq = [press(CURVED, m, pose, layer, indentation=dd, direction=u, geometry="unrolled",
                 grid=ContactGrid(spacing=1e-3)).force for dd in (0.2e-3, 0.5e-3, 1e-3)]
    assert 0 < seq[0] < seq[1] < seq[2]
    with pytest.raises(InputError, match="geometry"):
        press(CURVED, m, pose, layer, force=1.0, geometry="sphere")
    no_flat = Layout(CURVED.positions, CURVED.normals, CURVED.taxel_ids, CURVED.module_ids)
    with pytest.raises(InputError, match="flat"):
        press(no_flat, m, pose, layer, force=1.0, geometry="unrolled")


def test_mug_rim_across_the_curvature_bottoms_out_a_thin_soft_layer():
    """Seed 002's mug rim (4 mm wall) lying across the arc touches ~140 mm^2: 15 N needs ~100 kPa
    mean pressure, about twice Ecoflex 00-20's E, so 3 mm of it is compressed through (physical for
    a linear layer, not an artefact); seed 002's 6 mm Ecoflex 00-50 cover carries it."""
    mug = make_object("mug")
    nr = CURVED.normals[REF]
    pose = _pose_on(mug, REF, 3e-3, 1e-3, -nr)
    pose[1, 3] += 0.038  # the rim's wall crosses the reference taxel running along the curved direction
    kw = dict(direction=-nr, grid=ContactGrid(spacing=1e-3), geometry="unrolled")
    thin = SoftLayer(thickness=3e-3)
    with pytest.raises(UnreachableTargetError, match="thicker or stiffer"):
        press(CURVED, mug, pose, thin, force=15.0, **kw)
    full = press(CURVED, mug, pose, thin, indentation=3e-3 * 0.999, **kw)
    assert 5.0 < full.force < 15.0 and full.contact_area < 200e-6
    pose6 = _pose_on(mug, REF, 6e-3, 1e-3, -nr)
    pose6[1, 3] += 0.038
    r = press(CURVED, mug, pose6, SoftLayer(thickness=6e-3, material="ecoflex_00_50"), force=15.0, **kw)
    assert r.force == pytest.approx(15.0, rel=1e-6) and r.max_compression < 6e-3
