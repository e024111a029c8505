"""Figures of a validation: recorded and simulated footprints side by side, and the statistics."""

from __future__ import annotations

import numpy as np

from ..plots import pyplot
from .footprint import METRICS

LABELS = {"active": "active taxels (30 mm)", "ring1": "ring 1 / peak", "ring2": "ring 2 / peak",
          "major_mm": "major radius (mm)", "minor_mm": "minor radius (mm)", "peak": "peak (counts)"}


def footprints_figure(v, layout, title: str, per_row: int = 4, half_mm: float = 30.0):
    """One recorded (left) and simulated (right) footprint per recording, its strongest frame, on the
    layout's flat (isomap) coordinates, both on the recorded frame's colour scale, ``half_mm`` around
    the peak taxel. ``v``: a :class:`vtcore.calibrate.validate.Validation`."""
    plt = pyplot()
    flat = np.asarray(layout.flat if layout.flat is not None else layout.positions[:, :2], float) * 1e3
    recs = np.unique(v.recording)
    pick = [np.flatnonzero(v.recording == r)[np.nanargmax(np.nanmax(v.real[v.recording == r], axis=1))] for r in recs]
    n = len(pick)
    rows = int(np.ceil(n / per_row))
    fig, axes = plt.subplots(rows, 2 * per_row, figsize=(2.0 * 2 * per_row, 2.1 * rows + 0.6), squeeze=False)
    for ax in axes.ravel():
        ax.set_axis_off()
    for j, kf in enumerate(pick):
        real, sim = v.real[kf], v.sim[kf]
        pk = int(np.nanargmax(real))
        c = flat[pk]
        near = np.all(np.abs(flat - c) <= half_mm, axis=1) & np.isfinite(real)
        vmax = float(np.nanmax(real))
        for side, vals, tag in ((0, real, "real"), (1, sim, "sim")):
            ax = axes[j // per_row, 2 * (j % per_row) + side]
            ax.set_axis_on()
            ax.scatter(flat[near, 0] - c[0], flat[near, 1] - c[1], c=np.clip(vals[near], 0, None), s=22,
                       cmap="viridis", vmin=0, vmax=vmax, edgecolors="none")
            ax.set_xlim(-half_mm, half_mm)
            ax.set_ylim(-half_mm, half_mm)
            ax.set_aspect("equal")
            ax.set_xticks([])
            ax.set_yticks([])
            name = v.paths[v.recording[kf]].replace("\\", "/").split("/")[-1].replace(".txt", "")
            held = " (held out)" if v.held_out[kf] else ""
            ax.set_title(f"{name}{held}\n{tag}, frame {v.frame[kf]}" if side == 0 else f"\n{tag}, {v.force[kf]:.2g} N",
                         fontsize=7)
    fig.suptitle(title, fontsize=9)
    fig.tight_layout()
    return fig


def metrics_figure(v, title: str):
    """Box plots of each footprint statistic over the frames: recorded and simulated, all recordings
    and (where there are some) the held-out ones."""
    plt = pyplot()
    names = [m for m in METRICS]
    fig, axes = plt.subplots(1, len(names), figsize=(2.3 * len(names), 3.2))
    groups = [("all", np.ones(len(v.real), bool))]
    if v.held_out.any():
        groups.append(("held out", v.held_out))
    for ax, m in zip(axes, names):
        data, labels = [], []
        for g, sel in groups:
            for side, mm in (("real", v.real_metrics), ("sim", v.sim_metrics)):
                x = np.asarray(mm[m], float)[sel]
                data.append(x[np.isfinite(x)])
                labels.append(f"{side}\n{g}")
        ax.boxplot(data, showfliers=False)
        ax.set_xticks(range(1, len(labels) + 1), labels, fontsize=6)
        ax.set_title(LABELS[m], fontsize=8)
        ax.tick_params(labelsize=7)
    fig.suptitle(title, fontsize=9)
    fig.tight_layout()
    return fig


#: the statistics the force plot shows (the four the footprint comparison is judged on)
FORCE_METRICS = ("ring1", "ring2", "active", "minor_mm")


def force_figure(v, title: str):
    """Each footprint statistic against the pressed force (the matched force of each frame, N, log
    axis): every frame as a faint dot (recorded and simulated), each recording's strongest frame as
    a large marker (open where the recording was held out of the calibration), and the medians of
    force bins as lines (:func:`vtcore.calibrate.validate.by_force`). ``v``: a Validation."""
    from .validate import by_force, peak_frames

    plt = pyplot()
    fig, axes = plt.subplots(1, len(FORCE_METRICS), figsize=(3.2 * len(FORCE_METRICS), 3.3))
    peak = peak_frames(v)
    binned = by_force(v, FORCE_METRICS)
    f = np.asarray(v.force, float)
    for ax, m in zip(axes, FORCE_METRICS):
        for side, mm, col in (("real", v.real_metrics, "tab:blue"), ("sim", v.sim_metrics, "tab:orange")):
            y = np.asarray(mm[m], float)
            ax.scatter(f, y, s=5, color=col, alpha=0.25, edgecolors="none")
            for sel, face in ((peak & ~v.held_out, col), (peak & v.held_out, "none")):
                if sel.any():
                    ax.scatter(f[sel], y[sel], s=28, facecolors=face, edgecolors=col, linewidths=1.0)
            ax.plot(binned["force_n"], binned[f"{m}_{side}"], "-o", color=col, ms=3, lw=1.5,
                    label=f"{side} (bin medians)")
        ax.set_xscale("log")
        ax.xaxis.set_minor_formatter(plt.NullFormatter())    # a decade or less: minor labels overlap
        ax.xaxis.set_major_formatter(plt.FuncFormatter(lambda x, _: f"{x:g}"))
        ax.set_xlabel("matched force (N)", fontsize=8)
        ax.set_title(LABELS[m], fontsize=8)
        ax.tick_params(labelsize=7)
    axes[0].legend(fontsize=6, title="large: peak frames\nopen: held out", title_fontsize=6)
    fig.suptitle(title, fontsize=9)
    fig.tight_layout()
    return fig
