"""Seed 000's classification data sets (Sect. 4.1), active touch selection and the classify scene's
checks that need no torch: these run in both lanes (the py313 lane has no torch)."""

from __future__ import annotations

import math
import subprocess
import sys

import numpy as np
import pytest

from vtcore.errors import InputError
from vtcore.learn import datasets as D
from vtcore.learn.active import farthest_first, map_error, select_touches


def scan(name, n_points=8000, n_touch=17, seed=0, values=None):
    rng = np.random.default_rng(seed)
    pts = rng.normal(size=(n_points, 3))
    pts /= np.linalg.norm(pts, axis=1, keepdims=True) * 30.0           # a 33 mm sphere, metres
    touch = pts[rng.choice(n_points, n_touch, replace=False)]
    c = np.linspace(1e6, 2e6, n_touch) if values is None else values
    return D.ObjectScan(name, pts, touch, c)


def test_subsamples_are_disjoint_and_seeded():
    s = D.disjoint_subsamples(8000, 3)
    assert s.shape == (15, 512)
    assert len(np.unique(s)) == 15 * 512                               # no point in two subsamples
    assert np.array_equal(s, D.disjoint_subsamples(8000, 3))
    assert not np.array_equal(s, D.disjoint_subsamples(8000, 4))


def test_cloud_with_fewer_than_512_points_is_a_clear_error():
    with pytest.raises(InputError, match="500 points, fewer than the 512"):
        D.disjoint_subsamples(500, 0, name="tennis_ball.points")
    with pytest.raises(InputError, match=r"15 disjoint subsamples of 512 need 7680 \(it gives only 9\)"):
        D.disjoint_subsamples(5000, 0)


def test_g_equal_to_the_probes_gives_one_subset_per_subsample():
    subs, touches, unique = D.draw_pairs(17, 17, 500, 0)
    assert unique == 15 and len(subs) == 15                              # all it could make, said
    assert sorted(subs.tolist()) == list(range(15))
    assert np.all(touches == np.arange(17))
    ds = D.make_dataset([scan("a"), scan("b", seed=1)], 17, per_object=500)
    assert ds.unique_possible == {"a": 15, "b": 15} and len(ds.labels) == 30
    assert D.manifest([ds], [scan("a"), scan("b", seed=1)], scale=1.0)["datasets"][0]["unique_possible"]["a"] == 15


def test_more_touches_than_probes_is_a_clear_error():
    with pytest.raises(InputError, match="sponge_ball has 17 probes, fewer than G = 18"):
        D.make_dataset([scan("sponge_ball"), scan("b")], 18)


@pytest.mark.parametrize("n,g", [(17, 3), (24, 12)])   # listed exactly, and drawn with rejection
def test_pairs_are_unique(n, g):
    subs, touches, unique = D.draw_pairs(n, g, 500, 1)
    assert unique == 15 * math.comb(n, g) and len(subs) == 500
    assert np.all(np.diff(touches, axis=1) > 0)                         # sorted, no repeated probe
    keys = {(int(s),) + tuple(t) for s, t in zip(subs, touches)}
    assert len(keys) == 500


def test_geometry_only_set_is_the_subsamples_split_70_10_20():
    scans = [scan("a"), scan("b", seed=1)]
    ds = D.make_dataset(scans, 0, per_object=500)
    assert ds.touches.shape == (30, 0) and ds.propagation == "none" and ds.name == "g0"
    assert ds.counts() == {"train": 20, "val": 4, "test": 6}
    for o in range(2):
        assert sorted(ds.subsample[ds.labels == o].tolist()) == list(range(15))
    x = D.build_clouds(ds, scans, D.object_subsamples(scans, 0))
    assert x.shape == (30, 512, 3) and x.dtype == np.float32


def test_dataset_is_deterministic_for_a_seed_and_split_per_object():
    scans = [scan("a"), scan("b", seed=1, n_touch=24)]
    a = D.make_dataset(scans, 7, "smooth", per_object=500, seed=5)
    b = D.make_dataset(scans, 7, "smooth", per_object=500, seed=5)
    c = D.make_dataset(scans, 7, "smooth", per_object=500, seed=6)
    for k in ("labels", "subsample", "touches", "split"):
        assert np.array_equal(getattr(a, k), getattr(b, k))
    assert not np.array_equal(a.touches, c.touches)
    for o in range(2):
        split = a.split[a.labels == o]
        assert [int(np.sum(split == s)) for s in (D.TRAIN, D.VAL, D.TEST)] == [350, 50, 100]
    subs = D.object_subsamples(scans, 5)
    rows = np.arange(0, 1000, 97)
    xa = D.build_clouds(a, scans, subs, rows=rows)
    assert np.array_equal(xa, D.build_clouds(b, scans, subs, rows=rows))


def test_cloud_inputs_are_normalised_and_coloured_from_the_chosen_touches():
    scans = [scan("a"), scan("b", seed=1)]
    ds = D.make_dataset(scans, 3, "cluster", per_object=20, seed=2)
    subs = D.object_subsamples(scans, 2)
    scale = D.c_scale(scans)
    assert scale == pytest.approx(np.quantile(np.tile(np.linspace(1e6, 2e6, 17), 2), 0.95))
    x = D.build_clouds(ds, scans, subs)
    assert x.shape == (40, 512, 4)
    assert np.allclose(x[:, :, :3].mean(axis=1), 0, atol=1e-6)
    assert np.allclose(np.linalg.norm(x[:, :, :3], axis=2).max(axis=1), 1.0, atol=1e-6)
    for r in (0, 25):
        o = ds.labels[r]
        allowed = np.minimum(scans[o].touch_values[ds.touches[r]] / scale, 1.0)   # one touch's colour, on the scale
        assert np.all(np.isin(np.round(x[r, :, 3], 6), np.round(allowed.astype(np.float32), 6)))


def test_one_outlier_touch_does_not_set_the_colour_scale():
    """Eq. 1 with a noisy sub-millimetre displacement is heavy-tailed: one touch 1000x too stiff must
    not squeeze every other colour to 0 (it saturates at the top of the scale instead)."""
    vals = np.linspace(1e6, 2e6, 17)
    vals[3] = 1e9
    scans = [scan("a", values=vals), scan("b", seed=1, values=np.linspace(3e6, 4e6, 17))]
    scale = D.c_scale(scans)
    assert 3e6 < scale < 5e6
    np.testing.assert_allclose(D.colour_input([1e6, 1e9, -1.0], scale), [1e6 / scale, 1.0, 0.0])


def test_scan_rejects_nan_and_mismatched_probes():
    with pytest.raises(InputError, match="NaN or inf"):
        D.ObjectScan("a", np.full((10, 3), np.nan), np.zeros((2, 3)), [1.0, 2.0])
    with pytest.raises(InputError, match="3 probe points but 2 values"):
        D.ObjectScan("a", np.zeros((10, 3)), np.zeros((3, 3)), [1.0, 2.0])


def test_farthest_first_covers_before_it_repeats():
    line = np.c_[np.arange(10.0), np.zeros(10), np.zeros(10)]
    assert farthest_first(line, 3, 0).tolist() == [0, 9, 4]
    dup = np.zeros((4, 3))                                              # coincident candidates: still distinct
    assert sorted(farthest_first(dup, 4, 2).tolist()) == [0, 1, 2, 3]


def test_farthest_covers_better_than_random_on_average():
    s = scan("a", n_touch=24)

    def radius(idx):   # largest distance from a candidate to its nearest touch
        d = np.linalg.norm(s.touch_points[:, None] - s.touch_points[idx][None], axis=2)
        return d.min(axis=1).max()

    for g in (3, 7):
        far = np.mean([radius(select_touches("farthest", s.touch_points, g, k)) for k in range(20)])
        rnd = np.mean([radius(select_touches("random", s.touch_points, g, k)) for k in range(20)])
        assert far < rnd


def test_selection_errors_and_map_error_edge_cases():
    s = scan("a")
    with pytest.raises(InputError, match="unknown policy 'best'"):
        select_touches("best", s.touch_points, 3, 0)
    with pytest.raises(InputError, match=r"G = 18 touches asked of 17 candidate probes \(valid: 1..17\)"):
        select_touches("random", s.touch_points, 18, 0)
    assert np.isnan(map_error(s.touch_points, s.touch_values, np.arange(17)))
    uniform = scan("u", values=np.full(17, 3e6))
    assert map_error(uniform.touch_points, uniform.touch_values, np.array([0, 5]), "smooth") == pytest.approx(0)


def test_classify_scene_refuses_g_beyond_the_probes(tmp_path, root):
    from vtcore.scene import run_scene

    with pytest.raises(InputError, match="G = 20 touches per cloud but tennis_ball, sponge_ball have fewer probes"):
        run_scene(root / "scenes/classify_touches.toml", tmp_path / "o", overrides=[
            'task.objects=["empty_bottle", "tennis_ball", "sponge_ball"]', "task.touches=[3, 20]"])
    assert not (tmp_path / "o").exists()


def test_without_torch_the_cli_names_the_extra(tmp_path, root):
    code = ("import sys; sys.modules['torch'] = None\n"       # what an install without the extra sees
            "from vtcore.cli import main\n"
            f"sys.exit(main(['run', 'scenes/classify_touches.toml', '--out', {str(tmp_path / 'o')!r}]))")
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300, cwd=root)
    assert r.returncode == 2, r.stderr
    assert "pip install 'vtcore[learn]'" in r.stderr and "torch==2.13.0" in r.stderr
    assert "Traceback" not in r.stderr
    assert not (tmp_path / "o").exists()


def test_import_vtcore_learn_does_not_import_torch():
    code = "import sys, vtcore, vtcore.learn, vtcore.learn.experiment; print('torch' in sys.modules)"
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert r.stdout.strip() == "False", r.stderr


def test_bench_without_torch_says_it_did_not_run(tmp_path, root):
    code = ("import sys; sys.modules['torch'] = None\n"
            "from pathlib import Path\nfrom vtcore.learn.bench import run\n"
            f"rows = run(Path({str(tmp_path)!r}), quick=True)\nprint(rows[0]['status'])")
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300, cwd=root)
    assert r.returncode == 0, r.stderr
    assert "not run" in r.stdout and "vtcore[learn]" in r.stdout
    assert "not run" in (tmp_path / "table.md").read_text()
    assert (tmp_path / "accuracy_vs_time.png").stat().st_size > 1000


def test_coverage_picks_representative_touches_and_needs_the_surface():
    from vtcore.learn.active import greedy_median

    line = np.c_[np.arange(10.0), np.zeros(10), np.zeros(10)]
    dense = np.c_[np.linspace(0, 9, 901), np.zeros(901), np.zeros(901)]
    assert greedy_median(line, dense, 2, 0).tolist() == [0, 6]     # the k-median's second point, not the far end
    s = scan("a", n_touch=24)

    def mean_dist(idx):
        return np.linalg.norm(s.points[:, None] - s.touch_points[idx][None], axis=2).min(axis=1).mean()

    for g in (3, 7):
        cov = np.mean([mean_dist(select_touches("coverage", s.touch_points, g, k, surface=s.points[::4]))
                       for k in range(10)])
        far = np.mean([mean_dist(select_touches("farthest", s.touch_points, g, k)) for k in range(10)])
        assert cov < far
    with pytest.raises(InputError, match="coverage policy needs the visual cloud"):
        select_touches("coverage", s.touch_points, 3, 0)
