"""Figures of the classification task: confusion matrices (Fig. 8), training curves, active vs random."""

from __future__ import annotations

import numpy as np

from ..plots import pyplot

#: short labels of seed 000's objects for the matrix axes
SHORT = {"empty_bottle": "empty bottle", "full_bottle": "full bottle", "tennis_ball": "tennis ball",
         "sponge_ball": "sponge ball", "cube_low_shore": "cube low", "cube_high_shore": "cube high"}


def confusion_figure(matrices: dict, objects, title: str = ""):
    """One panel per ``name -> (k, k) counts`` (rows true, columns predicted), row-normalised colours."""
    plt = pyplot()
    n = len(matrices)
    cols = min(n, 3)
    rows = (n + cols - 1) // cols
    fig, axes = plt.subplots(rows, cols, figsize=(4.4 * cols, 4.0 * rows), squeeze=False)
    labels = [SHORT.get(o, o) for o in objects]
    for ax, (name, m) in zip(axes.ravel(), matrices.items()):
        m = np.asarray(m)
        frac = m / np.maximum(m.sum(axis=1, keepdims=True), 1)
        ax.imshow(frac, cmap="Blues", vmin=0, vmax=1)
        for i in range(m.shape[0]):
            for j in range(m.shape[1]):
                ax.text(j, i, str(m[i, j]), ha="center", va="center", fontsize=8,
                        color="white" if frac[i, j] > 0.5 else "black")
        ax.set_xticks(range(len(labels)), labels, rotation=45, ha="right", fontsize=7)
        ax.set_yticks(range(len(labels)), labels, fontsize=7)
        acc = np.trace(m) / max(m.sum(), 1)
        ax.set_title(f"{name}: {100 * acc:.1f} %", fontsize=9)
        ax.set_xlabel("predicted", fontsize=8)
        ax.set_ylabel("true", fontsize=8)
    for ax in axes.ravel()[n:]:
        ax.axis("off")
    if title:
        fig.suptitle(title)
    fig.tight_layout()
    return fig


def curves_figure(curves: dict):
    """Training loss and validation accuracy per epoch, one line per data set version."""
    plt = pyplot()
    fig, (a, b) = plt.subplots(1, 2, figsize=(10, 3.8))
    for name, c in curves.items():
        ep = np.arange(1, len(c["train_loss"]) + 1)
        a.plot(ep, c["train_loss"], label=name)
        b.plot(ep, np.asarray(c["val_accuracy"], float) * 100, label=name)
    a.set_xlabel("epoch")
    a.set_ylabel("training loss")
    b.set_xlabel("epoch")
    b.set_ylabel("validation accuracy (%)")
    b.legend(fontsize=7)
    fig.tight_layout()
    return fig


def active_figure(acc: dict, err: dict, title: str = ""):
    """Accuracy (left) and held-out compliance-map error (right) against G, mean and spread over seeds.

    acc, err : ``label -> (G (g,), values (seeds, g))``.
    """
    plt = pyplot()
    fig, (a, b) = plt.subplots(1, 2, figsize=(10, 3.8))
    for ax, data, scale in ((a, acc, 100.0), (b, err, 100.0)):
        for label, (g, v) in data.items():
            v = np.asarray(v, float) * scale
            m = np.nanmean(v, axis=0)
            lo, hi = np.nanmin(v, axis=0), np.nanmax(v, axis=0)
            line, = ax.plot(g, m, marker="o", label=label)
            ax.fill_between(g, lo, hi, color=line.get_color(), alpha=0.2)
        ax.set_xlabel("touches G")
        ax.legend(fontsize=7)
    b.set_yscale("log")                  # one touch errs by up to ~2x; later touches by ~10-30 %
    a.axhline(95.0, color="grey", lw=0.8, ls="--")
    a.set_ylabel("test accuracy (%), band: min-max over seeds")
    b.set_ylabel("compliance-map error on untouched probes (%)")
    if title:
        fig.suptitle(title)
    fig.tight_layout()
    return fig
