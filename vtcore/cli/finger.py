"""``vtcore calibrate-finger``: fit a soft finger to recorded presses, then test it on held-out ones.

    vtcore calibrate-finger RECORDING... --layout LAYOUT --holdout RECORDING... --out DIR
        [--profile cyskin] [--quick]

The profile's layer and transfer curve are kept; the soft finger's pulp modulus, pulp depth and
pad radius are fitted on the recordings not held out (:mod:`vtcore.calibrate.finger_fit`), then
every recording is validated with the chosen finger and the peak-frame statistics of the fitted
and held-out recordings are reported apart. Writes ``finger_fit.json`` (the grid, scores,
intervals, the table), ``report.md`` (the table) and ``by_force.png`` / ``footprints.png``.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

#: the quick grid (tests, a first look): two values each
QUICK_GRID = {"pad_modulus": (20e3, 80e3), "core_depth": (0.003,), "radius": (0.007,)}
#: the finger pad's fixed dimensions: the profile's fitted length and wrap are kept (a soft finger
#: changes the contact across the pad, not along it)
NAMES = {"pad_modulus": ("pad modulus", 1e-3, "kPa"), "core_depth": ("pulp depth over the bone", 1e3, "mm"),
         "radius": ("pad radius", 1e3, "mm")}


def _table(rows) -> list[str]:
    out = ["| recordings | statistic | real median [IQR] | simulated median | inside IQR |", "|---|---|---|---|---|"]
    for r in rows:
        out.append(f"| {r['group']} ({r['recordings']}) | {r['stat']} | {r['real_median']:.3g} "
                   f"[{r['real_q25']:.3g}-{r['real_q75']:.3g}] | {r['sim_median']:.3g} | "
                   f"{'yes' if r['within'] else 'no'} |")
    return out


def cmd_calibrate_finger(args) -> int:
    import numpy as np

    from .._io import staged_into
    from ..calibrate.finger_fit import GRID, fit_soft_finger, peak_table
    from ..calibrate.plots import footprints_figure, force_figure
    from ..calibrate.validate import sensor_from_profile, validate
    from ..contact import ContactGrid, SoftLayer
    from ..contact.profile import load_profile
    from ..errors import InputError
    from ..inputs import check_output_dir
    from ..layout import load

    check_output_dir(args.out)
    layout = load(args.layout)
    prof = load_profile(args.profile)
    r = prof.response
    if r is None:
        raise InputError(f"profile {prof.name!r} has no [response] (layer and transfer curve)", key="--profile")
    held = {str(Path(h).resolve()) for h in args.holdout}
    paths = sorted({str(Path(p).resolve()) for p in args.recordings} | held)
    fitted = [p for p in paths if p not in held]
    if not fitted or not held:
        raise InputError("name recordings to fit on and recordings to hold out (--holdout)", key="--holdout")
    layer = SoftLayer(thickness=r.thickness, material=r.material, young_modulus=r.young_modulus,
                      poisson=r.poisson, base=r.base)
    sensor = sensor_from_profile(prof, layout.taxel_ids)
    base = {"length": float(r.indenter.get("length", 0.04)), "wrap": float(r.indenter.get("wrap", 1.0))}
    kw = {"k": prof.detection_k, "grid": ContactGrid(spacing=1e-3), "samples_per_taxel": 7}
    grid = QUICK_GRID if args.quick else GRID
    fit = fit_soft_finger(fitted, layout, layer=layer, sensor=sensor, base=base, params=grid,
                          progress=lambda p, v: print(f"  {p}: {len(v.real)} frames", file=sys.stderr), **kw)
    finger = {**base, **fit.best, "kind": "softfinger"}
    v = validate(paths, layout, layer=layer, indenter=finger, sensor=sensor, rng=np.random.default_rng(0),
                 held_out=sorted(held), **kw)
    rows = peak_table(v)
    lines = [f"Soft finger fitted on {len(fitted)} recordings, {len(held)} held out; layer and transfer curve of "
             f"profile {prof.name!r}; pad length {base['length'] * 1e3:g} mm, wrap {base['wrap']:g} (the profile's).", ""]
    for n, (label, scale, unit) in NAMES.items():
        lo, hi = fit.intervals[n]
        lines.append(f"- {label}: {fit.best[n] * scale:g} {unit} (bootstrap 5-95 %: {lo * scale:g}-{hi * scale:g} "
                     f"{unit}; grid {min(grid[n]) * scale:g}-{max(grid[n]) * scale:g}"
                     f"{', reaches a grid bound' if fit.at_bound[n] else ''})")
    lines += ["", "Peak frame of each recording (its strongest reading):", ""] + _table(rows)
    doc = {"best": fit.best, "intervals": fit.intervals, "at_bound": fit.at_bound, "grid": grid,
           "points": fit.points, "scores": [float(s) for s in fit.scores], "table": rows, "fitted": fitted,
           "held_out": sorted(held), "warnings": v.warnings}
    with staged_into(args.out) as stage:
        (stage / "finger_fit.json").write_text(json.dumps(doc, indent=1))
        (stage / "report.md").write_text("\n".join(lines) + "\n")
        force_figure(v, "soft finger: footprint statistics against the pressed force").savefig(stage / "by_force.png",
                                                                                                 dpi=110)
        footprints_figure(v, layout, "soft finger: recorded vs simulated footprints").savefig(
            stage / "footprints.png", dpi=110)
    print("\n".join(lines))
    print(f"-> {args.out}")
    return 0


def register(sub) -> None:
    c = sub.add_parser("calibrate-finger", help="fit a soft finger to recorded presses and test it on held-out ones")
    c.add_argument("recordings", nargs="+", metavar="RECORDING", help="CySkin text recordings (.txt) of presses")
    c.add_argument("--layout", required=True, metavar="LAYOUT", help="the recorded skin's layout (joined by taxel UID)")
    c.add_argument("--holdout", nargs="+", required=True, metavar="RECORDING",
                   help="recordings left out of the fit and reported apart")
    c.add_argument("--profile", default="cyskin", help="sensor profile: layer, transfer curve, noise (default cyskin)")
    c.add_argument("--quick", action="store_true", help="a two-point grid (a first look, tests)")
    c.add_argument("--out", required=True, metavar="DIR")
    c.set_defaults(func=cmd_calibrate_finger)
