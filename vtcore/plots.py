"""Plots shared by tasks (matplotlib, Agg backend, imported lazily)."""

from __future__ import annotations

import numpy as np


def _plt():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def taxel_map(flat, values, *, title="", label="", ax=None, cmap="viridis", vmin=None, vmax=None,
              marker_mm=4.0):
    """Draw each taxel as a disc at its flat (or projected) position, coloured by ``values``.

    flat : (N, 2) metres (drawn in millimetres). values : (N,).
    Returns the matplotlib Figure.
    """
    plt = _plt()
    flat = np.asarray(flat, float) * 1e3
    values = np.asarray(values, float)
    if ax is None:
        fig, ax = plt.subplots(figsize=(5, 4.5))
    else:
        fig = ax.figure
    from matplotlib.collections import PatchCollection
    from matplotlib.patches import Circle

    coll = PatchCollection([Circle(xy, marker_mm / 2) for xy in flat], cmap=cmap)
    coll.set_array(values)
    coll.set_clim(vmin if vmin is not None else np.nanmin(values) if values.size else 0,
                  vmax if vmax is not None else np.nanmax(values) if values.size else 1)
    coll.set_edgecolor("0.3")
    coll.set_linewidth(0.4)
    ax.add_collection(coll)
    pad = marker_mm
    if len(flat):
        ax.set_xlim(flat[:, 0].min() - pad, flat[:, 0].max() + pad)
        ax.set_ylim(flat[:, 1].min() - pad, flat[:, 1].max() + pad)
    ax.set_aspect("equal")
    ax.set_xlabel("x (mm)")
    ax.set_ylabel("y (mm)")
    ax.set_title(title)
    fig.colorbar(coll, ax=ax, label=label, shrink=0.85)
    return fig
