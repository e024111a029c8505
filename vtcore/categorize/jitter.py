"""Seed 001 with its uncertainty: per-trial placement and tilt jitter, and the probability of each task.

Seed 001 presses each object "on the center" three times and averages the trials; how exactly each
object sat (a millimetre off the centre, a degree or two of tilt, how the long objects were turned)
is not recorded. :func:`jittered_poses` draws, for every trial of every object, an offset in the
skin's plane (normal, ``xy`` m per axis), a tilt (normal, ``tilt`` rad, about a horizontal axis of
uniform direction through the object's placement point) and a turn about the press axis (normal,
``yaw`` rad). :func:`task_probabilities` then gives, for one set of tactile images, the exact
probability that category formation returns each task's split (over the random K-Means starts);
averaged over jitter seeds it is the probability of each task under the placement uncertainty.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import InputError
from .formation import CategoryFormation, kmeans_splits


@dataclass(frozen=True)
class Jitter:
    """Standard deviations of the per-trial placement: ``xy`` m (each axis of the skin plane),
    ``tilt`` rad (about a random horizontal axis), ``yaw`` rad (about the press axis)."""

    xy: float = 0.0
    tilt: float = 0.0
    yaw: float = 0.0

    def __post_init__(self):
        for k in ("xy", "tilt", "yaw"):
            v = getattr(self, k)
            if not (np.isfinite(v) and v >= 0):
                raise InputError(f"must be a standard deviation >= 0, got {v}", key=f"jitter_{k}")

    @property
    def none(self) -> bool:
        return self.xy == 0 and self.tilt == 0 and self.yaw == 0


def _rot(axis, angle):
    """(n, 3, 3) rotations by ``angle`` (n,) rad about unit ``axis`` (n, 3) (Rodrigues)."""
    a = np.asarray(axis, float)
    c, s = np.cos(angle)[:, None, None], np.sin(angle)[:, None, None]
    k = np.zeros((len(a), 3, 3))
    k[:, 0, 1], k[:, 0, 2], k[:, 1, 2] = -a[:, 2], a[:, 1], -a[:, 0]
    k[:, 1, 0], k[:, 2, 0], k[:, 2, 1] = a[:, 2], -a[:, 1], a[:, 0]
    return np.eye(3)[None] + s * k + (1 - c) * (k @ k)


def jittered_poses(poses, jitter: Jitter, rng, trials: int) -> np.ndarray:
    """(trials, M, 4, 4): every object's pose ``poses`` (M, 4, 4) perturbed independently per trial.

    The perturbation turns the object about its placement point (the pose's translation) by the
    yaw (about z) then the tilt (about a horizontal axis), and shifts it in x and y. The caller
    re-seats the object above the layer (the tilt can lower one end). Draw order: for each trial,
    for each object, (dx, dy, tilt, tilt axis angle, yaw), so a seed gives the same poses.
    """
    p = np.asarray(poses, float).reshape(-1, 4, 4)
    m = len(p)
    draws = rng.normal(size=(trials, m, 5))
    dx, dy = draws[..., 0] * jitter.xy, draws[..., 1] * jitter.xy
    tilt = draws[..., 2] * jitter.tilt
    phi = draws[..., 3] * np.pi                            # any direction for the tilt axis
    yaw = draws[..., 4] * jitter.yaw
    axis = np.stack([np.cos(phi), np.sin(phi), np.zeros_like(phi)], -1).reshape(-1, 3)
    rz = _rot(np.tile([0.0, 0.0, 1.0], (trials * m, 1)), yaw.ravel())
    rt = _rot(axis, tilt.ravel())
    r = rt @ rz                                          # (T*M, 3, 3)
    out = np.repeat(p[None], trials, axis=0).reshape(-1, 4, 4).copy()
    out[:, :3, :3] = r @ out[:, :3, :3]
    out[:, 0, 3] += dx.ravel()
    out[:, 1, 3] += dy.ravel()
    return out.reshape(trials, m, 4, 4)


def task_probabilities(images, tasks, *, n_runs: int = 3, n_init: int = 1, max_retries: int = 10) -> np.ndarray:
    """(K,) the exact probability that category formation on ``images`` (M, D) returns each task's split
    (over the random K-Means starts, the runs having to agree); zeros where no split exists."""
    est = CategoryFormation(n_runs=n_runs, n_init=n_init, max_retries=max_retries, random_state=0).fit(images)
    targets = np.stack([t.target for t in tasks])
    p = np.zeros(len(tasks))
    if not est.n_components_:
        return p
    for r in kmeans_splits(est.projection_, n_runs=n_runs, n_init=n_init):
        if r["valid"]:
            hit = (targets == r["labels"]).all(axis=1) | (targets == 1 - r["labels"]).all(axis=1)
            p += r["p_accepted"] * hit
    return p
