"""What a design map writes: per-vertex values on the robot mesh (PLY), the summary table, histograms.

:func:`vertex_maps` hands every mesh vertex the values of its nearest sample on the same side;
:func:`write_ply` writes the mesh with them (binary little-endian PLY: ``x y z`` float32, one float
property per map in its display unit, ``blind`` / ``evaluated`` / ``covered`` uchar, ``red green blue``
uchar of one chosen map, faces), which MeshLab, Open3D, trimesh and Blender read.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from .._io import atomic_write
from .colours import QUANTITIES, colourise
from .design import DesignMap, weighted_quantiles
from .samples import vertex_samples

#: the vertex properties of the PLY and the Blender attributes, in this order
VERTEX_FLOATS = ("threshold_n", "localisation_mm", "two_point_mm", "detect_rate")
VERTEX_FLAGS = ("blind", "evaluated", "covered")


def sample_values(dm: DesignMap) -> dict:
    """Per-sample arrays in display units: the maps, their validity flags, blind and covered."""
    out = {"threshold_n": dm.detection.threshold, "threshold_valid": dm.detection.detectable,
           "localisation_mm": dm.localisation.error * 1e3, "localisation_valid": dm.localisation.located,
           "detect_rate": dm.localisation.detect_rate, "blind": dm.blind, "covered": dm.samples.covered}
    if dm.two_point is not None:
        out["two_point_mm"] = dm.two_point.distance * 1e3
        out["two_point_valid"] = dm.two_point.found
    return out


def vertex_maps(dm: DesignMap, vertices, vertex_normals) -> dict:
    """Per-vertex values (V,) of the maps (see :func:`sample_values`) plus ``evaluated`` (V,) bool.

    Vertices farther than the sample spacing from every sample (beyond the margin) are not evaluated:
    their values are those of no touch at all (largest force, capped error, blind)."""
    idx, ev = vertex_samples(dm.samples, vertices, vertex_normals)
    vals = sample_values(dm)
    out = {}
    for k, v in vals.items():
        v = np.asarray(v)[idx]
        if k == "covered" or k.endswith("_valid") or k == "detect_rate":
            v = np.where(ev, v, False if v.dtype == bool else 0.0)
        elif k == "blind":
            v = np.where(ev, v, True)
        else:
            cap = {"threshold_n": dm.detection.force_cap, "localisation_mm": dm.localisation.error_cap * 1e3,
                   "two_point_mm": dm.settings.max_separation * 1e3}[k]
            v = np.where(ev, v, cap)
        out[k] = v
    out["evaluated"] = ev
    return out


def map_colours(values: dict, quantity: str = "threshold", hi: float | None = None):
    """RGBA (V, 4) and the :class:`colours.Legend` of one map from :func:`vertex_maps`'s values; ``hi`` (SI)
    ends the colour range (default: the 98th percentile of the values)."""
    q = QUANTITIES[quantity]
    key = q.attribute
    return colourise(np.asarray(values[key]) / q.scale, values[f"{quantity}_valid"], q,
                     evaluated=values.get("evaluated"), hi=None if hi is None else hi * q.scale)


def write_ply(path, vertices, faces, values: dict, colours=None, comments=()) -> None:
    """Binary PLY of a mesh with per-vertex properties (see the module docstring), atomically."""
    v = np.asarray(vertices, np.float32).reshape(-1, 3)
    f = np.asarray(faces, np.int64).reshape(-1, 3)
    fields = [("x", "<f4"), ("y", "<f4"), ("z", "<f4")]
    floats = [k for k in VERTEX_FLOATS if k in values]
    flags = [k for k in VERTEX_FLAGS if k in values]
    fields += [(k, "<f4") for k in floats] + [(k, "u1") for k in flags]
    if colours is not None:
        fields += [("red", "u1"), ("green", "u1"), ("blue", "u1")]
    rec = np.zeros(len(v), dtype=fields)
    rec["x"], rec["y"], rec["z"] = v[:, 0], v[:, 1], v[:, 2]
    for k in floats:
        rec[k] = np.asarray(values[k], np.float32)
    for k in flags:
        rec[k] = np.asarray(values[k], bool).astype(np.uint8)
    if colours is not None:
        c = np.clip(np.round(np.asarray(colours)[:, :3] * 255), 0, 255).astype(np.uint8)
        rec["red"], rec["green"], rec["blue"] = c[:, 0], c[:, 1], c[:, 2]
    face = np.zeros(len(f), dtype=[("n", "u1"), ("i", "<i4", (3,))])
    face["n"], face["i"] = 3, f
    kind = {"<f4": "float", "u1": "uchar"}
    head = ["ply", "format binary_little_endian 1.0", "comment vtcore design map (docs/evaluate.md), metres"]
    head += [f"comment {c}" for c in comments]
    head += [f"element vertex {len(v)}"] + [f"property {kind[t]} {n}" for n, t in fields]
    head += [f"element face {len(f)}", "property list uchar int vertex_indices", "end_header"]
    with atomic_write(Path(path), "wb") as fh:
        fh.write(("\n".join(head) + "\n").encode("ascii"))
        fh.write(rec.tobytes())
        fh.write(face.tobytes())


def summary_rows(dm: DesignMap) -> list[dict]:
    """The report's table: per map and region, the area-weighted median and 95th percentile."""
    s = dm.samples
    vals = sample_values(dm)
    rows = []
    for q in QUANTITIES.values():
        if q.attribute not in vals:
            continue
        for region, mask in (("covered", s.covered), ("covered + margin", np.ones(len(s), bool))):
            v, ok, w = vals[q.attribute][mask], vals[f"{q.key}_valid"][mask], s.areas[mask]
            med, p95 = weighted_quantiles(v, w, (0.5, 0.95))
            share = float((w * ok).sum() / w.sum()) if w.sum() > 0 else 0.0
            rows.append({"map": q.title, "region": region, "unit": q.unit, "median": med, "p95": p95,
                         "with a value": f"{100 * share:.1f} %"})
    return rows


def blind_rows(dm: DesignMap) -> list[dict]:
    s = dm.samples
    out = []
    for region, mask in (("covered", s.covered), ("margin", ~s.covered), ("covered + margin", np.ones(len(s), bool))):
        a = float(s.areas[mask].sum())
        b = float(s.areas[mask & dm.blind].sum())
        out.append({"region": region, "area (cm^2)": a * 1e4, "blind (cm^2)": b * 1e4,
                    "blind share": f"{100 * b / a:.1f} %" if a > 0 else "-"})
    return out


def histograms(dm: DesignMap):
    """A matplotlib figure: one area-weighted histogram per map, covered surface and margin stacked."""
    from ..plots import pyplot

    plt = pyplot()
    s = dm.samples
    vals = sample_values(dm)
    qs = [q for q in QUANTITIES.values() if q.attribute in vals]
    fig, axes = plt.subplots(1, len(qs), figsize=(4.6 * len(qs), 3.6), squeeze=False)
    for ax, q in zip(axes[0], qs):
        v, ok = vals[q.attribute], vals[f"{q.key}_valid"]
        finite = v[ok]
        lo, hi = (float(finite.min()), float(finite.max())) if len(finite) else (0.0, 1.0)
        bins = np.linspace(lo, hi if hi > lo else lo + 1, 30)
        parts = [(s.covered & ok, "covered"), (~s.covered & ok, "margin")]
        ax.hist([v[m] for m, _ in parts], bins=bins, weights=[s.areas[m] * 1e4 for m, _ in parts], stacked=True,
                label=[lab for _, lab in parts], color=["#31688e", "#b5de2b"])
        none = float(s.areas[~ok].sum() * 1e4)
        ax.set_title(f"{q.title}\n(no value on {none:.3g} cm$^2$: {q.no_value})", fontsize=9)
        ax.set_xlabel(q.unit)
        ax.set_ylabel("area (cm$^2$)")
        ax.legend(fontsize=8)
    fig.suptitle(f"{dm.settings.probe.describe()} at {dm.settings.reference_force:g} N; "
                 f"k = {dm.noise.k:g}, sigma = {dm.noise.sigma:.4g} counts", fontsize=10)
    fig.tight_layout()
    return fig


def map_figure(dm: DesignMap, taxels=None):
    """A matplotlib figure: the samples in 3-D coloured by each map (legend: units, red = no value)."""
    from ..plots import pyplot

    plt = pyplot()
    s = dm.samples
    vals = sample_values(dm)
    qs = [q for q in QUANTITIES.values() if q.attribute in vals]
    fig = plt.figure(figsize=(5.2 * len(qs), 4.8))
    p = s.positions * 1e3
    span = np.ptp(p, axis=0).max() / 2
    mid = p.min(axis=0) + np.ptp(p, axis=0) / 2
    for i, q in enumerate(qs):
        ax = fig.add_subplot(1, len(qs), i + 1, projection="3d")
        rgba, leg = colourise(vals[q.attribute] / q.scale, vals[f"{q.key}_valid"], q)
        ax.scatter(p[:, 0], p[:, 1], p[:, 2], c=rgba, s=3, depthshade=False)
        if taxels is not None:
            t = np.asarray(taxels) * 1e3
            ax.scatter(t[:, 0], t[:, 1], t[:, 2], c="k", s=2)
        for c, setter in enumerate((ax.set_xlim, ax.set_ylim, ax.set_zlim)):
            setter(mid[c] - span, mid[c] + span)
        ax.set_title(f"{q.title} ({q.unit})", fontsize=10)
        from matplotlib.colors import LogNorm, Normalize

        sm = plt.cm.ScalarMappable(cmap="viridis", norm=(LogNorm if leg.log else Normalize)(leg.lo, leg.hi))
        fig.colorbar(sm, ax=ax, shrink=0.6, label=f"{q.unit}; red: {q.no_value}")
        ax.set_xlabel("x (mm)")
        ax.set_ylabel("y (mm)")
    fig.tight_layout()
    return fig
