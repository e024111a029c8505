"""Plots shared by tasks (matplotlib, Agg backend, imported lazily)."""

from __future__ import annotations

import numpy as np


def pyplot():
    """``matplotlib.pyplot`` with the non-interactive Agg backend (imported on first use, so
    ``import vtcore`` stays fast; every plot of vtcore is drawn through this)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def png_writer(make, *args):
    """A ``(file) -> None`` figure for the runner (``TaskResult.figures``): calls ``make(*args)``
    only when plots are written, saves the Figure it returns as PNG into the open file, closes it."""
    def write(fh):
        fig = make(*args)
        fig.savefig(fh, format="png", dpi=120, bbox_inches="tight")
        pyplot().close(fig)

    return write


def taxel_map(flat, values, *, title="", label="", ax=None, cmap="viridis", vmin=None, vmax=None,
              marker_mm=4.0):
    """Draw each taxel as a disc at its flat (or projected) position, coloured by ``values``.

    flat : (N, 2) metres (drawn in millimetres). values : (N,).
    Returns the matplotlib Figure.
    """
    plt = pyplot()
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


def skin_3d(positions, values, *, mesh=None, title="", label="", cmap="viridis", elev=22, azim=-60):
    """The taxels in 3-D on their end-effector, coloured by ``values``.

    positions : (N, 3) metres (drawn in millimetres). values : (N,).
    mesh : optional end-effector (anything with ``vertices`` (V, 3) and ``faces`` (F, 3)),
        drawn as a light surface clipped to the patch's neighbourhood.
    Returns the matplotlib Figure.
    """
    plt = pyplot()
    from mpl_toolkits.mplot3d.art3d import Poly3DCollection

    pos = np.asarray(positions, float) * 1e3
    values = np.asarray(values, float)
    fig = plt.figure(figsize=(6, 5))
    # draw the taxels over the surface they sit on (matplotlib's depth sort puts them behind)
    ax = fig.add_subplot(projection="3d", computed_zorder=False)
    lo, hi = pos.min(axis=0), pos.max(axis=0)
    pad = 0.15 * max(float((hi - lo).max()), 1.0)
    if mesh is not None:
        v = np.asarray(mesh.vertices, float) * 1e3
        f = np.asarray(mesh.faces)
        tri = v[f]
        centre = tri.mean(axis=1)
        keep = np.all((centre >= lo - pad) & (centre <= hi + pad), axis=1)
        if keep.any():
            ax.add_collection3d(Poly3DCollection(tri[keep], facecolor="0.8", edgecolor="0.6", linewidths=0.15, alpha=0.4,
                                                 zorder=1))
    sc = ax.scatter(pos[:, 0], pos[:, 1], pos[:, 2], c=values, cmap=cmap, s=30, depthshade=False,
                    edgecolors="0.3", linewidths=0.3, zorder=2)
    span = float((hi - lo).max()) / 2 + pad
    mid = (lo + hi) / 2
    ax.set_xlim(mid[0] - span, mid[0] + span)
    ax.set_ylim(mid[1] - span, mid[1] + span)
    ax.set_zlim(mid[2] - span, mid[2] + span)
    ax.set_box_aspect((1, 1, 1))
    ax.view_init(elev=elev, azim=azim)
    ax.set_xlabel("x (mm)")
    ax.set_ylabel("y (mm)")
    ax.set_zlabel("z (mm)")
    ax.set_title(title)
    fig.colorbar(sc, ax=ax, label=label, shrink=0.7, pad=0.1)
    return fig


#: Every per-taxel quantity the add-on colours, with its title, unit and the factor from vtcore's
#: SI value to the unit shown (strain is a fraction, shown in %); "bool" quantities are two colours.
QUANTITIES = {
    "pressure": ("Pressure", "Pa", 1.0),
    "response": ("Sensor response", "counts", 1.0),
    "response_compensated": ("Response above baseline", "counts", 1.0),
    "edge": ("Edge of the contact", "bool", 1.0),
    "strain": ("Module-edge strain", "%", 100.0),
    "overlap": ("Overlap with another module", "bool", 1.0),
    "compliance": ("Compliance", "m/N", 1.0),
    "module_id": ("Module", "id", 1.0),
}


def legend_lines(name: str, values) -> list[str]:
    """The legend of a colour-by quantity as the add-on's panel shows it: title and unit, then the
    range the colour ramp spans (low = dark purple, high = yellow; viridis), from ``values`` (N,)."""
    title, unit, k = QUANTITIES.get(name, (name.replace("_", " ").capitalize(), "", 1.0))
    v = np.asarray(values, float).reshape(-1)
    v = v[np.isfinite(v)]
    if unit == "bool":
        n = int((v > 0.5).sum())
        return [f"{title}: yellow yes ({n} taxels), purple no ({len(v) - n})"]
    if not len(v):
        return [f"{title} ({unit}): no values"]
    lo, hi = float(v.min()) * k, float(v.max()) * k
    return [f"{title} ({unit}): purple {lo:.4g} .. yellow {hi:.4g}" + (" (all equal)" if lo == hi else "")]


def add_colorbar(png_path, name: str, lo: float, hi: float, cmap: str = "viridis") -> None:
    """Append a horizontal colour bar with the quantity's title, unit and range under the picture
    ``png_path`` (rendered pictures of the add-on: ``scripts/render_docs.py``), in place."""
    plt = pyplot()
    import matplotlib as mpl

    title, unit, k = QUANTITIES.get(name, (name, "", 1.0))
    img = plt.imread(str(png_path))
    h, w = img.shape[:2]
    dpi = 100
    fig = plt.figure(figsize=(w / dpi, h / dpi + 0.9), dpi=dpi)
    ax = fig.add_axes([0, 0.9 / (h / dpi + 0.9), 1, h / dpi / (h / dpi + 0.9)])
    ax.imshow(img)
    ax.axis("off")
    cax = fig.add_axes([0.15, 0.35 / (h / dpi + 0.9), 0.7, 0.18 / (h / dpi + 0.9)])
    if unit == "bool":
        cmap_ = mpl.colors.ListedColormap([mpl.colormaps[cmap](0.0), mpl.colormaps[cmap](1.0)])
        cb = fig.colorbar(mpl.cm.ScalarMappable(mpl.colors.Normalize(0, 1), cmap_), cax=cax,
                          orientation="horizontal", ticks=[0.25, 0.75])
        cb.ax.set_xticklabels(["no", "yes"])
        cb.set_label(title)
    else:
        cb = fig.colorbar(mpl.cm.ScalarMappable(mpl.colors.Normalize(lo * k, hi * k if hi > lo else lo * k + 1),
                                                mpl.colormaps[cmap]), cax=cax, orientation="horizontal")
        cb.set_label(f"{title} ({unit})")
    fig.savefig(str(png_path), dpi=dpi)
    plt.close(fig)
