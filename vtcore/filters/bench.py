"""``vtcore bench filters``: edge-filter time and accuracy side by side.

Rows:
- ``mesh_filter`` Eq. 6 alone, one frame, on the seed 002 skins (20 and 210 taxels;
  paper: 0.075 ms for its 211-taxel patch; goal <= 0.02 ms).
- ``mesh_filter_batch`` Eq. 6 on (T, N) batches of random Delaunay skins of 211,
  1,000 and 4,000 taxels x 10,000 frames (1,000 with ``--quick``), float64 and
  float32 (goal >= 50 M taxel-frames/s).
  Both mesh-filter rows give ``rel_err``: the largest difference from Eq. 6 summed
  edge by edge straight from the triangles and positions (:func:`eq6_reference`, not
  the filter's CSR matrix nor its batched ``G (p p) - p (G p)`` form), over the
  largest reference value, on up to 200 of the batch's frames.
- ``detect_<method>`` the whole per-frame pipeline (filter, threshold, components,
  Eq. 8, moments, centroid) of each method on both skins, with its accuracy on
  straight-edge contacts (analytic pressure at random offsets and angles):
  error of the edge's position (mm) and orientation (deg). Knobs: the image
  grid (0.5/1/2 mm), the Loop subdivision levels (0/1/2).
- ``image_backproject_all`` the whole image pipeline with every skin pixel
  back-projected and used in the moments (seed 002's worst case, 7.2 ms), at
  grids of 2, 1 and 0.5 mm, against every pixel back-projected by a plain loop
  over the flat triangles (:func:`backproject_reference`): ``pos_err_mm`` the
  largest distance between the two 3-D points of a pixel, ``rel_err`` the
  distance between the two moments' centroids (mm), ``ang_err_deg`` between
  their orientations, ``misses`` the pixels one calls on the skin and the other not.

Only layout, contact and filters are used (filters sits left of control): the
closed-loop contour error of each method next to its time is
``vtcore bench control`` (``vtcore/control/bench.py``).
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np

from .._bench import save_png, write_table
from ..contact.analytic import footprint_pressure

#: What this benchmark measures its error against (the closing note of ``vtcore bench`` lists it).
REFERENCE = ("the known edge (position and orientation) of synthetic line contacts; mesh-filter rows: Eq. 6 "
             "summed edge by edge from the triangles and positions; image_backproject_all rows: every pixel "
             "back-projected by a plain loop over the flat triangles")

#: frames of a batch compared with the edge-by-edge reference (it is a slow loop over edges)
REFERENCE_FRAMES = 200


def _best(fn, repeat=5, number=None):
    """Best mean seconds per call over ``repeat`` rounds (auto-sized rounds of >= 20 ms)."""
    if number is None:
        number = 1
        while True:
            t0 = time.perf_counter()
            for _ in range(number):
                fn()
            if time.perf_counter() - t0 > 0.02 or number > 1e5:
                break
            number *= 4
    best = np.inf
    for _ in range(repeat):
        t0 = time.perf_counter()
        for _ in range(number):
            fn()
        best = min(best, (time.perf_counter() - t0) / number)
    return best


def _random_mesh(n, rng):
    from scipy.spatial import Delaunay

    from ..layout import mesh_from_triangles

    side = 7.5e-3 * np.sqrt(n)
    xy = rng.random((n, 2)) * side
    pos = np.column_stack([xy, np.zeros(n)])
    return mesh_from_triangles(pos, np.tile([0, 0, 1.0], (n, 1)), Delaunay(xy).simplices)


def _skins():
    """The seed 002 skins in their detector frames (x_R at the origin, z the approach axis)."""
    from .. import layout as L
    from .extract import skin_frame

    out = {}
    for name in ("seed002_planar", "seed002_curved"):
        _, lay = getattr(L, name)()
        lay = lay.transformed(np.linalg.inv(skin_frame(lay)))
        out[name] = (lay, L.skin_mesh(lay))
    return out


def eq6_reference(positions, triangles, values) -> np.ndarray:
    """Eq. 6 of seed 002 summed edge by edge, (T, N) float64: the filters' independent reference.

    ``r_i = sum_j p_j (p_j - p_i) / |x_i - x_j|`` over the undirected edges of ``triangles``
    (M, 3); ``positions`` (N, 3) m; ``values`` (T, N). Built from the triangles, not from
    the skin mesh's adjacency or the filter's CSR weights, and without the batched form's
    ``G (p p) - p (G p)`` factoring (which loses digits where ``p`` is large and nearly even).
    """
    tri = np.asarray(triangles, dtype=np.int64)
    e = np.sort(np.concatenate([tri[:, [0, 1]], tri[:, [1, 2]], tri[:, [2, 0]]]), axis=1)
    i, j = np.unique(e, axis=0).T
    inv_d = 1.0 / np.linalg.norm(np.asarray(positions)[i] - np.asarray(positions)[j], axis=1)
    p = np.asarray(values, dtype=np.float64).T                         # (N, T)
    r = np.zeros_like(p)
    np.add.at(r, i, p[j] * (p[j] - p[i]) * inv_d[:, None])
    np.add.at(r, j, p[i] * (p[i] - p[j]) * inv_d[:, None])
    return r.T


def _rel_err(got, ref) -> float:
    """max |got - ref| / max |ref| (float64)."""
    return float(np.max(np.abs(np.asarray(got, dtype=np.float64) - ref)) / max(np.max(np.abs(ref)), 1e-300))


def _line_cases(n, rng):
    return [(rng.uniform(-4e-3, 4e-3), rng.uniform(-0.6, 0.6)) for _ in range(n)]


def line_pressure(positions, offset, angle, width=1e-3, force=15.0, spread=2e-3, depth=3e-3, area=4.9e-5):
    """Taxel pressure (N,) Pa of a thin straight edge pressed on a skin facing it, or None.

    The skin's frame (positions (N, 3) metres, z towards the object) is turned by
    ``angle`` (rad) about z and flipped onto a table, as the control frame of a robot
    facing down; the edge runs along the table's x at ``y = offset`` (m) and is
    ``width`` m wide. In skin coordinates a point is at table height
    ``y_t = sin(angle) x - cos(angle) y``. Pressure:
    ``exp(-d^2 / (2 spread^2)) * clip(1 - (z_max - z) / depth, 0, 1)``, with ``d``
    the distance to the edge's top face and ``z_max`` the highest skin point near it
    (where a curved skin touches first), scaled to ``force`` over ``area`` per taxel.
    The same field as ``vtcore.control.AnalyticContact`` for a straight edge
    (both use :func:`vtcore.contact.footprint_pressure`).
    """
    q = np.asarray(positions, dtype=np.float64)
    y_t = np.sin(angle) * q[:, 0] - np.cos(angle) * q[:, 1]
    dist = np.maximum(np.abs(y_t - offset) - width / 2, 0.0)
    # z points towards the object, so the highest taxel touches first: gap = -z
    return footprint_pressure(dist, -q[:, 2], force, spread, depth, area)


def _accuracy(det, lay, cases):
    """Mean position (mm) and angle (deg) error of ``det`` on analytic straight edges."""
    pos_err, ang_err, frames = [], [], []
    for off, ang in cases:
        p = line_pressure(lay.positions, off, ang)
        if p is None:
            continue
        frames.append(p)
        f = det.detect(p)
        if not f.found:
            pos_err.append(np.nan)
            ang_err.append(np.nan)
            continue
        c = f.centroid
        pos_err.append(abs(np.sin(ang) * c[0] - np.cos(ang) * c[1] - off) * 1e3)
        # the edge's direction on the table: the skin's theta seen through the flip and the turn
        a = ang - f.theta
        ang_err.append(abs(np.degrees(np.mod(a + np.pi / 2, np.pi) - np.pi / 2)))
    miss = int(np.sum(np.isnan(pos_err)))
    return float(np.nanmean(pos_err)), float(np.nanmean(ang_err)), miss, frames


def backproject_reference(flat, positions, triangles, pixels) -> tuple[np.ndarray, np.ndarray]:
    """Every pixel centre back-projected onto the 3-D skin by a plain loop over the flat triangles:
    the independent reference of the ``image_backproject_all`` rows.

    ``flat`` (N, 2) m, ``positions`` (N, 3) m, ``triangles`` (F, 3), ``pixels`` (P, 2) m.
    Returns ``(inside (P,) bool, points (P, 3) m)``. Each triangle's affine map flat -> 3-D is solved
    from its corners (``np.linalg.solve``), and a pixel is inside where its barycentric coordinates
    are all >= -1e-9: no point location structure (the tactile image uses matplotlib's trifinder)
    and no precomputed weight matrix.
    """
    flat, pos, px = (np.asarray(a, dtype=np.float64) for a in (flat, positions, pixels))
    inside = np.zeros(len(px), dtype=bool)
    points = np.zeros((len(px), 3))
    for tri in np.asarray(triangles, dtype=np.int64):
        a, b, c = flat[tri]
        lo, hi = np.minimum(np.minimum(a, b), c) - 1e-12, np.maximum(np.maximum(a, b), c) + 1e-12
        cand = np.flatnonzero(np.all((px >= lo) & (px <= hi), axis=1) & ~inside)
        m = np.column_stack([b - a, c - a])
        if len(cand) == 0 or abs(np.linalg.det(m)) < 1e-18:  # a degenerate flat triangle covers no pixel
            continue
        l12 = np.linalg.solve(m, (px[cand] - a).T).T   # (k, 2)
        bary = np.column_stack([1.0 - l12.sum(axis=1), l12])
        ok = np.all(bary >= -1e-9, axis=1)
        inside[cand[ok]] = True
        points[cand[ok]] = bary[ok] @ pos[tri]
    return inside, points


def _backproject_rows(skins, frames_of) -> list[dict]:
    """Seed 002's worst case of the image pipeline (7.2 ms): every skin pixel back-projected and used
    in the moments, at three grids, with its error against :func:`backproject_reference`."""
    from .detectors import ImageEdgeDetector
    from .extract import features

    rows = []
    for name, (lay, mesh) in skins.items():
        frame = frames_of[name][0]
        for res in (2e-3, 1e-3, 0.5e-3):
            img = ImageEdgeDetector(lay.positions, mesh.triangles, lay.flat, resolution=res,
                                    sigma=1.5 * 1e-3 / res)
            tac = img.tactile

            def all_pixels():
                from skimage.measure import label

                _, e = img.edge_pixels(frame)
                label(e, connectivity=2)
                pts = tac.back_project(tac.inside)
                return features(pts, np.zeros(len(pts), dtype=np.int64))

            t = _best(all_pixels, repeat=3)
            got = all_pixels()
            h, w = tac.shape
            gx, gy = np.meshgrid(tac.origin[0] + res * np.arange(w), tac.origin[1] + res * np.arange(h))
            ref_in, ref_pts = backproject_reference(tac.flat, lay.positions, mesh.triangles,
                                                    np.column_stack([gx.ravel(), gy.ravel()]))
            mine_in = tac.inside.ravel()
            both = mine_in & ref_in
            ref = features(ref_pts[ref_in], np.zeros(int(ref_in.sum()), dtype=np.int64))
            d_theta = np.degrees(abs(np.mod(got.theta - ref.theta + np.pi / 2, np.pi) - np.pi / 2))
            rows.append({"row": "image_backproject_all", "skin": name, "taxels": len(lay), "frames": 1,
                         "knob": f"grid {res * 1e3:g} mm, {int(mine_in.sum())} px", "ms_per_frame": t * 1e3,
                         "taxel_frames_per_s": len(lay) / t,
                         "rel_err": float(np.linalg.norm(got.centroid - ref.centroid) * 1e3),
                         "pos_err_mm": float(np.max(np.linalg.norm(tac.pixel_points[both] - ref_pts[both], axis=1))
                                             * 1e3),
                         "ang_err_deg": float(d_theta), "misses": int(np.sum(mine_in != ref_in))})
    return rows


def _mesh_filter_rows(skins, rng, quick) -> list[dict]:
    """Eq. 6 alone: one frame on each seed 002 skin, then (T, N) batches of three sizes per dtype
    (``--quick``: fewer frames, not fewer sizes), each against :func:`eq6_reference`."""
    from .local import EdgeFilter

    rows = []
    for name, (lay, mesh) in skins.items():
        ef = EdgeFilter(mesh)
        p = rng.random(len(lay))
        t = _best(lambda: ef(p))
        rel = _rel_err(ef(p), eq6_reference(mesh.positions, mesh.triangles, p[None])[0])
        rows.append({"row": "mesh_filter", "skin": name, "taxels": len(lay), "frames": 1, "knob": "float64",
                     "ms_per_frame": t * 1e3, "taxel_frames_per_s": len(lay) / t, "rel_err": rel,
                     "pos_err_mm": "", "ang_err_deg": "", "misses": ""})
    t_frames = 1000 if quick else 10000
    for n in (211, 1000, 4000):
        mesh = _random_mesh(n, rng)
        for dt in (np.float64, np.float32):
            ef = EdgeFilter(mesh, dtype=dt)
            batch = rng.random((t_frames, n)).astype(dt)
            t = _best(lambda: ef(batch), repeat=2 if n * t_frames > 1e7 else 3, number=1)
            head = batch[:REFERENCE_FRAMES]
            rel = _rel_err(ef(batch)[:REFERENCE_FRAMES], eq6_reference(mesh.positions, mesh.triangles, head))
            rows.append({"row": "mesh_filter_batch", "skin": f"random_{n}", "taxels": n, "frames": t_frames,
                         "knob": np.dtype(dt).name, "ms_per_frame": t * 1e3 / t_frames,
                         "taxel_frames_per_s": n * t_frames / t, "rel_err": rel, "pos_err_mm": "",
                         "ang_err_deg": "", "misses": ""})
    return rows


def _detect_rows(skins, cases) -> tuple[list[dict], dict]:
    """The whole per-frame pipeline of each method and knob on both skins, with its accuracy on the
    straight-edge ``cases``; also returns each skin's analytic frames."""
    from .detectors import ImageEdgeDetector, MeshEdgeDetector, SubtaxelEdgeDetector

    rows, frames_of = [], {}
    for name, (lay, mesh) in skins.items():
        dets = [("mesh", "fraction 0.15", MeshEdgeDetector(mesh, fraction=0.15))]
        for res in (2e-3, 1e-3, 0.5e-3):  # >= 3 points per curve, quick or not
            dets.append(("image", f"grid {res * 1e3:g} mm",
                         ImageEdgeDetector(lay.positions, mesh.triangles, lay.flat, resolution=res,
                                           sigma=1.5 * 1e-3 / res)))
        for lv in (0, 1, 2):
            dets.append(("subtaxel", f"levels {lv}", SubtaxelEdgeDetector(mesh, levels=lv)))
        for method, knob, det in dets:
            pe, ae, miss, frames = _accuracy(det, lay, cases)
            frames_of[name] = frames
            k = [0]

            def one():
                det.detect(frames[k[0] % len(frames)])
                k[0] += 1

            t = _best(one, repeat=3)
            rows.append({"row": f"detect_{method}", "skin": name, "taxels": len(lay), "frames": 1, "knob": knob,
                         "ms_per_frame": t * 1e3, "taxel_frames_per_s": len(lay) / t, "rel_err": "",
                         "pos_err_mm": pe, "ang_err_deg": ae, "misses": miss})
    return rows, frames_of


def run(out: Path, quick: bool = False) -> list[dict]:
    """Write ``table.md``, ``table.csv`` and ``accuracy_vs_time.png`` into ``out``; return the rows."""
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    rng = np.random.default_rng(0)
    skins = _skins()
    rows = _mesh_filter_rows(skins, rng, quick)
    detect, frames_of = _detect_rows(skins, _line_cases(8 if quick else 40, rng))
    rows += detect + _backproject_rows(skins, frames_of)
    _write(out, rows)
    return rows


def _write(out: Path, rows: list[dict]) -> None:
    notes = ["Seed 002: Eq. 6 on its 211-taxel patch 0.075 ms; tactile-image pipeline 3.7 ms "
             "(7.2 ms with every pixel back-projected). Goals: <= 0.02 ms per frame on 211 taxels, "
             ">= 50 M taxel-frames/s batched. Accuracy: straight-edge contacts (analytic pressure), "
             "error of the detected edge position and orientation. Mesh-filter rows: rel_err against Eq. 6 "
             "summed edge by edge from the triangles (float32 rows show the single-precision rounding). "
             "image_backproject_all rows: against every pixel back-projected by a plain loop over the flat "
             "triangles (pos_err_mm: largest 3-D distance of a pixel's two points; rel_err: distance of the "
             "two moments' centroids, mm; ang_err_deg: of their orientations; misses: pixels on the skin "
             "in one and not the other)."]
    img = [r for r in rows if r["row"] == "detect_image" and r["knob"] == "grid 1 mm"]
    for m in (r for r in rows if r["row"] == "detect_mesh"):
        i = [r for r in img if r["skin"] == m["skin"]]
        if i:
            notes.append(f"{m['skin']}: mesh pipeline {m['ms_per_frame']:.3f} ms vs tactile image "
                         f"{i[0]['ms_per_frame']:.3f} ms per frame (x{i[0]['ms_per_frame'] / m['ms_per_frame']:.1f}); "
                         f"position error {m['pos_err_mm']:.2f} vs {i[0]['pos_err_mm']:.2f} mm.")
    write_table(out, rows, title="Edge filters: time and accuracy", notes=notes)

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6.5, 4.5))
    colours = {"mesh": "C0", "image": "C1", "subtaxel": "C2"}
    markers = {"seed002_planar": "o", "seed002_curved": "s"}
    for r in rows:
        method = r["row"].split("_", 1)[1] if r["row"].startswith("detect_") else ""
        if r["pos_err_mm"] == "" or method not in colours:
            continue
        ax.scatter(r["ms_per_frame"], r["pos_err_mm"], c=colours[method], marker=markers.get(r["skin"], "o"))
        ax.annotate(r["knob"], (r["ms_per_frame"], r["pos_err_mm"]), fontsize=6, xytext=(3, 3),
                    textcoords="offset points")
    for name, c in colours.items():
        ax.scatter([], [], c=c, label=name)
    for name, mk in markers.items():
        ax.scatter([], [], c="k", marker=mk, label=name)
    ax.legend(fontsize=7)
    log_time_axis(ax)
    ax.set_ylabel("edge position error, straight edges (mm)")
    ax.set_title("single frames: accuracy vs time (closed loop: vtcore bench control)")
    save_png(fig, out / "accuracy_vs_time.png")


def log_time_axis(ax) -> None:
    """A readable log x axis of milliseconds per frame (1, 2, 5 ticks)."""
    from matplotlib.ticker import FormatStrFormatter, LogLocator, NullFormatter

    ax.set_xscale("log")
    ax.xaxis.set_major_locator(LogLocator(base=10, subs=(1.0, 2.0, 5.0)))
    ax.xaxis.set_major_formatter(FormatStrFormatter("%g"))
    ax.xaxis.set_minor_formatter(NullFormatter())
    ax.set_xlabel("time per frame (ms)")
