"""``vtcore bench evaluate``: the design maps' accuracy against press-by-press solves, next to their time.

Rows:

- ``shortcut`` the maps (response table + superposition) against full contact solves at the same
  points (:func:`vtcore.evaluate.reference_points`, same estimator, noise draws and blob criterion):
  on seed 001's flat CySkin hexagon (the 'Done when' check: a few dozen points), on seed 002's curved
  patch (R 45 mm) and on a skin wrapped round a 20 mm link. Errors: the neighbour taxels' mean readings
  (% of the press's peak reading), the estimator on the mean readings (mm), the expected localisation
  error over 256 noise draws (%), the detection threshold (%), two-point distance (share within one
  1 mm step). Time per point of each.
- ``table_spacing`` the accuracy knob: the response table's cell (0.25 / 0.5 / 1 mm), each map against
  press-by-press solves at 12 of its 64 points on the flat hexagon (thresholds at 4; ``--quick``: 4 of
  16, 2), and the table's cost.
- ``link_1000`` the issue's performance case: a 1,000-taxel skin (100 CySkin modules filled on a 72 x
  200 mm link of 101k faces) at 2 mm (goal: detection + localisation under 10 s), cold (the table
  computed) and warm (table kept), with and without the two-point map; 4 and 1 mm; a two-layout
  comparison (goal under 30 s); peak memory (tracemalloc, numpy's buffers included). ``--quick``: 30
  modules on a 10k-face link. Errors: the first layout's maps against press-by-press
  solves (:func:`map_error`) at the covered samples nearest 8 random taxels (3 with ``--quick``),
  thresholds at 3 (2) of them; rows of one spacing share those samples and solves.
- ``resolution`` seed 001's Fig. 10 study as design maps: random subsets of s of the hexagon's 60 taxels
  (2 subsets per size with ``--quick``, 5 in full), each size's wall and CPU seconds per design map, and
  the first subset's maps against press-by-press solves with the same dead taxels at the samples
  nearest 6 of its live taxels (3 with ``--quick``), thresholds at 3 (2).

Every row states the machine's load average when it ran (2 shared cores): wall times move with it,
process CPU times much less.
"""

from __future__ import annotations

import os
import time
import tracemalloc
from pathlib import Path

import numpy as np

from .._bench import save_png, write_table
from .design import Settings, evaluate, evaluate_points
from .probe import Probe
from .maps import neighbours, readings
from .noise import sensor_noise
from .reference import reference_points

#: What this benchmark measures its error against (the closing note of ``vtcore bench`` lists it).
REFERENCE = ("full press-by-press contact solves at the same points (vtcore.evaluate.reference_points: one "
             "contact solve per point and force on the taxels near the point; the maps are a response table and "
             "superposition), on every row: shortcut, table_spacing, link_1000, resolution")


def _load() -> float:
    return round(os.getloadavg()[0], 1)


def _timed(fn):
    t0, c0 = time.perf_counter(), time.process_time()
    out = fn()
    return time.perf_counter() - t0, time.process_time() - c0, out


def _points_on(mesh, layout, m, rng, spacing=0.002):
    """``m`` random covered sample points (and normals) of ``layout`` on ``mesh``."""
    from .samples import sample_surface

    s = sample_surface(mesh, layout.positions, layout.normals, spacing=spacing, margin=0.0)
    pick = rng.choice(np.flatnonzero(s.covered), size=min(m, int(s.covered.sum())), replace=False)
    return s.positions[pick], s.normals[pick]


def shortcut_row(case, layout, points, normals, layer, st, noise, *, n_thr, n_tp, tp_dirs=(0.0, np.pi / 2)):
    """One 'shortcut' row: the map against press-by-press solves at ``points``."""
    t_map, c_map, pm = _timed(lambda: evaluate_points(layout, points, normals, layer, st, noise))
    t_ref, c_ref, ref = _timed(lambda: reference_points(layout, points, normals, layer, st, noise,
                                                        threshold_points=range(n_thr), two_point_points=range(n_tp),
                                                        two_point_directions=tp_dirs))
    k = pm.table.index(st.reference_force)
    nb = neighbours(layout.positions, layout.normals, points, normals, pm.table.reach, st.probe.yaw,
                    axis=st.probe_axis)
    mine = noise.counts(readings(pm.table, k, nb))
    peak = np.maximum(ref.readings.max(axis=1), 1e-300)
    rd = np.abs(mine - ref.readings).max(axis=1) / peak * 100
    loc_ok = pm.localisation.located & ref.localisation.located
    le = np.abs(pm.localisation.error - ref.localisation.error)[loc_ok]
    rel = le / np.maximum(ref.localisation.error[loc_ok], 1e-4) * 100
    nf = np.abs(pm.localisation.error_noise_free - ref.localisation.error_noise_free) * 1e3
    # no threshold asked for (the ring rows at --quick): no error to show, not a 0 % one
    thr = np.abs(pm.detection.threshold[:n_thr] / ref.threshold[:n_thr] - 1) * 100 if n_thr else None
    if n_tp and pm.two_point is not None:
        # the map's worst over the reference's orientations, computed for those orientations only
        sub = evaluate_points(layout, points[:n_tp], normals[:n_tp], layer,
                              Settings(**{**st.__dict__, "two_point_directions": len(tp_dirs)}), noise)
        agree = float(np.mean(np.abs(sub.two_point.distance - ref.two_point[:n_tp]) <= st.two_point_step + 1e-9))
    else:
        agree = None
    return {"case": "shortcut", "setting": case, "points": len(points), "load": _load(),
            "map_s_per_point": t_map / len(points), "press_s_per_point": t_ref / len(points),
            "presses": ref.presses, "reading_err_pct_median": float(np.median(rd)), "reading_err_pct_max": float(rd.max()),
            "loc_noise_free_err_mm_max": float(nf.max()),
            "loc_expected_err_pct_median": float(np.median(rel)) if len(rel) else None,
            "loc_expected_err_pct_max": float(rel.max()) if len(rel) else None,
            "threshold_err_pct_max": None if thr is None else float(thr.max()), "two_point_within_1mm": agree}


def link_skin(faces: int, modules: int):
    """A CySkin fill of ``modules`` modules on the side of a 72 x 200 mm link meshed with ~``faces`` faces."""
    from ..layout import cadmeshes, fill

    r, length = 0.072, 0.2
    mesh = cadmeshes.full_cylinder(r, length, float(np.sqrt(4 * np.pi * r * length / faces)))
    lay, _ = fill(mesh, (r, 0, 0), (0, 0, 1), radius=0.16)
    keep = np.unique(lay.module_ids)[:modules]
    return mesh, lay.subset(np.isin(lay.module_ids, keep))


def _interior_samples(dm, layout, k: int, seed: int = 5) -> np.ndarray:
    """Indices of ``k`` covered samples of ``dm``: the one nearest each of ``k`` random taxels (inside a
    module, where the press-by-press plane solve has taxels all round; see the curved patch's row)."""
    from scipy.spatial import cKDTree

    s = dm.samples
    cov = np.flatnonzero(s.covered)
    taxels = np.random.default_rng(seed).choice(len(layout), size=min(k, len(layout)), replace=False)
    _, near = cKDTree(s.positions[cov]).query(layout.positions[taxels])
    return np.unique(cov[near])


def map_error(dm, layout, layer, st, noise, k: int, n_thr: int, axis=(0.0, 0.0, 1.0)) -> dict:
    """The design map ``dm`` of ``layout`` against press-by-press solves (:func:`reference_points`) at
    ``k`` of its covered samples (:func:`_interior_samples`), the threshold at ``n_thr`` of them.
    ``axis``: the probe's long axis in the reference where ``st`` leaves it to the map (which lays a
    finger along the surface's flattest direction: a link's axis, z for :func:`link_skin`)."""
    idx = _interior_samples(dm, layout, k)
    s = dm.samples
    ref_st = Settings(**{**st.__dict__, "two_point": False,
                         "probe_axis": axis if st.probe_axis is None else st.probe_axis})
    t_ref, _, ref = _timed(lambda: reference_points(layout, s.positions[idx], s.normals[idx], layer, ref_st, noise,
                                                    threshold_points=range(n_thr)))
    return {"points": len(idx), "press_s_per_point": t_ref / len(idx),
            **_errors_against(dm.localisation, dm.detection, idx, ref, n_thr)}


def _errors_against(loc, det, idx, ref, n_thr: int) -> dict:
    """The map's localisation (``loc``) and detection (``det``) at the points ``idx`` against the
    press-by-press reference ``ref`` there (:func:`reference_points`, thresholds at its first
    ``n_thr`` points): the largest noise-free localisation difference (mm), the expected localisation
    error's difference (% of the reference's; median, max) and the threshold's (%; max, over the points
    where both find one)."""
    nf = np.abs(loc.error_noise_free[idx] - ref.localisation.error_noise_free) * 1e3
    both = loc.located[idx] & ref.localisation.located
    le = np.abs(loc.error[idx] - ref.localisation.error)[both]
    rel = le / np.maximum(ref.localisation.error[both], 1e-4) * 100
    ok = np.isfinite(ref.threshold[:n_thr]) & det.detectable[idx[:n_thr]]
    thr = np.abs(det.threshold[idx[:n_thr]][ok] / ref.threshold[:n_thr][ok] - 1) * 100
    return {"loc_noise_free_err_mm_max": float(nf.max()),
            "loc_expected_err_pct_median": float(np.median(rel)) if len(rel) else None,
            "loc_expected_err_pct_max": float(rel.max()) if len(rel) else None,
            "threshold_err_pct_max": float(thr.max()) if len(thr) else None}


def perf_rows(quick: bool, layer, noise) -> list[dict]:
    """The performance case (see the module docstring), each row with its error against press-by-press
    solves at a few of its samples (the same samples for rows of the same layout and spacing)."""
    from .design import clear_tables

    mesh, lay = link_skin(10_000 if quick else 100_000, 30 if quick else 100)
    rows, errors = [], {}
    n_ref, n_thr = (3, 2) if quick else (8, 3)

    def one(setting, st, spacing, layouts=(lay,), cold=False):
        if cold:
            clear_tables()
        tracemalloc.start()
        wall, cpu, dms = _timed(lambda: [evaluate(x, mesh, layer, st, noise, spacing=spacing) for x in layouts])
        peak = tracemalloc.get_traced_memory()[1]
        tracemalloc.stop()
        dm = dms[0]
        s = dm.summary()
        if spacing not in errors:  # detection and localisation do not depend on two_point or a warm table
            errors[spacing] = map_error(dm, lay, layer, st, noise, n_ref, n_thr)
        rows.append({"case": "link_1000", "setting": setting, "taxels": sum(len(x) for x in layouts),
                     "faces": len(mesh.faces), "samples": len(dm.samples), "load": _load(), "wall_s": wall,
                     "cpu_s": cpu, "peak_mb": peak / 2 ** 20,
                     "steps": ", ".join(f"{k} {v:.2f}" for k, v in dm.seconds.items()),
                     "threshold_median_n": s["threshold_covered_median_n"],
                     "localisation_median_mm": s["localisation_covered_median_mm"], **errors[spacing]})

    no2 = Settings(two_point=False)
    one("2 mm, detection + localisation, cold (table computed)", no2, 0.002, cold=True)
    one("2 mm, detection + localisation, warm (table kept)", no2, 0.002)
    one("2 mm, + two-point (4 mm points)", Settings(), 0.002)
    one("4 mm, detection + localisation", no2, 0.004)
    one("1 mm, detection + localisation", no2, 0.001)  # quick too: three spacings on the error curve
    half = lay.subset(np.isin(lay.module_ids, np.unique(lay.module_ids)[::2]))
    one("two layouts (all modules, every other one), 2 mm, cold", no2, 0.002, layouts=(lay, half), cold=True)
    one("two layouts, 2 mm, + two-point, warm", Settings(), 0.002, layouts=(lay, half))
    return rows


def knob_rows(hexagon, layer, noise, quick) -> list[dict]:
    """The table's cell (0.25 / 0.5 / 1 mm) against press-by-press solves at the first points of the
    maps (not against the finest cell, which is the same model), and what each cell costs."""
    from .design import clear_tables

    rng = np.random.default_rng(3)
    m = 16 if quick else 64
    pts = np.column_stack([rng.uniform(-0.02, 0.02, m), rng.uniform(-0.02, 0.02, m), np.zeros(m)])
    nrm = np.tile([0.0, 0.0, 1.0], (m, 1))
    k, n_thr = (4, 2) if quick else (12, 4)
    idx = np.arange(k)
    t_ref, _, ref = _timed(lambda: reference_points(hexagon, pts[idx], nrm[idx], layer, Settings(two_point=False),
                                                    noise, threshold_points=range(n_thr)))
    out = []
    for cell in (0.00025, 0.0005, 0.001):
        st = Settings(two_point=False, table_spacing=cell)
        clear_tables()
        t, c, pm = _timed(lambda: evaluate_points(hexagon, pts, nrm, layer, st, noise))
        out.append({"case": "table_spacing", "setting": f"{cell * 1e3:g} mm cell", "load": _load(), "points": k,
                    "map_s_per_point": t / m, "press_s_per_point": t_ref / k, "table_s": pm.seconds["table"],
                    "cpu_s": c, "table_cells": int(pm.table.values[0].size),
                    **_errors_against(pm.localisation, pm.detection, idx, ref, n_thr)})
    return out


def resolution_rows(mesh, hexagon, layer, noise, quick) -> list[dict]:
    """Seed 001 Fig. 10: random subsets of s taxels of the hexagon, median maps over the covered surface
    of the full hexagon (the subset's blind spots count), each size's time (wall and CPU per design map)
    and its error against press-by-press solves with the same dead taxels (:func:`_resolution_error`)."""
    from .design import table_for
    from .samples import sample_surface

    table_for(Settings(draws=8, two_point=False), layer)  # the response table, so no size's time includes it
    s = sample_surface(mesh, hexagon.positions, hexagon.normals, spacing=0.003, margin=0.0)
    cov = s.covered
    pts, nrm, a = s.positions[cov], s.normals[cov], s.areas[cov]
    rows = []
    seeds = range(2 if quick else 5)
    for size in (6, 12, 18, 24, 30, 36, 60):
        med, wall, cpu = [], 0.0, 0.0
        for seed in seeds:
            rng = np.random.default_rng(seed)
            keep = rng.choice(len(hexagon), size=size, replace=False)
            st = Settings(dead=tuple(int(i) for i in np.delete(hexagon.taxel_ids, keep)), draws=8, two_point=False,
                          seed=seed)
            t, c, pm = _timed(lambda st=st: evaluate_points(hexagon, pts, nrm, layer, st, noise))
            wall, cpu = wall + t, cpu + c
            med.append((np.median(pm.detection.threshold), np.median(pm.localisation.error) * 1e3,
                        float(a[pm.blind].sum() / a.sum() * 100)))
            if seed == 0:
                err = _resolution_error(pm, hexagon, keep, pts, nrm, layer, st, noise, quick)
        med = np.asarray(med)
        rows.append({"case": "resolution", "setting": f"s = {size} taxels", "load": _load(),
                     "map_s": wall / len(seeds), "cpu_s": cpu / len(seeds), "samples": len(pts),
                     "threshold_median_n": float(med[:, 0].mean()), "localisation_median_mm": float(med[:, 1].mean()),
                     "blind_pct": float(med[:, 2].mean()), "blind_pct_std": float(med[:, 2].std()),
                     "subsets": len(seeds), **err})
    return rows


def _resolution_error(pm, hexagon, keep, pts, nrm, layer, st, noise, quick) -> dict:
    """The first subset's maps ``pm`` against press-by-press solves with the same dead taxels at the
    samples nearest 3 (``quick``) or 6 of its live taxels (``keep``), thresholds at 2 (3) of them."""
    from scipy.spatial import cKDTree

    k, n_thr = (3, 2) if quick else (6, 3)
    taxels = np.random.default_rng(7).choice(keep, size=min(k, len(keep)), replace=False)
    idx = np.unique(cKDTree(pts).query(hexagon.positions[taxels])[1])
    t_ref, _, ref = _timed(lambda: reference_points(hexagon, pts[idx], nrm[idx], layer, st, noise,
                                                    threshold_points=range(n_thr)))
    return {"points": len(idx), "press_s_per_point": t_ref / len(idx),
            **_errors_against(pm.localisation, pm.detection, idx, ref, n_thr)}


def run(out: Path, quick: bool = False) -> list[dict]:
    """Write ``table.md``, ``table.csv`` and ``accuracy_vs_time.png`` into ``out``; return the rows."""
    from ..contact import SoftLayer
    from ..layout import make_patch, seed001_disc, seed002_curved

    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    layer = SoftLayer(thickness=0.003)
    noise = sensor_noise()
    rng = np.random.default_rng(0)
    disc, hexagon = seed001_disc()
    st = Settings(draws=256)
    rows = []
    n = 8 if quick else 36
    pts, nrm = _points_on(disc, hexagon, n, rng)
    rows.append(shortcut_row("flat CySkin hexagon (seed 001), 3 mm, finger pad 5 N", hexagon, pts, nrm, layer, st,
                             noise, n_thr=4 if quick else 12, n_tp=2 if quick else 8))
    mesh2, curved = seed002_curved()
    pts, nrm = _points_on(mesh2, curved, 60, rng)
    # points well inside the patch: near its edge the press-by-press plane solve extrapolates the
    # skin's surface beyond the taxels (a fitted quadric), which is not the shortcut's error
    inner = np.argsort(np.linalg.norm(pts - curved.positions.mean(axis=0), axis=1))[:4 if quick else 12]
    rows.append(shortcut_row("seed 002 curved patch (R 45 mm), finger pad across its curvature", curved, pts[inner], nrm[inner],
                             layer, st, noise, n_thr=2 if quick else 6, n_tp=0))
    for radius in (0.045, 0.02):
        ring = _ring_skin(radius, rows=15)
        m = 4 if quick else 10
        th = rng.uniform(0, 2 * np.pi, m)
        nr = np.column_stack([np.cos(th), np.sin(th), np.zeros(m)])
        pr = radius * nr + rng.uniform(-0.004, 0.004, m)[:, None] * [0, 0, 1]
        for what, s_ in (("finger pad along the link", Settings(draws=256, probe_axis=(0, 0, 1))),
                         ("finger pad across the link", Settings(draws=256, probe_axis=(0, 0, 1),
                                                                 probe=Probe(yaw=np.pi / 2))),
                         ("fingertip (sphere r 8 mm) at 2 N", Settings(draws=256, probe_axis=(0, 0, 1),
                                                                      probe=Probe("sphere"), reference_force=2.0))):
            rows.append(shortcut_row(f"skin round a {radius * 2e3:g} mm link, {what}", ring, pr, nr, layer, s_,
                                     noise, n_thr=0 if quick else 3, n_tp=0))
    rows += knob_rows(make_patch("hexagon").flat_layout(), layer, noise, quick)
    rows += perf_rows(quick, layer, noise)
    rows += resolution_rows(disc, hexagon, layer, noise, quick)
    _plot(out, rows)
    cols = ["case", "setting", "load", "points", "map_s_per_point", "press_s_per_point", "reading_err_pct_median",
            "reading_err_pct_max", "loc_noise_free_err_mm_max", "loc_expected_err_pct_median",
            "loc_expected_err_pct_max", "threshold_err_pct_max", "two_point_within_1mm", "table_s", "table_cells",
            "taxels", "faces", "samples", "map_s", "wall_s", "cpu_s", "peak_mb", "steps", "threshold_median_n",
            "localisation_median_mm", "blind_pct", "blind_pct_std", "subsets"]
    write_table(out, rows, title="Design maps (vtcore.evaluate): the shortcut against press-by-press solves, and "
                                 "its cost", columns=cols, notes=[
        "Goals (issue 29): detection + localisation maps of a 1,000-taxel skin on a 100k-face link at 2 mm "
        "under 10 s; a two-layout comparison under 30 s. The machine has 2 cores shared with other engineers: "
        "`load` is the 1-minute load average when the row ran; `cpu_s` is this process's CPU time.",
        "Shortcut errors are against press-by-press solves on a 0.5 mm grid with 19 samples per taxel disc "
        "(the same estimator, noise draws and blob criterion); reading errors are the neighbour taxels' mean "
        "readings at the reference force, in % of that press's peak reading. link_1000 rows: the same "
        "comparison at the covered samples nearest a few random taxels (`points`; `press_s_per_point` is the "
        "reference's cost). table_spacing rows: each cell's maps against press-by-press solves at 12 of their 64 "
        "points (thresholds at 4), not against the finest cell; the reference's own 0.5 mm grid and 1 % "
        "bisection bound how closely a cell can agree with it. resolution rows: `map_s` and `cpu_s` are one design map's "
        "wall and CPU seconds (mean over the subsets), the errors the first subset's maps against press-by-press "
        "solves with the same dead taxels."])
    return rows


def _ring_skin(radius: float, rows: int = 5):
    from ..layout import PITCH, Layout

    n = int(round(2 * np.pi * radius / PITCH))
    th = np.concatenate([2 * np.pi * (np.arange(n) + 0.5 * (r % 2)) / n for r in range(rows)])
    z = np.repeat((np.arange(rows) - (rows - 1) / 2) * PITCH * np.sqrt(3) / 2, n)
    nrm = np.column_stack([np.cos(th), np.sin(th), np.zeros_like(th)])
    return Layout(radius * nrm + z[:, None] * [0, 0, 1], nrm, np.arange(len(th)), np.arange(len(th)) // 10)


def _short(setting: str) -> str:
    """A case's name short enough for the plot's legend, keeping what tells the cases apart (the link's
    size, along or across, the probe)."""
    for long, short in (("flat CySkin hexagon (seed 001), 3 mm, ", "flat hexagon, "),
                        ("seed 002 curved patch (R 45 mm), finger pad across its curvature",
                         "seed 002 R 45 mm, pad across"),
                        ("skin round a ", ""), (" link, finger pad ", " link, pad "), ("the link", ""),
                        ("fingertip (sphere r 8 mm)", "fingertip")):
        setting = setting.replace(long, short)
    return setting.strip()


def _plot(out: Path, rows: list[dict]) -> None:
    from ..plots import pyplot

    plt = pyplot()
    fig, axes = plt.subplots(1, 2, figsize=(11, 4))
    ax = axes[0]
    for r in (r for r in rows if r["case"] == "shortcut"):
        ax.scatter([r["map_s_per_point"] * 1e3], [r["reading_err_pct_max"]], marker="o",
                   label=f"map: {_short(r['setting'])}")
        ax.scatter([r["press_s_per_point"] * 1e3], [0.0], marker="x", color="k")
    ax.set_xscale("log")
    ax.set_xlabel("ms per point (x: press by press, the reference)")
    ax.set_ylabel("largest reading error (% of peak)")
    ax.legend(fontsize=7)
    ax.set_title("shortcut vs press-by-press")
    ax = axes[1]
    perf = [r for r in rows if r["case"] == "link_1000"]
    ax.barh(range(len(perf)), [r["wall_s"] for r in perf], color="#31688e", label="wall")
    ax.barh(range(len(perf)), [r["cpu_s"] for r in perf], color="#b5de2b", height=0.4, label="CPU")
    ax.set_yticks(range(len(perf)))
    ax.set_yticklabels([r["setting"][:46] for r in perf], fontsize=7)
    ax.axvline(10, color="r", ls="--", lw=0.8)
    ax.set_xlabel("seconds (red: the 10 s goal)")
    ax.legend(fontsize=7)
    ax.invert_yaxis()
    fig.tight_layout()
    save_png(fig, out / "accuracy_vs_time.png")
