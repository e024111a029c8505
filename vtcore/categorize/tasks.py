"""Tasks, cluster matching (Eq. 7 of seed 001) and accuracy.

A *task* is one way of splitting the touched objects into two non-empty sets
(seed 001 §III, Fig. 5). With the paper's four objects there are
``2**(4-1) - 1 = 7`` tasks, numbered as in Fig. 5:

====  =============================  ==========================
task  cluster 1                      cluster 2
====  =============================  ==========================
1     sphere                         cube, half-cylinder, cuboid
2     cube                           sphere, half-cylinder, cuboid
3     half-cylinder                  sphere, cube, cuboid
4     cuboid                         sphere, cube, half-cylinder
5     sphere, half-cylinder (round)  cube, cuboid (edged)
6     sphere, cube (short)           half-cylinder, cuboid (long)
7     sphere, cuboid                 cube, half-cylinder
====  =============================  ==========================

(The extracted Fig. 5 shows only a circle or a square per object; the singleton
order follows the figure's legend, sphere - cube - half-cylinder - cuboid, and
is confirmed by Fig. 8: the 6 mm layer solves Task 2, and only the cube is
singled out by the decision boundary of Fig. 9b.)

For any other object set the tasks are every split, singletons first, then
pairs, ..., each split counted once (the set holding the first object is
"cluster 1" when both halves are equally large).

A task is a target vector ``t`` (N,) in {0, 1} with ``t_i = 1`` for objects in
cluster 1. Cluster matching (Eq. 7) relabels a guess ``v`` to ``1 - v`` when
that is strictly closer to ``t``; accuracy is then the fraction of objects whose
matched label equals ``t``.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass

import numpy as np

from ..errors import InputError

#: The four objects of seed 001 in the order of Fig. 5's legend.
PAPER_OBJECTS = ("sphere", "cube", "halfcylinder", "cuboid")

#: Fig. 5: cluster 1 of each task, by object name (task k is ``PAPER_TASKS[k - 1]``).
PAPER_TASKS = (
    ("sphere",),
    ("cube",),
    ("halfcylinder",),
    ("cuboid",),
    ("sphere", "halfcylinder"),
    ("sphere", "cube"),
    ("sphere", "cuboid"),
)

#: What each paper task groups by, for reports.
PAPER_TASK_NOTES = {5: "edged vs round", 6: "long vs short"}


@dataclass(frozen=True)
class Task:
    """One split of the objects into two sets.

    number : 1-based task number (Fig. 5 numbering for the paper's objects).
    target : (N,) int in {0, 1}, 1 for the objects of cluster 1, in object order.
    cluster1, cluster2 : object names of each side.
    """

    number: int
    target: np.ndarray
    cluster1: tuple[str, ...]
    cluster2: tuple[str, ...]

    @property
    def label(self) -> str:
        return f"{'+'.join(self.cluster1)} | {'+'.join(self.cluster2)}"


def make_tasks(names) -> list[Task]:
    """Every split of ``names`` into two non-empty sets, numbered.

    names : sequence of N >= 2 distinct object names. When they are the paper's
    four objects (in any order) the numbering is that of seed 001 Fig. 5.
    Returns ``2**(N-1) - 1`` tasks.
    """
    names = tuple(str(n) for n in names)
    n = len(names)
    if n < 2:
        raise InputError(f"category formation needs at least 2 objects, got {n}", key="objects")
    if len(set(names)) != n:
        dup = sorted({x for x in names if names.count(x) > 1})
        raise InputError(f"object names must be distinct; repeated: {', '.join(dup)}", key="objects")
    if n > 16:
        raise InputError(f"at most 16 objects (2**15 tasks), got {n}", key="objects")
    index = {name: i for i, name in enumerate(names)}
    if set(names) == set(PAPER_OBJECTS):
        groups = [tuple(index[x] for x in grp) for grp in PAPER_TASKS]
    else:
        groups = []
        for size in range(1, n // 2 + 1):
            for grp in itertools.combinations(range(n), size):
                if 2 * size == n and 0 not in grp:
                    continue  # the complement (which holds object 0) was counted already
                groups.append(grp)
    tasks = []
    for k, grp in enumerate(groups, start=1):
        t = np.zeros(n, dtype=np.int64)
        t[list(grp)] = 1
        tasks.append(Task(k, t, tuple(names[i] for i in sorted(grp)),
                          tuple(names[i] for i in range(n) if not t[i])))
    return tasks


def _check_pair(labels, target):
    v = np.asarray(labels)
    t = np.asarray(target)
    if v.shape != t.shape or v.ndim != 1:
        raise InputError(f"labels {v.shape} and target {t.shape} must be equal-length vectors",
                         key="labels")
    if not (np.isin(v, (0, 1)).all() and np.isin(t, (0, 1)).all()):
        raise InputError("labels and target must hold only 0 and 1 (a failed categorisation has -1 "
                         "labels and no accuracy)", key="labels")
    return v.astype(np.int64), t.astype(np.int64)


def cluster_match(labels, target) -> np.ndarray:
    """Eq. 7 of seed 001: the guess ``v`` or its relabelling ``1 - v``, whichever is closer to ``t``.

    labels, target : (N,) int in {0, 1}. Returns (N,) int. On a tie (both equally
    far) ``v`` is kept, as Eq. 7 swaps only when the swap is strictly closer.
    """
    v, t = _check_pair(labels, target)
    flipped = 1 - v
    return flipped if np.sum(flipped != t) < np.sum(v != t) else v


def accuracy(labels, target) -> float:
    """Fraction of objects whose matched cluster (Eq. 7) equals the task's, in [0.5, 1] for N even."""
    v, t = _check_pair(labels, target)
    if len(v) == 0:  # the mean of nothing is NaN: say so instead of returning it
        raise InputError("no objects: accuracy needs at least one label", key="labels")
    return float(np.mean(cluster_match(v, t) == t))


def confusion(labels, target) -> np.ndarray:
    """(2, 2) int: ``C[i, j]`` objects of task cluster ``i`` matched (Eq. 7) to guess ``j``.

    Index 0 is cluster 1 of the task (``t = 1``), index 1 is cluster 2, so the
    diagonal counts the correct guesses as in Fig. 8.
    """
    v, t = _check_pair(labels, target)
    m = cluster_match(v, t)
    c = np.zeros((2, 2), dtype=np.int64)
    np.add.at(c, (1 - t, 1 - m), 1)
    return c


def task_accuracies(labels, tasks) -> np.ndarray:
    """(K,) float: :func:`accuracy` of ``labels`` on each of ``tasks`` (vectorised over tasks)."""
    v = np.asarray(labels, dtype=np.int64)
    t = np.stack([task.target for task in tasks])  # (K, N)
    _check_pair(v, t[0])
    wrong = (v[None, :] != t).sum(axis=1)
    # Eq. 7: the relabelled guess gets N - wrong right; keep v on ties.
    right = np.maximum(len(v) - wrong, wrong)
    return right / len(v)

#: Accuracy per task (1..7) that seed 001 reports in Fig. 8 for its three layers (metres -> row).
#: For side-by-side comparison in reports only; nothing is fitted to it. Note that Eq. 7 with
#: "fraction of objects matched" cannot give 0.00 for a 2-2 task scored against a different 2-2
#: split (it gives 0.50), so the paper's 0.00 entries do not follow from its own definition.
PAPER_FIG8 = {
    0.003: (0.75, 0.75, 0.75, 0.75, 1.00, 0.00, 0.00),
    0.006: (0.50, 1.00, 0.50, 0.50, 0.75, 0.75, 0.75),
    0.010: (0.75, 0.75, 0.75, 0.75, 0.00, 1.00, 0.00),
}
