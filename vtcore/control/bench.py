"""``vtcore bench control``: closed-loop contour following, each method's error next to its time.

Seed 002 §5.2 in simulation, without the scene runner (control may import only
layout, contact and filters): for each of the four seed 002 setups (ruler / mug
x planar 20-taxel / curved 210-taxel skin) and each edge detector (``mesh``:
Eq. 6 on the skin mesh; ``image``: the tactile-image baseline; ``subtaxel``:
Eq. 6 on the Loop-subdivided mesh), one seeded run of the tapping loop with the
contact solver (``vtcore.contact.press``, 15 N through 6 mm of Ecoflex 00-50,
the contour scenes' cover), the sensor chain of the scenes (gain 0.1 counts/Pa,
20 counts of noise, 16-bit clip, integer counts) and, on the curved skin, the
filters working on taxel positions with a 1 mm error (seed 002's estimate).

Rows ``contour_<method>``: detection time per tap (ms; the filter, threshold,
components, Eq. 8, moments and centroid, not the contact solve) next to the
contour error d-bar and d_M (mm, seed 002 §6). The single-frame filter timings
and straight-edge accuracy are ``vtcore bench filters``. The scenes
``scenes/contour_*.toml`` give the three-run numbers.
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np

from .._bench import save_png, write_table

#: What this benchmark measures its error against (the closing note of ``vtcore bench`` lists it).
REFERENCE = "the object's true contour (seed 002's d-bar and d_M)"

SETUPS = (("seed002_planar", "ruler"), ("seed002_planar", "mug"),
          ("seed002_curved", "ruler"), ("seed002_curved", "mug"))
METHODS = ("mesh", "image", "subtaxel")


def _detector(method, mesh, flat):
    """The detectors with the contour scenes' settings (``vtcore/scene/tasks/contour.py`` defaults)."""
    from ..filters import ImageEdgeDetector, MeshEdgeDetector, SubtaxelEdgeDetector

    if method == "mesh":
        return MeshEdgeDetector(mesh, fraction=0.15)
    if method == "image":
        return ImageEdgeDetector(mesh.positions, mesh.triangles, flat, resolution=1e-3, sigma=1.5,
                                 low=0.1, high=0.2)
    return SubtaxelEdgeDetector(mesh, levels=2, fraction=0.1, centroid="curve", interpolate="log")


def follow(end_effector: str, obj: str, method: str, *, seed: int = 0, max_taps: int = 120,
           position_error: float | None = None, thickness: float = 6e-3, material: str = "ecoflex_00_50",
           force: float = 15.0, step: float = 5e-3) -> dict:
    """One seeded contour-following run; returns d-bar, d_M (mm), taps, ms per tap, stop reason.

    position_error : RMS error (m) of the taxel positions the robot believes (module
    model, ``taxel_position_error``); None: 1 mm on the curved skin (seed 002), 0 on
    the planar one.
    """
    from ..contact import SoftLayer, make_object, sensor
    from ..layout import skin_mesh
    from .contour import (ContourFollower, PressContact, believed_skin, control_skin, random_starts,
                          seed002_object, summarize, taxel_position_error)

    rng = np.random.default_rng(seed)
    _, layout, _ = control_skin(end_effector)
    if position_error is None:
        position_error = 1e-3 if end_effector == "seed002_curved" else 0.0
    belief = layout
    if position_error > 0:  # as the contour scenes: module misplacement, control frame from the belief
        layout, belief, _ = believed_skin(layout, taxel_position_error(layout, position_error, rng))
    mesh = skin_mesh(belief)
    det = _detector(method, mesh, belief.flat)
    contour, spec, world = seed002_object(obj)
    start = random_starts(contour, 1, rng, step=step)[0]
    layer = SoftLayer(thickness=thickness, material=material)
    press = PressContact(layout, make_object(spec[0], **spec[1]), world, layer, force=force)
    noise_rng = np.random.default_rng([seed, 1])

    def sense(pose):
        q = press(pose)
        if q is None:
            return None
        c = sensor.add_noise(sensor.gain(q, 0.1), 20.0, noise_rng)
        return sensor.quantise(sensor.saturate(c))

    stop = contour.explored(0.03) if obj == "ruler" else contour.explored(2 * np.pi)
    t0 = time.perf_counter()
    run = ContourFollower(det, step=step, max_taps=max_taps).run(sense, start, stop)
    seconds = time.perf_counter() - t0
    s = summarize([contour.distances(run.x_ref)])
    return {"d_mean_mm": s["d_mean"] * 1e3, "d_max_mm": s["d_max"] * 1e3, "taps": len(run),
            "ms_per_tap": 1e3 * run.seconds_detect / max(len(run), 1), "seconds": seconds,
            "stop": run.stop_reason, "taps_below_force": press.saturated}


def run(out: Path, quick: bool = False) -> list[dict]:
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    setups = SETUPS[:1] if quick else SETUPS
    rows = []
    for ee, obj in setups:
        for method in METHODS:
            r = follow(ee, obj, method, seed=2, max_taps=10 if quick else 120)
            rows.append({"row": f"contour_{method}", "skin": ee, "object": obj, "taps": r["taps"],
                         "ms_per_tap": r["ms_per_tap"], "d_mean_mm": r["d_mean_mm"], "d_max_mm": r["d_max_mm"],
                         "stop": r["stop"]})
    _write(out, rows)
    return rows


def _write(out: Path, rows: list[dict]) -> None:
    write_table(out, rows, title="Contour following: each method's error next to its time", notes=[
        "One seeded run per setup and method (seed 002 §5.2: 15 N, s = 5 mm; 6 mm Ecoflex 00-50 cover, "
        "an assumption: the paper gives none). ms_per_tap: edge detection only. Seed 002 Tables 1-2: "
        "d̄ 0.89-1.86 mm; Eq. 6 0.075 ms, tactile image 3.7 ms per frame."])

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from ..filters.bench import log_time_axis

    fig, ax = plt.subplots(figsize=(6.5, 4.5))
    colours = {"mesh": "C0", "image": "C1", "subtaxel": "C2"}
    for r in rows:
        m = r["row"].split("_", 1)[1]
        mk = "s" if "curved" in r["skin"] else "o"
        ax.scatter(r["ms_per_tap"], r["d_mean_mm"], c=colours[m], marker=mk)
        ax.annotate(f"{r['object']}, {r['skin'].split('_')[1]}", (r["ms_per_tap"], r["d_mean_mm"]), fontsize=6,
                    xytext=(3, 3), textcoords="offset points")
    for name, c in colours.items():
        ax.scatter([], [], c=c, label=name)
    ax.legend(fontsize=7)
    log_time_axis(ax)
    ax.set_xlabel("edge detection per tap (ms)")
    ax.set_ylabel("contour error d-bar, closed loop (mm)")
    ax.set_title("contour following: accuracy vs time (one run per setup)")
    save_png(fig, out / "accuracy_vs_time.png")
