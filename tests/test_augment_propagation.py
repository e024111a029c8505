"""Cluster, smooth and GP propagation of tactile colours (seed 000, Eqs. 2-4), with their hard cases."""

import numpy as np
import pytest

from vtcore.augment import (AugmentedPointCloud, ClusterPropagation, GPPropagation, SmoothPropagation,
                            softmax_weights)
from vtcore.errors import InputError


@pytest.fixture
def cloud():
    rng = np.random.default_rng(0)
    pts = rng.uniform(-0.05, 0.05, size=(2000, 3))
    idx = rng.choice(len(pts), 12, replace=False)
    vals = rng.uniform(1e5, 1e7, size=12)
    return pts, pts[idx], vals


def brute_smooth(x, c, v, beta):
    d = np.linalg.norm(x[:, None, :] - c[None, :, :], axis=-1)
    w = np.exp(beta * d)                       # fine for these moderate beta*d
    return (w @ v) / w.sum(axis=1)


def test_cluster_is_nearest_contact(cloud):
    x, c, v = cloud
    d = np.linalg.norm(x[:, None] - c[None], axis=-1)
    np.testing.assert_array_equal(ClusterPropagation().fit(c, v).predict(x), v[d.argmin(axis=1)])


def test_cluster_kdtree_path_matches_brute_force():
    rng = np.random.default_rng(1)
    c = rng.normal(size=(200, 3))             # > 64 contacts: the KD-tree path
    v = rng.normal(size=200)
    x = rng.normal(size=(500, 3))
    d = np.linalg.norm(x[:, None] - c[None], axis=-1)
    np.testing.assert_array_equal(ClusterPropagation().fit(c, v).predict(x), v[d.argmin(axis=1)])


def test_smooth_matches_equations_3_4(cloud):
    x, c, v = cloud
    got = SmoothPropagation(beta=-30.0).fit(c, v).predict(x)
    # the Gram expansion costs ~1e-8 m of distance at coincident points: rtol 1e-8
    np.testing.assert_allclose(got, brute_smooth(x, c, v, -30.0), rtol=1e-8)


def test_smooth_float32_kernel_close_to_float64(cloud):
    x, c, v = cloud
    a = SmoothPropagation().fit(c, v).predict(x)
    b = SmoothPropagation(dtype=np.float32).fit(c, v).predict(x)
    np.testing.assert_allclose(b, a, rtol=1e-4)


def test_single_touch_covers_the_cloud(cloud):
    x, c, v = cloud
    for est in (ClusterPropagation(), SmoothPropagation(), SmoothPropagation(beta=-3000.0), GPPropagation()):
        np.testing.assert_array_equal(est.fit(c[:1], v[:1]).predict(x), np.full(len(x), v[0]))


def test_all_contacts_at_one_point(cloud):
    x, _, v = cloud
    c = np.zeros((12, 3))
    for est in (ClusterPropagation(), SmoothPropagation(), SmoothPropagation(beta=-1e6)):
        got = est.fit(c, v).predict(x)
        assert np.all(np.isfinite(got))
        np.testing.assert_allclose(got, v.mean(), rtol=1e-12)


def test_beta_zero_is_the_plain_mean(cloud):
    x, c, v = cloud
    np.testing.assert_allclose(SmoothPropagation(beta=0.0).fit(c, v).predict(x), v.mean(), rtol=1e-12)
    np.testing.assert_allclose(SmoothPropagation(beta=-1e-9).fit(c, v).predict(x), v.mean(), rtol=1e-8)


def test_beta_minus_infinity_is_cluster_based(cloud):
    x, c, v = cloud
    cl = ClusterPropagation().fit(c, v).predict(x)
    np.testing.assert_array_equal(SmoothPropagation(beta=-np.inf).fit(c, v).predict(x), cl)
    # and the limit is approached continuously: a very steep beta already equals it
    np.testing.assert_allclose(SmoothPropagation(beta=-1e7).fit(c, v).predict(x), cl, rtol=1e-6)


def test_steep_beta_over_a_metre_stays_finite():
    rng = np.random.default_rng(2)
    x = rng.uniform(0, 1.0, size=(5000, 3))          # a 1 m object
    c = rng.uniform(0, 1.0, size=(24, 3))
    v = rng.uniform(0, 1, size=24)
    got = SmoothPropagation(beta=-3000.0).fit(c, v).predict(x)
    assert np.all(np.isfinite(got))
    assert got.min() >= v.min() - 1e-12 and got.max() <= v.max() + 1e-12   # a convex combination


def test_float32_input_and_positive_beta_rejected(cloud):
    x, c, v = cloud
    a = SmoothPropagation().fit(c, v).predict(x)
    b = SmoothPropagation().fit(c.astype(np.float32), v.astype(np.float32)).predict(x.astype(np.float32))
    assert b.dtype == np.float64 and np.all(np.isfinite(b))
    np.testing.assert_allclose(b, a, rtol=1e-4)
    with pytest.raises(InputError, match="beta"):
        SmoothPropagation(beta=300.0).fit(c, v)


def test_cloud_in_millimetres(cloud):
    x, c, v = cloud
    metres = SmoothPropagation().fit(c, v).predict(x)
    mm = SmoothPropagation(scale=1e-3).fit(c * 1e3, v).predict(x * 1e3)
    np.testing.assert_allclose(mm, metres, rtol=1e-7)
    np.testing.assert_array_equal(ClusterPropagation().fit(c * 1e3, v).predict(x * 1e3),
                                  ClusterPropagation().fit(c, v).predict(x))
    # forgetting the scale makes beta 1000x steeper: still finite, close to cluster-based
    assert np.all(np.isfinite(SmoothPropagation().fit(c * 1e3, v).predict(x * 1e3)))


def test_far_from_origin_keeps_precision(cloud):
    x, c, v = cloud
    off = np.array([1e3, -2e3, 5e2])                  # a cloud in millimetres in a robot's base frame
    a = SmoothPropagation(scale=1e-3).fit((c + off) * 1e3, v).predict((x + off) * 1e3)
    np.testing.assert_allclose(a, SmoothPropagation().fit(c, v).predict(x), rtol=1e-6)


def test_empty_visual_cloud(cloud):
    _, c, v = cloud
    for est in (ClusterPropagation(), SmoothPropagation(), SmoothPropagation(k_nearest=3), GPPropagation()):
        assert est.fit(c, v).predict(np.empty((0, 3))).shape == (0,)
    assert SmoothPropagation().fit(c, np.c_[v, v]).predict(np.empty((0, 3))).shape == (0, 2)
    aug = AugmentedPointCloud(np.empty((0, 3)), "smooth").add_touch(c[0], v[0])
    assert aug.values.shape == (0,)


def test_vector_valued_channels(cloud):
    x, c, v = cloud
    vv = np.c_[v, v * 1e-6, -v]
    for est in (ClusterPropagation(), SmoothPropagation(), SmoothPropagation(k_nearest=4)):
        got = est.fit(c, vv).predict(x)
        assert got.shape == (len(x), 3)
        np.testing.assert_allclose(got[:, 0], est.fit(c, v).predict(x), rtol=1e-12)
        np.testing.assert_allclose(got[:, 2], -got[:, 0], rtol=1e-12)


def test_truncation_converges_to_dense(cloud):
    x, c, v = cloud
    dense = SmoothPropagation().fit(c, v).predict(x)
    errs = [np.abs(SmoothPropagation(k_nearest=k).fit(c, v).predict(x) - dense).max() for k in (1, 3, 6, 12)]
    assert errs[-1] < 1e-6 * v.max()
    assert errs[0] > errs[2] > errs[-1]
    np.testing.assert_array_equal(SmoothPropagation(k_nearest=1).fit(c, v).predict(x),
                                  ClusterPropagation().fit(c, v).predict(x))


def test_partial_fit_equals_fit(cloud):
    x, c, v = cloud
    for est_cls in (ClusterPropagation, SmoothPropagation):
        inc = est_cls().fit(c[:5], v[:5]).partial_fit(c[5:], v[5:])
        np.testing.assert_allclose(inc.predict(x), est_cls().fit(c, v).predict(x), rtol=1e-12)


@pytest.mark.parametrize("method,beta", [("cluster", -300.0), ("smooth", -300.0), ("smooth", -3000.0),
                                         ("smooth", 0.0), ("smooth", -np.inf)])
def test_incremental_cloud_equals_batch(cloud, method, beta):
    x, c, v = cloud
    c = np.r_[c, c[:1]]                               # a repeated probe of the first point
    v = np.r_[v, v[:1] * 0.5]
    aug = AugmentedPointCloud(x, method, beta=beta)
    assert np.all(np.isnan(aug.values))               # no touch: no colour
    for i in range(len(c)):
        aug.add_touch(c[i], v[i])
        batch = (ClusterPropagation() if method == "cluster" else SmoothPropagation(beta=beta)).fit(
            c[:i + 1], v[:i + 1]).predict(x)
        # the batch kernel's Gram expansion costs ~1e-8 m at coincident points: rtol 1e-7
        np.testing.assert_allclose(aug.values, batch, rtol=1e-7)


def test_softmax_weights_rows_sum_to_one():
    d = np.array([[0.0, 1.0, 2.0], [5.0, 5.0, 5.0], [1e3, 0.0, 1e-9]])
    for beta in (0.0, -1.0, -1e4, -np.inf):
        w = softmax_weights(d, beta)
        assert np.all(np.isfinite(w))
        np.testing.assert_allclose(w.sum(axis=1), 1.0)


def test_gp_baseline_and_neighbourhood_augmentation(cloud):
    x, c, v = cloud
    field = lambda p: 1e6 * (3.0 + 20.0 * p[:, 0] - 10.0 * p[:, 2])     # a smooth field
    gp = GPPropagation(random_state=0).fit(c, field(c))
    y = gp.predict(x)
    assert y.shape == (len(x),) and np.all(np.isfinite(y))
    assert np.abs(y - field(x)).mean() < 0.05 * field(x).mean()      # it recovers a smooth field
    big = GPPropagation(radius=0.02, voxel=0.01, max_train=300).fit(c, v, visual_points=x)
    assert len(big.train_points_) > len(c)


def test_bad_input_errors(cloud):
    x, c, v = cloud
    with pytest.raises(InputError, match="contact_points"):
        ClusterPropagation().fit(np.empty((0, 3)), [])
    with pytest.raises(InputError, match="values"):
        SmoothPropagation().fit(c, v[:3])
    with pytest.raises(InputError, match="not fitted"):
        SmoothPropagation().predict(x)
    with pytest.raises(InputError, match="points"):
        ClusterPropagation().fit(c, v).predict(np.ones((3, 2)))
    with pytest.raises(InputError, match="not finite"):
        SmoothPropagation().fit(c, v).predict(np.full((2, 3), np.nan))


def test_incremental_cloud_writes_ply(cloud, tmp_path):
    from vtcore.augment import read_ply_vertices

    x, c, v = cloud
    aug = AugmentedPointCloud(x, "smooth", channels=2, normals=x / np.linalg.norm(x, axis=1, keepdims=True))
    aug.add_touches(c, np.c_[v, 0.5 * np.ones_like(v)])
    back = read_ply_vertices(aug.write_ply(tmp_path / "a.ply", 0.0, 1e7, channel_names=["c", "friction"]))
    np.testing.assert_allclose(back["tactile_color"], aug.values[:, 0], rtol=1e-6)
    np.testing.assert_allclose(back["friction"], 0.5, rtol=1e-6)
    with pytest.raises(InputError, match="dtype"):
        SmoothPropagation(dtype=np.int32).fit(c, v)
    np.testing.assert_allclose(SmoothPropagation(dtype="float32").fit(c, v).predict(x),
                               SmoothPropagation().fit(c, v).predict(x), rtol=1e-4)
