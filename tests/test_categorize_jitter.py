"""Seed 001 with its uncertainty (issue 27): placement jitter, task probabilities, reproducible from the seed."""

from pathlib import Path

import numpy as np
import pytest

from vtcore.categorize import make_tasks, tactile_images
from vtcore.categorize.jitter import Jitter, jittered_poses, task_probabilities
from vtcore.errors import InputError
from vtcore.scene import run_scene

SCENES = Path(__file__).resolve().parents[1] / "scenes"


def test_jittered_poses_follow_their_sigmas_and_their_seed():
    base = np.repeat(np.eye(4)[None], 4, axis=0)
    base[:, :3, 3] = [0.0, 0.0, 0.05]
    j = Jitter(xy=0.002, tilt=np.radians(3), yaw=np.radians(5))
    a = jittered_poses(base, j, np.random.default_rng(1), trials=2000)
    b = jittered_poses(base, j, np.random.default_rng(1), trials=2000)
    assert a.shape == (2000, 4, 4, 4) and np.array_equal(a, b)
    assert abs(a[..., 0, 3].std() / 0.002 - 1) < 0.05 and abs(a[..., 1, 3].std() / 0.002 - 1) < 0.05
    tilt = np.degrees(np.arccos(np.clip(a[..., 2, 2], -1, 1)))            # angle of the z axis from vertical
    assert abs(np.sqrt(np.mean(tilt**2)) - 3.0) < 0.2
    r = a[..., :3, :3]
    assert np.allclose(r @ np.swapaxes(r, -1, -2), np.eye(3), atol=1e-12)   # still rotations
    still = jittered_poses(base, Jitter(), np.random.default_rng(2), trials=3)
    assert np.array_equal(still, np.repeat(base[None], 3, axis=0))
    with pytest.raises(InputError):
        Jitter(xy=-1.0)


def test_task_probabilities_sum_to_one_over_the_splits():
    names = ["sphere", "cube", "halfcylinder", "cuboid"]
    tasks = make_tasks(names)
    rng = np.random.default_rng(0)
    images = np.array([[0, 0, 0, 0], [0, 1, 0, 0], [5, 0, 0, 0], [5, 1, 0, 0]], float) + 0.01 * rng.normal(size=(4, 4))
    p = task_probabilities(images, tasks)
    assert np.all(p >= 0) and p.sum() <= 1 + 1e-9
    assert np.argmax(p) == 5     # two far groups (sphere, cube) vs (halfcylinder, cuboid): task 6 splits them


def test_per_trial_pressures_make_per_trial_images():
    p = np.stack([np.full((2, 3), 1.0), np.full((2, 3), 3.0)])        # (trials 2, objects 2, taxels 3)
    images, frames = tactile_images(p, None, readings=2, trials=2)
    assert np.allclose(images, 2.0) and frames.shape == (2, 2, 2, 3)
    with pytest.raises(InputError, match="trials"):
        tactile_images(p, None, readings=2, trials=3)


SMALL = ["task.resolution_runs=0", "task.readings=2", "task.trials=2", "task.jitter_seeds=2",
         'task.jitter_bases=["bonded"]', "task.jitter_p_halfs=[0.0]"]


@pytest.mark.slow
def test_a_jittered_category_run_is_reproducible_from_its_seed(tmp_path):
    a = run_scene(SCENES / "category_3mm.toml", tmp_path / "a", overrides=SMALL)
    b = run_scene(SCENES / "category_3mm.toml", tmp_path / "b", overrides=SMALL)
    c = run_scene(SCENES / "category_3mm.toml", tmp_path / "c", overrides=SMALL + ["scene.seed=7"])
    assert a["metrics"] == b["metrics"]
    za, zb, zc = (np.load(tmp_path / x / "arrays.npz") for x in "abc")
    assert za["jitter_probability"].shape == (1, 1, 2, 7)
    assert np.array_equal(za["jitter_probability"], zb["jitter_probability"])
    assert not np.array_equal(za["object_pressure"], zc["object_pressure"]) or \
        not np.array_equal(za["jitter_probability"], zc["jitter_probability"])
    p = [a["metrics"][f"jitter_p_task{k}"] for k in range(1, 8)]
    assert all(0 <= x <= 1 for x in p) and sum(p) <= 1 + 1e-9
    report = (tmp_path / "a" / "report.md").read_text()
    assert "Task probabilities under placement jitter (2 draws)" in report
