"""``vtcore bench calibrate``: the time of ``vtcore calibrate`` and ``vtcore validate`` on the shared
real CySkin recordings, beside what they buy (how far the simulated footprints lie from the recorded
ones), and the validation's grid spacing as its accuracy knob.

Needs the recordings at ``../shared/data/cyskin_gesture`` beside the repository (or the folder named
by ``VTCORE_SHARED_DATA``).
"""

from __future__ import annotations

import os
import resource
import time
from pathlib import Path

import numpy as np

from .._bench import save_png, write_table
from ..errors import InputError

#: What this benchmark measures its error against (the closing note of ``vtcore bench`` lists it).
REFERENCE = ("the real CySkin recordings: each validate row's simulated footprint statistics against the "
             "recorded ones (their IQR)")

DONE = ("ring1", "ring2", "active", "minor_mm")


def shared_data() -> Path:
    """The folder of the shared CySkin gesture recordings (InputError naming where it looked)."""
    root = Path(os.environ.get("VTCORE_SHARED_DATA", Path(__file__).resolve().parents[2].parent / "shared" / "data"))
    d = root / "cyskin_gesture"
    if not (d / "1_finger").is_dir():
        raise InputError(f"the shared CySkin recordings are not at {d} (set VTCORE_SHARED_DATA to the folder "
                         "holding cyskin_gesture/)", key="VTCORE_SHARED_DATA")
    return d


def _clock(fn):
    w0, c0 = time.perf_counter(), time.process_time()
    out = fn()
    return out, time.perf_counter() - w0, time.process_time() - c0


def _deviation(m: dict, group: str = "all") -> tuple[int, float]:
    """(statistics of DONE within the recorded IQR, largest |sim median - real median| / real IQR)."""
    inside, worst = 0, 0.0
    for name in DONE:
        lo, hi = m[f"{group}_real_{name}_q25"], m[f"{group}_real_{name}_q75"]
        med_r, med_s = m[f"{group}_real_{name}_median"], m[f"{group}_sim_{name}_median"]
        inside += int(lo <= med_s <= hi)
        worst = max(worst, abs(med_s - med_r) / max(hi - lo, 1e-12))
    return inside, worst


def run(out: Path, quick: bool = False) -> list[dict]:
    from ..contact import ContactGrid, SoftLayer
    from ..contact.profile import load_profile
    from ..layout import load
    from .calibrate import calibrate
    from .validate import sensor_from_profile, validate

    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    d = shared_data()
    layout = load(d / "curved_gesture_patch_full_isomap.json")
    idle = sorted((d / "0_finger").glob("*.txt"))
    touched = sorted((d / "1_finger").glob("*.txt"))
    held = touched[11:]
    load0 = os.getloadavg()[0]
    rows = []
    rss0 = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    if quick:
        cal, wall, cpu = _clock(lambda: calibrate(idle + touched[:11], layout, name="bench", response=False))
        rows.append({"step": "calibrate (noise only)", "recordings": len(idle) + 11, "grid_mm": None,
                     "wall_s": wall, "cpu_s": cpu, "accuracy": f"sigma {cal.noise.summary['sigma']['median']:.0f}"})
    else:
        cal, wall, cpu = _clock(lambda: calibrate(idle + touched, layout, name="bench", holdout=held))
        fit = cal.response
        rows.append({"step": "calibrate", "recordings": len(idle) + len(touched) - len(held), "grid_mm": 1.0,
                     "wall_s": wall, "cpu_s": cpu,
                     "accuracy": f"score {fit.score.min() / fit.dof:.2f} IQR^2 per statistic and frame",
                     "peak_rss_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024})
    prof = load_profile("cyskin")
    sensor = sensor_from_profile(prof, layout.taxel_ids)
    r = prof.response
    layer = SoftLayer(thickness=r.thickness, material=r.material, young_modulus=r.young_modulus,
                      poisson=r.poisson, base=r.base)
    indenter = r.press_indenter()
    recs = touched[:4] if quick else touched
    grids = (2e-3, 1.5e-3, 1e-3) if quick else (2e-3, 1.5e-3, 1e-3, 0.75e-3)  # >= 3 points per curve
    results = {}
    for g in grids:
        v, wall, cpu = _clock(lambda: validate(recs, layout, layer=layer, indenter=indenter, sensor=sensor,
                                               rng=np.random.default_rng(1), k=prof.detection_k,
                                               held_out=r.fields.get("held_out", []),
                                               grid=ContactGrid(spacing=g)))
        results[g] = v
        inside, worst = _deviation(v.metrics)
        rows.append({"step": "validate", "recordings": len(recs), "grid_mm": g * 1e3, "wall_s": wall, "cpu_s": cpu,
                     "frames": v.metrics["frames"],
                     "accuracy": f"{inside}/4 in the recorded IQR (worst {worst:.2f} IQR off)",
                     "within": inside, "worst_iqr": worst,
                     "peak_rss_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024})
    if len(grids) > 1:
        ref = results[grids[-1]].sim_metrics
        for row, g in zip([x for x in rows if x["step"] == "validate"], grids):
            sm = results[g].sim_metrics
            row["vs_finest"] = float(max(np.nanmax(np.abs(np.asarray(sm[m]) - np.asarray(ref[m])))
                                         / max(np.nanmedian(np.abs(ref[m])), 1e-12) for m in DONE))
    load1 = os.getloadavg()[0]
    write_table(out, rows, title=f"Calibrate and validate on the shared CySkin recordings ({'quick' if quick else 'full'})",
                notes=[f"Shared recordings: {len(idle)} idle and {len(touched)} one-finger files, 642-taxel curved "
                       f"patch; the calibration holds out {len(held)} recordings. Accuracy: the fit's score; for "
                       "validate, how many of the issue's four statistics (ring 1, ring 2, active taxels, minor "
                       "radius) have their simulated median inside the recorded IQR, and the largest distance of a "
                       "simulated median from the recorded one in recorded IQRs; vs_finest: largest change of a "
                       "frame's statistic against the finest grid, relative to the statistic's median. "
                       f"Wall and process CPU seconds; load average {load0:.1f} / {load1:.1f} before / after "
                       f"(2 shared cores); peak RSS before: {rss0 / 1024:.0f} MB."],
                columns=["step", "recordings", "grid_mm", "frames", "wall_s", "cpu_s", "peak_rss_mb", "accuracy",
                         "vs_finest"])
    from ..plots import pyplot

    plt = pyplot()
    fig, ax = plt.subplots(figsize=(6.0, 4.0))
    val = [x for x in rows if x["step"] == "validate"]
    ax.plot([x["cpu_s"] for x in val], [x["worst_iqr"] for x in val], "o-")
    for x in val:
        ax.annotate(f"{x['grid_mm']:g} mm", (x["cpu_s"], x["worst_iqr"]), fontsize=7)
    ax.axvline(60, color="0.6", ls="--", lw=0.8)
    ax.set_xlabel("validate CPU time (s)")
    ax.set_ylabel("worst |sim - real| median, in recorded IQRs")
    ax.set_title("validate: accuracy vs time (labels: contact grid)")
    save_png(fig, out / "accuracy_vs_time.png")
    return rows
