"""Category formation of seed 001 on synthetic tactile images: tasks, Eq. 7, PCA + K-Means, hard cases."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from vtcore.categorize import (PAPER_OBJECTS, CategoryFormation, accuracy, cluster_match, confusion,
                               decision_boundary, design_sweep, format_ranges_mm, kmeans_splits, make_tasks,
                               resolution_study, tactile_images, task_accuracies)
from vtcore.errors import InputError

TASKS = make_tasks(PAPER_OBJECTS)


def two_groups(rng, groups=(0, 1, 0, 1), d=60, sep=5.0, noise=0.1):
    """Four tactile images in two well-separated groups."""
    base = rng.normal(size=(2, d)) * sep
    return base[list(groups)] + rng.normal(size=(len(groups), d)) * noise


# -- tasks and cluster matching ------------------------------------------------------------------

def test_paper_tasks_are_the_seven_splits_numbered_as_fig5():
    assert len(TASKS) == 7
    splits = {frozenset(t.cluster1) for t in TASKS} | {frozenset(t.cluster2) for t in TASKS}
    assert len(splits) == 14  # every split once, each side distinct
    by_number = {t.number: set(t.cluster1) for t in TASKS}
    assert by_number[2] == {"cube"}
    assert by_number[5] == {"sphere", "halfcylinder"}  # round vs edged
    assert by_number[6] == {"sphere", "cube"}  # short vs long
    assert [t.number for t in TASKS] == list(range(1, 8))


def test_paper_task_numbering_does_not_depend_on_object_order():
    names = ["cuboid", "sphere", "cube", "halfcylinder"]
    tasks = make_tasks(names)
    t5 = tasks[4]
    assert set(t5.cluster1) == {"sphere", "halfcylinder"}
    assert t5.target.tolist() == [0, 1, 0, 1]


def test_generic_object_sets_enumerate_every_split_once():
    for n in (2, 3, 5, 6):
        tasks = make_tasks([f"o{i}" for i in range(n)])
        assert len(tasks) == 2 ** (n - 1) - 1
        keys = {tuple(sorted((tuple(t.target), tuple(1 - t.target)))) for t in tasks}
        assert len(keys) == len(tasks)
        assert all(0 < t.target.sum() < n for t in tasks)


@pytest.mark.parametrize("names", [["a"], ["a", "a"], []])
def test_bad_object_sets_are_rejected(names):
    with pytest.raises(InputError):
        make_tasks(names)


def test_cluster_match_example_of_the_paper():
    # Eq. 7: v = [0 0 0 1] for t = [1 1 1 0] is re-associated as [1 1 1 0].
    assert cluster_match([0, 0, 0, 1], [1, 1, 1, 0]).tolist() == [1, 1, 1, 0]
    # A tie keeps the guess.
    assert cluster_match([0, 1, 0, 1], [1, 1, 0, 0]).tolist() == [0, 1, 0, 1]


def test_fig8_rows_from_an_exact_split():
    """Accuracies of Fig. 8 that follow from Eq. 7 when a layer solves Task 5, 2 or 6 exactly."""
    np.testing.assert_allclose(task_accuracies(TASKS[4].target, TASKS), [.75, .75, .75, .75, 1, .5, .5])
    np.testing.assert_allclose(task_accuracies(TASKS[1].target, TASKS), [.5, 1, .5, .5, .75, .75, .75])
    np.testing.assert_allclose(task_accuracies(TASKS[5].target, TASKS), [.75, .75, .75, .75, .5, 1, .5])
    # the vectorised form agrees with the one-task form
    for labels in ([0, 1, 1, 1], [0, 0, 1, 1], [0, 1, 0, 0]):
        assert task_accuracies(labels, TASKS).tolist() == [accuracy(labels, t.target) for t in TASKS]


def test_confusion_diagonal_counts_correct_guesses():
    c = confusion([0, 1, 1, 1], TASKS[0].target)  # sphere alone: solved
    assert c.tolist() == [[1, 0], [0, 3]]
    c = confusion([0, 1, 0, 1], TASKS[5].target)  # round/edged split scored on short/long
    assert np.trace(c) == 2 and c.sum() == 4


def test_failed_labels_have_no_accuracy():
    with pytest.raises(InputError):
        accuracy([-1, -1, -1, -1], TASKS[0].target)
    with pytest.raises(InputError):
        accuracy([0, 1], TASKS[0].target)


# -- category formation ---------------------------------------------------------------------------

def test_separated_groups_are_found_and_seeded_runs_repeat():
    rng = np.random.default_rng(3)
    x = two_groups(rng)
    a = CategoryFormation(random_state=7).fit(x)
    b = CategoryFormation(random_state=7).fit(x)
    assert a.status_ == "ok" and a.labels_.tolist() == [0, 1, 0, 1]
    assert a.n_retries_ == 0 and a.n_attempts_ == 1
    np.testing.assert_array_equal(a.projection_, b.projection_)
    assert a.explained_variance_ratio_[0] > 0.9
    assert accuracy(a.labels_, TASKS[4].target) == 1.0


def test_labels_do_not_depend_on_units():
    x = two_groups(np.random.default_rng(4), groups=(0, 0, 1, 1))
    for s in (1e-9, 1.0, 1e6, 1e300):
        assert CategoryFormation(random_state=0).fit(x * s).labels_.tolist() == [0, 0, 1, 1]
    x32 = x.astype(np.float32)
    assert CategoryFormation(random_state=0).fit(x32).labels_.tolist() == [0, 0, 1, 1]


def test_decision_boundary_separates_the_clusters():
    x = two_groups(np.random.default_rng(5), groups=(0, 1, 1, 0))
    est = CategoryFormation(random_state=1).fit(x)
    mid, d = decision_boundary(est.centroids_)
    normal = np.array([d[1], -d[0]])
    side = np.sign((est.projection_ - mid) @ normal)
    assert len(set(side[est.labels_ == 0])) == 1 and len(set(side[est.labels_ == 1])) == 1
    assert side[est.labels_ == 0][0] != side[est.labels_ == 1][0]
    _, d0 = decision_boundary(np.zeros((2, 2)))
    assert np.isfinite(d0).all()


def test_disagreeing_runs_are_retried_and_bounded():
    # Four evenly spaced points on a line: {1}|{2,3,4}, {1,2}|{3,4} and {1,2,3}|{4} are all
    # K-Means fixed points, so random initialisations disagree now and then.
    x = np.array([[1.0], [2.0], [3.0], [4.0]])
    retried = unstable = 0
    for seed in range(30):
        est = CategoryFormation(random_state=seed, max_retries=3).fit(x)
        assert est.n_retries_ <= 3 and est.n_attempts_ == est.n_retries_ + 1
        retried += est.n_retries_ > 0
        if not est.ok:
            unstable += 1
            assert est.status_ == "unstable" and (est.labels_ == -1).all()
            assert "disagreed" in est.message_
    assert retried > 0
    # Without retries an ambiguous case gives up immediately and says so.
    est = CategoryFormation(random_state=0, max_retries=0, n_runs=50).fit(x)
    assert est.status_ == "unstable" and est.n_attempts_ == 1


def test_one_run_per_attempt_never_retries():
    x = np.array([[1.0], [2.0], [3.0], [4.0]])
    for seed in range(10):
        est = CategoryFormation(random_state=seed, n_runs=1).fit(x)
        assert est.ok and est.n_retries_ == 0


# -- hard cases -----------------------------------------------------------------------------------

@pytest.mark.parametrize("x", [np.full((4, 60), 123.0), np.zeros((4, 60)), np.ones((4, 1)),
                               np.full((4, 60), 1e300)])
def test_identical_images_are_degenerate_without_nan(x):
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        est = CategoryFormation(random_state=0).fit(x)
    assert est.status_ == "degenerate" and not est.ok
    assert "identical" in est.message_
    assert (est.labels_ == -1).all()
    for attr in ("projection_", "components_", "explained_variance_", "explained_variance_ratio_",
                 "centroids_"):
        assert np.isfinite(getattr(est, attr)).all(), attr


def test_two_objects_with_coincident_projections_share_a_cluster():
    rng = np.random.default_rng(8)
    x = rng.normal(size=(4, 60))
    x[2] = x[0]  # objects 0 and 2 give the same tactile image
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        for seed in range(10):
            est = CategoryFormation(random_state=seed).fit(x)
            assert est.ok
            np.testing.assert_allclose(est.projection_[0], est.projection_[2], atol=1e-12)
            assert est.labels_[0] == est.labels_[2]
            assert np.isfinite(est.centroids_).all()


def test_two_pairs_of_coincident_objects_split_into_the_pairs():
    x = np.array([[1.0, 5.0, 2.0]] * 2 + [[4.0, 0.0, 2.0]] * 2)[[0, 2, 1, 3]]
    est = CategoryFormation(random_state=0).fit(x)
    assert est.ok and est.labels_.tolist() == [0, 1, 0, 1] and est.n_retries_ == 0


def test_fewer_taxels_than_objects():
    rng = np.random.default_rng(9)
    for d in (1, 2, 3):
        x = np.concatenate([rng.normal(0, 0.1, (2, d)), rng.normal(5, 0.1, (2, d))])
        est = CategoryFormation(random_state=0).fit(x)
        assert est.ok and est.labels_.tolist() == [0, 0, 1, 1]
        assert est.n_components_ == min(2, d) and est.projection_.shape == (4, 2)
        assert np.isfinite(est.projection_).all() and np.isfinite(est.explained_variance_ratio_).all()
        if d == 1:
            assert (est.projection_[:, 1] == 0).all() and (est.components_[1] == 0).all()


def test_two_objects_are_split_apart():
    est = CategoryFormation(random_state=0).fit([[0.0, 1.0], [2.0, 1.0]])
    assert est.ok and est.labels_.tolist() == [0, 1]
    assert CategoryFormation(random_state=0).fit([[1.0, 1.0], [1.0, 1.0]]).status_ == "degenerate"


@pytest.mark.parametrize("bad", [np.zeros((1, 5)), np.zeros((4, 0)), np.zeros(4),
                                 np.array([[0.0, np.nan], [1.0, 2.0]])])
def test_bad_input_is_a_clear_error(bad):
    with pytest.raises(InputError):
        CategoryFormation().fit(bad)
    with pytest.raises(InputError):
        CategoryFormation(n_runs=0).fit(np.eye(3))


# -- tactile images -------------------------------------------------------------------------------

def test_tactile_images_average_readings_then_trials():
    p = np.arange(8.0).reshape(2, 4)
    img, frames = tactile_images(p, readings=10, trials=3)
    np.testing.assert_array_equal(img, p)
    assert frames.shape == (3, 2, 10, 4)
    calls = []

    def sensor(block):
        calls.append(block.shape)
        return block * 2.0 + len(calls)  # a drift that grows with every call

    img, frames = tactile_images(p, sensor, readings=5, trials=3)
    assert calls == [(5, 4)] * 6  # trials outer, objects inner
    # object 0 gets calls 1, 3, 5; object 1 gets 2, 4, 6
    np.testing.assert_allclose(img, p * 2.0 + np.array([[3.0], [4.0]]))
    with pytest.raises(InputError):
        tactile_images(p, lambda b: b[:, :2])
    with pytest.raises(InputError):
        tactile_images(p, readings=0)


# -- resolution study and designer sweep ----------------------------------------------------------

def test_resolution_study_subset_of_one_taxel_and_degenerate_runs():
    rng = np.random.default_rng(10)
    x = two_groups(rng, groups=(1, 1, 0, 0), d=12, sep=3.0)
    x[:, :4] = 7.0  # four taxels that see the same for every object
    study = resolution_study(x, TASKS, sizes=(1, 6, 12), runs=40, random_state=2)
    assert study.accuracy.shape == (3, 40, 7) and study.ok.shape == (3, 40)
    # one-taxel subsets on the flat taxels are degenerate: counted, not scored
    flat_runs = (study.subsets[0, :, 0] < 4)
    assert flat_runs.any()
    assert not study.ok[0, flat_runs].any()
    assert study.ok[0, ~flat_runs].all()
    assert study.n_ok[0] == (~flat_runs).sum()
    mean = study.mean()
    assert np.isfinite(mean).all() and mean[2, 5] == 1.0  # all 12 taxels: Task 6 split
    assert np.isfinite(study.std()).all() and np.isfinite(study.sem()).all()
    assert (study.solved_fraction()[0] <= study.n_ok[0] / 40).all()
    again = resolution_study(x, TASKS, sizes=(1, 6, 12), runs=40, random_state=2)
    np.testing.assert_array_equal(study.accuracy, again.accuracy)
    np.testing.assert_array_equal(study.subsets, again.subsets)


def test_resolution_study_where_no_run_succeeds_is_undefined_not_zero():
    x = np.zeros((4, 5))
    study = resolution_study(x, TASKS, sizes=(1, 5), runs=3, random_state=0)
    assert not study.ok.any()
    assert np.isnan(study.mean()).all()  # documented: undefined, not a fake accuracy
    assert (study.solved_fraction() == 0).all()
    with pytest.raises(InputError):
        resolution_study(x, TASKS, sizes=(6,), runs=3)
    with pytest.raises(InputError):
        resolution_study(x, TASKS, sizes=(0,), runs=3)


def test_design_sweep_reports_the_solving_thicknesses():
    rng = np.random.default_rng(11)
    base = rng.normal(size=(4, 30))
    edges = np.array([0.0, 1.0, 0.0, 1.0])[:, None] * base[0] * 10  # cube/cuboid differ from round
    length = np.array([0.0, 0.0, 1.0, 1.0])[:, None] * base[1] * 10  # half-cylinder/cuboid are long

    def images_at(h, r):
        w = h / 0.010  # edges fade and length takes over as the layer thickens
        noise = np.random.default_rng([int(h * 1e6), r]).normal(size=(4, 30)) * 0.05
        return (1 - w) * edges + w * length + noise

    hs = np.arange(1, 11) * 1e-3
    sweep = design_sweep(hs, images_at, TASKS, repeats=3, random_state=0)
    t5 = sweep.solving_thicknesses(4)
    t6 = sweep.solving_thicknesses(5)
    assert 0.001 in np.round(t5, 6) and 0.010 in np.round(t6, 6)
    assert not set(np.round(t5, 6)) & set(np.round(t6, 6))
    assert sweep.solved().shape == (10, 7) and sweep.mean_accuracy().max() <= 1.0 + 1e-12
    rate = sweep.solve_rate()
    assert ((rate >= 0) & (rate <= 1 + 1e-12)).all()
    # at most one split of the objects can be formed at a time: probabilities over tasks sum to <= 1
    assert (sweep.p_solve.sum(axis=2) <= 1 + 1e-9).all()
    # the seeded procedure's draws agree with the exact distribution where it is certain
    sure = sweep.p_solve[..., 5] > 1 - 1e-9
    assert (sweep.accuracy[..., 5][sure] == 1.0).all()
    assert format_ranges_mm([0.003, 0.004, 0.005, 0.009], step=0.001) == "3-5, 9 mm"
    assert format_ranges_mm([]) == "none"
    with pytest.raises(InputError):
        design_sweep([-0.001], images_at, TASKS)
    with pytest.raises(InputError):
        design_sweep(hs, images_at, TASKS, solve_probability=0.0)


def test_kmeans_splits_are_exact_over_random_starts():
    # a square: both 2-2 splits are K-Means fixed points; the diagonal split is not
    w = np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0], [1.0, 1.0]])
    w = w * np.array([1.0, 1.2])  # make the horizontal pairing the better one
    rows = kmeans_splits(w, n_runs=3)
    assert abs(sum(r["p_accepted"] for r in rows) - 1.0) < 1e-12
    assert abs(sum(r["p_run"] for r in rows) - 1.0) < 1e-12
    assert all(abs(r["p_run"] * 6 - round(r["p_run"] * 6)) < 1e-12 for r in rows)  # 6 starting pairs
    # empirical check against the seeded procedure: the frequency of each split over many seeds
    counts = {}
    for seed in range(150):
        est = CategoryFormation(random_state=seed, max_retries=200).fit(w)
        counts[tuple(est.labels_)] = counts.get(tuple(est.labels_), 0) + 1
    for r in rows:
        freq = counts.get(tuple(r["labels"]), 0) / 150
        assert abs(freq - r["p_accepted"]) < 0.12, (r, freq)
    assert kmeans_splits(np.zeros((4, 2))) == []


def test_figures_draw_for_ok_and_degenerate_outcomes(tmp_path):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from vtcore.categorize import plots

    x = two_groups(np.random.default_rng(12))
    for est in (CategoryFormation(random_state=0).fit(x), CategoryFormation().fit(np.ones((4, 3)))):
        fig = plots.projection_figure(est, PAPER_OBJECTS, title="t")
        fig.savefig(tmp_path / "p.png")
        plt.close(fig)
    acc = np.array([[1.0] * 7, [np.nan] * 7])
    conf = np.zeros((2, 7, 2, 2), int)
    fig = plots.accuracy_figure(acc, conf, ["3 mm", "6 mm"], list(range(1, 8)))
    fig.savefig(tmp_path / "a.png")
    plt.close(fig)
