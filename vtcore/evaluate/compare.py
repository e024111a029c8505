"""Designs side by side: one table, one CSV and one picture from the runs' own folders.

Each design is a folder written by the ``evaluate`` scene task (``result.json``, ``arrays.npz``); the
comparison reads the per-sample maps back and summarises the covered surface of each design with the
same area-weighted quantiles as its own report, so the numbers match the designs' reports exactly.
"""

from __future__ import annotations

import csv
import io
import json
from pathlib import Path

import numpy as np

from .._io import atomic_write
from .colours import QUANTITIES
from .design import weighted_quantiles

COLUMNS = ("design", "taxels", "covered (cm^2)", "blind, covered (cm^2)", "blind, margin (cm^2)",
           "threshold median (N)", "threshold p95 (N)", "localisation median (mm)", "localisation p95 (mm)",
           "two-point median (mm)", "two-point p95 (mm)", "seconds")


def design_row(name: str, folder: Path) -> dict:
    """One design's row (see :data:`COLUMNS`) from its run folder."""
    res = json.loads((Path(folder) / "result.json").read_text(encoding="utf-8"))
    m = res["metrics"]
    row = {"design": name, "taxels": m.get("taxels_live"), "covered (cm^2)": m.get("covered_area_cm2"),
           "blind, covered (cm^2)": m.get("blind_area_covered_cm2"),
           "blind, margin (cm^2)": m.get("blind_area_margin_cm2"), "seconds": res.get("seconds")}
    for q, label in (("threshold", "threshold"), ("localisation", "localisation"), ("two_point", "two-point")):
        unit = QUANTITIES[q].unit
        for stat in ("median", "p95"):
            row[f"{label} {stat} ({unit})"] = m.get(f"{q}_covered_{stat}_{'n' if unit == 'N' else 'mm'}")
    return row


def covered_values(folder: Path) -> dict:
    """Per-sample values on the covered surface of one design: map key -> (values, areas, valid)."""
    a = np.load(Path(folder) / "arrays.npz")
    cov = a["sample_covered"].astype(bool)
    out = {}
    for q in QUANTITIES.values():
        name = f"sample_{q.attribute}"
        if name in a.files:
            out[q.key] = (a[name][cov], a["sample_areas"][cov], a[f"sample_{q.key}_valid"][cov].astype(bool))
    return out


def comparison_figure(designs: list[tuple[str, Path]]):
    """Per map, each design's covered-surface median with a 5-95 % bar (area-weighted); the share of
    the covered surface with no value (blind, never located, never told apart) is written above it."""
    from ..plots import pyplot

    plt = pyplot()
    qs = list(QUANTITIES.values())
    fig, axes = plt.subplots(1, len(qs), figsize=(4.2 * len(qs), 0.9 + 0.35 * len(designs) + 2.2), squeeze=False)
    vals = [covered_values(f) for _, f in designs]
    for ax, q in zip(axes[0], qs):
        for i, ((name, _), v) in enumerate(zip(designs, vals)):
            if q.key not in v:
                continue
            x, w, ok = v[q.key]
            lo, med, hi = weighted_quantiles(x, w, (0.05, 0.5, 0.95))
            ax.errorbar([med], [i], xerr=[[med - lo], [hi - med]], fmt="o", color="#31688e", capsize=3)
            none = float(w[~ok].sum() / w.sum()) if w.sum() > 0 else 0.0
            if none > 0:
                ax.annotate(f"{100 * none:.0f} % none", (hi, i), xytext=(4, 0), textcoords="offset points",
                            va="center", fontsize=7, color="#cc1a26")
        ax.set_yticks(range(len(designs)))
        ax.set_yticklabels([n for n, _ in designs] if ax is axes[0][0] else [], fontsize=8)
        ax.set_xlabel(q.unit)
        ax.set_title(f"{q.title}\n(covered surface: median, 5-95 %)", fontsize=9)
        ax.invert_yaxis()
        ax.grid(axis="x", alpha=0.3)
    fig.tight_layout()
    return fig


def write_comparison(out: Path, designs: list[tuple[str, Path]], *, title: str = "Designs side by side",
                     notes=()) -> list[dict]:
    """Write ``out/comparison.md``, ``comparison.csv`` and ``comparison.png`` for ``designs`` (name, folder);
    designs whose folder holds no finished run are listed as failed. Returns the rows."""
    from .._bench import markdown_table, save_png

    out = Path(out)
    rows, done = [], []
    for name, folder in designs:
        if (Path(folder) / "result.json").is_file():
            rows.append(design_row(name, folder))
            done.append((name, Path(folder)))
        else:
            rows.append({"design": name, "taxels": "failed (see its folder)"})
    buf = io.StringIO()
    w = csv.DictWriter(buf, fieldnames=list(COLUMNS), lineterminator="\n", extrasaction="ignore")
    w.writeheader()
    w.writerows(rows)
    with atomic_write(out / "comparison.csv", "w", encoding="utf-8", newline="") as fh:
        fh.write(buf.getvalue())
    md = [f"# {title}", "", *[f"{n}\n" for n in notes],
          "Covered surface: within the lattice circumradius of a live taxel; medians and 95th percentiles are "
          "area-weighted; a point without a value (blind, never located, never told apart) counts at the "
          "largest value tested. Each design's folder holds its own report, maps.ply and arrays.", "",
          markdown_table(rows, COLUMNS), ""]
    if done:
        save_png(comparison_figure(done), out / "comparison.png")
        md += ["![designs side by side](comparison.png)", ""]
    with atomic_write(out / "comparison.md", "w", encoding="utf-8") as fh:
        fh.write("\n".join(md))
    return rows
