"""Figures of seed 001: tactile images (Fig. 6), confusion matrices and accuracy (Fig. 8),
projections with the K-Means boundary (Fig. 9), accuracy against spatial resolution
(Fig. 10), and the designer's accuracy against layer thickness.

matplotlib with the Agg backend, imported lazily; every function returns a Figure.
"""

from __future__ import annotations

import numpy as np

from ..plots import pyplot
from .formation import CategoryFormation, decision_boundary

_MARKERS = {"sphere": "o", "cube": "s", "halfcylinder": "D", "cuboid": "P"}
_FALLBACK_MARKERS = "o s D P ^ v < > h X *".split()


def _marker(name, i):
    return _MARKERS.get(name, _FALLBACK_MARKERS[i % len(_FALLBACK_MARKERS)])


def tactile_images_figure(flat, images, names, *, title="", label="counts"):
    """Fig. 6: one taxel map per object, on a shared colour scale.

    flat : (N, 2) metres. images : (M, N). names : M object names.
    """
    from ..plots import taxel_map

    plt = pyplot()
    images = np.asarray(images, dtype=np.float64)
    m = len(images)
    fig, axes = plt.subplots(1, m, figsize=(3.6 * m, 3.4), squeeze=False)
    lo, hi = float(images.min()), float(images.max())
    if hi <= lo:
        hi = lo + 1.0
    for ax, img, name in zip(axes[0], images, names):
        taxel_map(flat, img, ax=ax, title=name, label=label, vmin=lo, vmax=hi)
    if title:
        fig.suptitle(title)
    fig.tight_layout()
    return fig


def projection_figure(est: CategoryFormation, names, *, title="", ax=None):
    """Fig. 9: the 2-D encodings of the objects, the centroids C0, C1 and the K-Means boundary ``l_kmc``."""
    plt = pyplot()
    if ax is None:
        fig, ax = plt.subplots(figsize=(5.2, 4.6))
    else:
        fig = ax.figure
    w = est.projection_
    ok = est.ok
    colours = ("tab:blue", "tab:orange")
    for i, name in enumerate(names):
        c = colours[est.labels_[i]] if ok else "0.4"
        ax.scatter(w[i, 0], w[i, 1], marker=_marker(name, i), s=90, color=c, edgecolor="k", zorder=3,
                   label=name)
        ax.annotate(name, w[i], textcoords="offset points", xytext=(7, 6), fontsize=9)
    span = np.ptp(w, axis=0).max() if len(w) else 1.0
    span = span if span > 0 else 1.0
    lo = w.min(axis=0) - 0.25 * span
    hi = w.max(axis=0) + 0.25 * span
    if ok:
        cen = est.centroids_
        for j in (0, 1):
            ax.scatter(*cen[j], marker="x", s=80, color=colours[j], zorder=4)
            ax.annotate(f"C{j}", cen[j], textcoords="offset points", xytext=(6, -12), fontsize=9,
                        color=colours[j])
        lo = np.minimum(lo, cen.min(axis=0) - 0.1 * span)
        hi = np.maximum(hi, cen.max(axis=0) + 0.1 * span)
        mid, d = decision_boundary(cen)
        t = 3.0 * span
        seg = np.stack([mid - t * d, mid + t * d])
        ax.plot(seg[:, 0], seg[:, 1], "k--", lw=1.2, label="$l_{kmc}$")
    else:
        ax.text(0.5, 0.5, f"no categories: {est.status_}", transform=ax.transAxes, ha="center")
    ax.set_xlim(lo[0], hi[0])
    ax.set_ylim(lo[1], hi[1])
    ev = est.explained_variance_ratio_
    ax.set_xlabel(f"PC1 ({100 * ev[0]:.0f}% of variance)")
    ax.set_ylabel(f"PC2 ({100 * ev[1]:.0f}% of variance)")
    ax.set_title(title)
    ax.legend(fontsize=8, loc="best")
    return fig


def accuracy_figure(accuracy, confusions, layer_labels, task_numbers, *, title=""):
    """Fig. 8: a 2x2 confusion matrix per layer and task, its accuracy written below.

    accuracy : (L, K) float. confusions : (L, K, 2, 2) int. layer_labels : L strings.
    task_numbers : K ints. Undefined accuracies (NaN) are drawn as empty cells.
    """
    plt = pyplot()
    acc = np.asarray(accuracy, dtype=np.float64)
    conf = np.asarray(confusions)
    n_l, n_k = acc.shape
    fig, axes = plt.subplots(n_l, n_k, figsize=(1.35 * n_k + 1.2, 1.6 * n_l + 0.6), squeeze=False)
    vmax = max(int(conf.max()), 1) if conf.size else 1
    for i in range(n_l):
        for k in range(n_k):
            ax = axes[i, k]
            ax.set_xticks([])
            ax.set_yticks([])
            if np.isfinite(acc[i, k]):
                ax.imshow(conf[i, k], cmap="Greys", vmin=0, vmax=vmax)
                for (r, c), v in np.ndenumerate(conf[i, k]):
                    ax.text(c, r, str(v), ha="center", va="center", fontsize=8,
                            color="w" if v > vmax / 2 else "k")
                best = acc[i, k] >= 1.0
                ax.set_xlabel(f"{acc[i, k]:.2f}", color="tab:red" if best else "k",
                              fontweight="bold" if best else "normal")
            else:
                ax.set_xlabel("n/a")
            if i == 0:
                ax.set_title(f"Task {task_numbers[k]}", fontsize=9)
            if k == 0:
                ax.set_ylabel(layer_labels[i])
    if title:
        fig.suptitle(title)
    fig.tight_layout()
    return fig


def resolution_figure(study, tasks, show, *, title=""):
    """Fig. 10: mean accuracy against taxels per subset, error bars one standard deviation.

    study : :class:`ResolutionStudy`. tasks : the task list. show : 0-based task indices to draw.
    """
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(5.6, 4.0))
    mean, std, sem = study.mean(), study.std(), study.sem()
    for k in show:
        line = ax.errorbar(study.sizes, mean[:, k], yerr=std[:, k], marker="o", capsize=3,
                           label=f"Task {tasks[k].number}: {tasks[k].label}")
        ax.fill_between(study.sizes, mean[:, k] - sem[:, k], mean[:, k] + sem[:, k],
                        color=line[0].get_color(), alpha=0.2, lw=0)
    ax.set_xlabel("taxels in the random subset, s")
    ax.set_ylabel(f"accuracy (mean of {study.accuracy.shape[1]} runs, bars: 1 std, band: s.e.m.)")
    ax.set_ylim(0.4, 1.05)
    ax.set_xticks(study.sizes)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    ax.set_title(title)
    return fig


def sweep_figure(sweep, tasks, *, title="", paper_layers_mm=(3, 6, 10)):
    """The designer's plot: expected accuracy (top) and solve probability (bottom) of every task
    against layer thickness; filled markers where the thickness solves the task."""
    plt = pyplot()
    fig, (ax, ax2) = plt.subplots(2, 1, figsize=(8.0, 7.0), sharex=True)
    mm = sweep.thicknesses * 1e3
    acc = sweep.mean_accuracy()
    rate = sweep.solve_rate()
    solved = sweep.solved()
    for k, task in enumerate(tasks):
        jitter = 0.004 * (k - len(tasks) / 2)  # keeps coinciding lines apart
        line, = ax.plot(mm, acc[:, k] + jitter, "-", lw=1.4, label=f"Task {task.number}: {task.label}")
        ax.scatter(mm[solved[:, k]], acc[solved[:, k], k] + jitter, s=40, color=line.get_color(), zorder=3)
        ax2.plot(mm, rate[:, k] + jitter, "-", lw=1.4, color=line.get_color())
        ax2.scatter(mm[solved[:, k]], rate[solved[:, k], k] + jitter, s=40, color=line.get_color(), zorder=3)
    for a in (ax, ax2):
        for h in paper_layers_mm or ():
            if mm.min() <= h <= mm.max():
                a.axvline(h, color="0.7", ls=":", lw=1)
        a.grid(alpha=0.3)
    ax2.axhline(sweep.threshold, color="k", ls="--", lw=0.8)
    ax.set_ylabel(f"expected accuracy\n(mean of {sweep.expected.shape[1]} noise draws)")
    ax.set_ylim(0.4, 1.05)
    ax2.set_ylabel("probability of forming\nexactly the task's split")
    ax2.set_ylim(-0.03, 1.05)
    ax2.set_xlabel("soft layer thickness (mm)")
    ax.legend(fontsize=7, loc="center left", bbox_to_anchor=(1.0, 0.0))
    ax.set_title(title or "which layer solves which task (dots: solved; dotted: seed 001's 3, 6, 10 mm)")
    fig.tight_layout()
    return fig
