"""Render the placement pictures of docs/layout.md (matplotlib, ~1 min):

- docs/img/layout_seam.png: the side of a closed cylinder filled by chart growth, unrolled
  (angle round the axis x radius against height), taxels coloured by the chart that placed
  their module, seam-pass modules outlined;
- docs/img/layout_sphere.png: a sphere filled the same way, module strain in colour (a sphere
  is not developable: each chart stretches its outer modules).

Run: PYTHONPATH=. .venv/bin/python scripts/layout_figures.py
"""

from __future__ import annotations

import warnings
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from vtcore.layout import cadmeshes, fill  # noqa: E402

OUT = Path(__file__).resolve().parent.parent / "docs" / "img"


def seam():
    r = 0.02
    cyl = cadmeshes.full_cylinder(r, 0.1, 0.003)
    side = np.abs(cyl.face_normals[:, 2]) < 0.5
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        lay, rep = fill(cyl, (r, 0, 0), (0, 1, 0), region=side)
    p = lay.positions
    s = np.arctan2(p[:, 1], p[:, 0]) * r * 1e3
    fig, ax = plt.subplots(figsize=(8, 4.2))
    chart = np.asarray(lay.meta.get("module_charts", np.zeros(lay.n_modules)))[lay.module_ids]
    sc = ax.scatter(s, p[:, 2] * 1e3, c=chart, cmap="tab20", s=14)
    seam_mods = set(lay.meta.get("seam_module_ids", []))
    for m in range(lay.n_modules):
        t = lay.module_ids == m
        if m in seam_mods:
            ax.scatter(s[t], p[t, 2] * 1e3, facecolors="none", edgecolors="k", s=40)
    ax.axvline(np.pi * r * 1e3, color="grey", lw=0.8, ls="--")
    ax.axvline(-np.pi * r * 1e3, color="grey", lw=0.8, ls="--")
    ax.set_xlabel("arc round the axis (mm; the dashed lines are the same line, opposite 'at')")
    ax.set_ylabel("height (mm)")
    ax.set_title(f"fill of a closed 20 mm cylinder's side: {lay.n_modules} modules, {rep.charts} charts, "
                 f"{rep.seam_modules} seam modules, overlaps {len(rep.overlaps)}", fontsize=9)
    fig.colorbar(sc, ax=ax, label="chart")
    ax.set_aspect("equal")
    fig.tight_layout()
    fig.savefig(OUT / "layout_seam.png", dpi=110)
    plt.close(fig)


def sphere():
    sph = cadmeshes.sphere(0.04, 4)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        lay, rep = fill(sph, (0, 0, 0.04), (1, 0, 0))
    p = lay.positions
    ms = rep.module_strain[lay.module_ids]
    fig = plt.figure(figsize=(6, 5))
    ax = fig.add_subplot(projection="3d")
    sc = ax.scatter(*(p.T * 1e3), c=ms, cmap="viridis", s=8)
    ax.set_title(f"fill of a 40 mm sphere: {lay.n_modules} modules, {rep.charts} charts, "
                 f"strain max {rep.strain_max:.3f}", fontsize=9)
    fig.colorbar(sc, ax=ax, label="module strain", shrink=0.7)
    fig.tight_layout()
    fig.savefig(OUT / "layout_sphere.png", dpi=110)
    plt.close(fig)


if __name__ == "__main__":
    OUT.mkdir(parents=True, exist_ok=True)
    seam()
    sphere()
