"""The placement report as a designer reads it: the same lines in the CLI, ``vtcore layout
info`` and the Blender panel.

A placement report is the dict :meth:`PlacementReport.as_dict` writes into
``layout.meta["placement"]`` (and what a layout file keeps of it). :func:`report_fields`
picks the numbers a designer acts on (lists become counts), :func:`report_lines`
words them. A field a report does not have is left out, so older layout files and
the analytic placements of scenes show what they know.
"""

from __future__ import annotations

import math


def _num(value, shown_times: float = 1.0):
    """A finite float, or None (missing, None, nan; or a value that overflows once shown in the unit
    it is printed in, ``value x shown_times``: 1e308 m is not a distance in mm, -1e308 printed -Infinity)."""
    if value is None or isinstance(value, bool):
        return None
    try:
        v = float(value)
    except (TypeError, ValueError, OverflowError):
        return None
    return v if math.isfinite(v * shown_times) else None


def _count(value):
    """A count from an int or from a list of items (e.g. taxel indices)."""
    if isinstance(value, (list, tuple)):
        return len(value)
    v = _num(value)
    return None if v is None else int(v)


def report_fields(placement: dict | None) -> dict:
    """The designer-facing numbers of a placement report dict (absent ones left out).

    Returns a dict with any of: ``method`` (str), ``coverage`` (fraction of the
    region under module outlines), ``strain_max``, ``strain_mean`` (|stretch| of module
    edges, fractions), ``overlaps``, ``overlaps_within``, ``overlaps_existing`` (module
    pairs), ``off_boundary`` (taxels), ``charts`` (log maps a fill grew through),
    ``seam_modules`` (modules a fill's seam pass added where growth fronts met),
    ``normal_outliers`` (taxels whose normal is off the normal of the face they lie on by more
    than the report's threshold), ``normal_deviation_max_deg``,
    ``surface_distance_max_mm``, ``seconds``.
    """
    p = placement or {}
    out = {}
    if isinstance(p.get("method"), str):
        out["method"] = p["method"]
    for key, shown in (("coverage", 100), ("strain_max", 100), ("strain_mean", 100), ("seconds", 1),
                       ("normal_deviation_max_deg", 1)):
        v = _num(p.get(key), shown)
        if v is not None:
            out[key] = v
    for key in ("overlaps", "overlaps_within", "overlaps_existing", "off_boundary", "charts", "seam_modules",
                "normal_outliers"):
        v = _count(p.get(key))
        if v is not None:
            out[key] = v
    d = _num(p.get("surface_distance_max_m"), 1e3)
    if d is not None:
        out["surface_distance_max_mm"] = d * 1e3
    return out


def report_lines(placement: dict | None) -> list[str]:
    """Short lines, one per finding, for a terminal or a panel (empty without a report)."""
    f = report_fields(placement)
    lines = []
    if "coverage" in f:
        lines.append(f"coverage {100 * f['coverage']:.1f} % of the region")
    if "strain_max" in f:
        mean = f" (mean {100 * f['strain_mean']:.2f} %)" if "strain_mean" in f else ""
        lines.append(f"strain max {100 * f['strain_max']:.2f} %{mean}")
    if "overlaps" in f:
        parts = [f"{f[k]} {w}" for k, w in (("overlaps_within", "within the patch"),
                                            ("overlaps_existing", "with modules already there")) if f.get(k)]
        lines.append(f"overlaps {f['overlaps']} module pairs" + (f" ({', '.join(parts)})" if parts else ""))
    if f.get("off_boundary"):
        lines.append(f"{f['off_boundary']} taxels off the mapped surface")
    if f.get("normal_outliers"):
        worst = f" (up to {f['normal_deviation_max_deg']:.0f} deg)" if "normal_deviation_max_deg" in f else ""
        lines.append(f"{f['normal_outliers']} taxels with a normal off their face's{worst}")
    if f.get("charts", 1) > 1 or "seam_modules" in f:
        seam = f", {f['seam_modules']} modules closing the seam" if "seam_modules" in f else ""
        lines.append(f"grown through {f.get('charts', 1)} charts{seam}")
    return lines
