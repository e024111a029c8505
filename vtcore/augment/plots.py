"""Pictures of augmented point clouds in the style of seed 000's Fig. 7 (matplotlib, lazy)."""

from __future__ import annotations

import numpy as np

from ..plots import pyplot
from .cloud import colour_map
from .experiment import voxel_filter


def view_coordinates(points, view_dir=(1.0, 0.0, 0.0), up=(0.0, 0.0, 1.0)):
    """Orthographic projection of (M, 3) points seen along ``-view_dir``: (M, 2) and depth (M,)."""
    d = np.asarray(view_dir, float)
    d /= np.linalg.norm(d)
    u = np.asarray(up, float) - np.dot(up, d) * d
    u /= np.linalg.norm(u)
    r = np.cross(u, d)
    p = np.asarray(points, float)
    return np.c_[p @ r, p @ u], p @ d


def augmented_panels(points, panels: dict, contacts=None, *, c_min, c_max, cmap="viridis_r", voxel=0.003,
                     view_dir=(1.0, 0.0, 0.0), title="", path=None, label="tactile colour c (counts/m)"):
    """One panel per colour field (name -> (M,) values), on a shared scale, contacts as red dots.

    points : (M, 3) metres. contacts : (n, 3) metres or None. Points are voxel
    filtered for display (``voxel`` metres) like the paper's figure, drawn
    back to front. path : optional (x, y) polyline in view coordinates (metres)
    to overlay, e.g. a path-following trajectory. Returns the Figure.
    """
    plt = pyplot()
    keep = voxel_filter(points, voxel)
    xy, depth = view_coordinates(points[keep], view_dir)
    order = np.argsort(depth)
    fig, axes = plt.subplots(1, len(panels), figsize=(2.6 * len(panels) + 0.8, 4.2), squeeze=False)
    for ax, (name, vals) in zip(axes[0], panels.items()):
        rgb = colour_map(np.asarray(vals)[keep][order], c_min, c_max, cmap) / 255.0
        ax.scatter(xy[order, 0] * 1e3, xy[order, 1] * 1e3, c=rgb, s=3, linewidths=0)
        if contacts is not None and len(contacts):
            cxy, _ = view_coordinates(contacts, view_dir)
            ax.scatter(cxy[:, 0] * 1e3, cxy[:, 1] * 1e3, c="red", s=10, linewidths=0)
        if path is not None:
            ax.plot(np.asarray(path)[:, 0] * 1e3, np.asarray(path)[:, 1] * 1e3, "-", color="tab:red", lw=1.2)
        ax.set_aspect("equal")
        ax.set_title(name, fontsize=9)
        ax.set_xlabel("mm")
    axes[0][0].set_ylabel("mm")
    import matplotlib as mpl

    sm = mpl.cm.ScalarMappable(norm=mpl.colors.Normalize(c_min, c_max), cmap=cmap)
    fig.colorbar(sm, ax=axes[0].tolist(), shrink=0.8, label=label)
    if title:
        fig.suptitle(title, fontsize=10)
    return fig


def touch_sequence(points, contacts, values, counts=(0, 2, 13, 22), *, beta=-300.0, c_min, c_max,
                   cmap="viridis_r", voxel=0.003, view_dir=(1.0, 0.0, 0.0), title=""):
    """Seed 000's Fig. 2: the augmented cloud after 0, 2, 13, 22 touches, smooth (top) and cluster (bottom).

    Built with :class:`AugmentedPointCloud`, one touch at a time (each update costs
    O(M)); points without any touch yet are grey. Returns the Figure.
    """
    from .propagation import AugmentedPointCloud

    plt = pyplot()
    counts = [k for k in counts if k <= len(contacts)]
    keep = voxel_filter(points, voxel)
    xy, depth = view_coordinates(points[keep], view_dir)
    order = np.argsort(depth)
    fig, axes = plt.subplots(2, len(counts), figsize=(2.2 * len(counts) + 0.6, 7.6), squeeze=False)
    for row, method in enumerate(("smooth", "cluster")):
        aug = AugmentedPointCloud(points, method, beta=beta)
        done = 0
        for col, k in enumerate(counts):
            aug.add_touches(contacts[done:k], values[done:k])
            done = k
            ax = axes[row][col]
            rgb = colour_map(aug.values[keep][order], c_min, c_max, cmap) / 255.0
            ax.scatter(xy[order, 0] * 1e3, xy[order, 1] * 1e3, c=rgb, s=2, linewidths=0)
            if k:
                cxy, _ = view_coordinates(contacts[:k], view_dir)
                ax.scatter(cxy[:, 0] * 1e3, cxy[:, 1] * 1e3, c="red", s=8, linewidths=0)
            ax.set_aspect("equal")
            ax.set_xticks([])
            ax.set_yticks([])
            ax.set_title(f"{method}, {k} touches", fontsize=8)
    if title:
        fig.suptitle(title, fontsize=10)
    return fig
