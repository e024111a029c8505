"""Benchmark of the contact simulation: accuracy and time per frame side by side.

``vtcore bench contact --out DIR [--quick]``. A 30 mm sphere (20,480 triangles)
slides across seed 002's non-planar patch (210 taxels) through 3 mm of
Ecoflex 00-20 at a fixed pose-driven indentation of 1 mm, one frame per pose,
each frame warm-started from the previous one (best of 3 runs). For every model x grid spacing
x samples per taxel: the relative L2 error of the taxel readings against a
converged finite-layer reference (a 327,680-face sphere, 0.25 mm grid, 19 samples: none of the
rows) at the same poses, and
the wall time per frame (proximity + contact solve + spreading + sampling).
Plus one row of the local model on a 4,000-taxel flat patch.
"""

from __future__ import annotations

import os
import time
from pathlib import Path

import numpy as np

from .._bench import save_png, write_table
from .materials import SoftLayer
from .objects import make_object
from .press import ContactGrid, press_sequence

#: What this benchmark measures its error against (the closing note of ``vtcore bench`` lists it).
REFERENCE = ("a converged finite-layer run on a sphere of 16x the faces and a finer grid (none of the rows); "
             "in peers.md the half-space against Hertz and the solver against tamaas and ContactMechanics")


def _trajectory(layout, mesh, layer, frames):
    """Poses of the sphere sliding 10 mm along x across the patch's top, 1 mm into the layer."""
    from .objects import placement_pose

    top = float((layout.positions[:, 2] + layer.thickness * layout.normals[:, 2]).max())
    c = layout.positions[np.argmax(layout.positions[:, 2])]
    base = placement_pose(mesh, xy=(c[0], c[1]), top=top, gap=-1e-3)
    poses = np.repeat(base[None], frames, axis=0)
    poses[:, 0, 3] += np.linspace(-5e-3, 5e-3, frames)
    return poses


def _time_run(layout, mesh, poses, layer, repeat=3, **kw):
    """Readings (T, N), wall and CPU seconds per frame: the best of ``repeat`` runs of the whole
    trajectory (the machine is shared; the minimum is the least disturbed estimate). CPU time is
    the process's (all its threads), so it shows the work done whatever the machine's load."""
    press_sequence(layout, mesh, poses[:1], layer, **kw)  # builds and caches kernels, not timed
    best, best_cpu = np.inf, np.inf
    for _ in range(repeat):
        t0, c0 = time.perf_counter(), time.process_time()
        res = press_sequence(layout, mesh, poses, layer, **kw)
        best = min(best, (time.perf_counter() - t0) / len(poses))
        best_cpu = min(best_cpu, (time.process_time() - c0) / len(poses))
    return np.array([r.pressure for r in res]), best, best_cpu


def _big_skin_row(mesh, layer, frames, rep) -> dict:
    """The local model on a large skin (4,096 taxels on a flat 64 x 64 lattice, 2 mm grid), its error
    against the finite layer at 1 mm on the same skin."""
    from ..layout import Layout

    i, j = np.meshgrid(np.arange(64), np.arange(64), indexing="ij")
    pos = np.column_stack([(i.ravel() - 31.5) * 4e-3, (j.ravel() - 31.5) * 4e-3, np.zeros(i.size)])
    big = Layout(pos, np.tile([0, 0, 1.0], (len(pos), 1)), np.arange(len(pos)), np.zeros(len(pos), int))
    bp = _trajectory(big, mesh, layer, frames)
    ref, _, _ = _time_run(big, mesh, bp, layer, repeat=1, model="finite_layer", grid=ContactGrid(spacing=1e-3),
                          samples_per_taxel=1)
    p, dt, cpu = _time_run(big, mesh, bp, layer, repeat=rep, model="local", grid=ContactGrid(spacing=2e-3),
                           samples_per_taxel=1)
    err = float(np.mean(np.linalg.norm(p - ref, axis=1) / np.maximum(np.linalg.norm(ref, axis=1), 1e-12)))
    return {"model": "local", "taxels": len(big), "triangles": len(mesh.faces), "grid_mm": 2.0, "samples": 1,
            "error": err, "ms_per_frame": dt * 1e3, "cpu_ms_per_frame": cpu * 1e3, "frames_per_s": 1.0 / dt}


def run(out: Path, quick: bool = False, peers: bool = False) -> list[dict]:
    """Run the benchmark, write ``table.md``, ``table.csv``, ``accuracy_vs_time.png`` into ``out``, and
    the solver side by side (:mod:`vtcore.contact.peers`: ``peers.md``, ``time_vs_n.png``), the layer
    models against the finite-element reference (:mod:`vtcore.contact.layer_bench`: ``layer/``); with
    ``peers=True`` tamaas and ContactMechanics run beside vtcore in a throwaway venv under ``out``."""
    from .layer_bench import run as run_layer
    from .peers import run as run_peers

    run_peers(Path(out), quick=quick, peers=peers)
    run_layer(Path(out) / "layer", quick=quick)  # the layer models against the finite-element reference
    from ..layout import seed002_curved

    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    load0 = os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")
    _, layout = seed002_curved()
    layer = SoftLayer(thickness=3e-3)
    mesh = make_object("sphere", subdivisions=3 if quick else 5)
    frames = 3 if quick else 10
    poses = _trajectory(layout, mesh, layer, frames)
    # The reference is no row: a converged run on a near-smooth sphere (4x and 16x as many faces as
    # the rows' mesh, facets 0.5 / 0.25 mm, narrower than its grid's cells x 2) on a grid finer than
    # every row's, so each row's error is its grid's, its sampling's and its mesh's facets' together.
    ref_mesh = make_object("sphere", subdivisions=6 if quick else 7)
    ref_grid, ref_samples = (0.5e-3, 7) if quick else (0.25e-3, 19)
    rep = 1 if quick else 3
    ref, ref_dt, ref_cpu = _time_run(layout, ref_mesh, poses, layer, repeat=1, model="finite_layer",
                                     grid=ContactGrid(spacing=ref_grid), samples_per_taxel=ref_samples)
    norm = np.linalg.norm(ref, axis=1)
    models = ("local", "finite_layer") if quick else ("local", "halfspace", "finite_layer")
    grids = (2e-3, 1e-3, 0.75e-3) if quick else (2e-3, 1e-3, 0.5e-3)
    samples = (1, 7) if quick else (1, 7, 19)
    rows = []
    for model in models:
        for g in grids:
            for s in samples:
                p, dt, cpu = _time_run(layout, mesh, poses, layer, repeat=rep, model=model, grid=ContactGrid(spacing=g),
                                  samples_per_taxel=s)
                err = float(np.mean(np.linalg.norm(p - ref, axis=1) / np.maximum(norm, 1e-12)))
                rows.append({"model": model, "taxels": len(layout), "triangles": len(mesh.faces),
                             "grid_mm": g * 1e3, "samples": s, "error": err, "ms_per_frame": dt * 1e3,
                             "cpu_ms_per_frame": cpu * 1e3, "frames_per_s": 1.0 / dt})
    rows.append({"model": "finite_layer (reference)", "taxels": len(layout), "triangles": len(ref_mesh.faces),
                 "grid_mm": ref_grid * 1e3, "samples": ref_samples, "error": float("nan"),
                 "ms_per_frame": ref_dt * 1e3, "cpu_ms_per_frame": ref_cpu * 1e3, "frames_per_s": 1.0 / ref_dt})
    if not quick:
        rows.append(_big_skin_row(mesh, layer, frames, rep))

    load = (load0, os.getloadavg()[0]) if hasattr(os, "getloadavg") else (float("nan"),) * 2
    write_table(out, rows, title=f"Contact benchmark ({'quick' if quick else 'full'})", notes=[
        f"Sphere r 30 mm sliding over {len(layout)} taxels through 3 mm Ecoflex 00-20, {frames} warm-started "
        f"frames; error = mean relative L2 error of the taxel readings vs a converged finite-layer run on a "
        f"finer mesh ({len(ref_mesh.faces):,} faces against the rows' {len(mesh.faces):,}) at {ref_grid * 1e3:g} mm, "
        f"{ref_samples} samples (a reference that is none of the rows; its own row has no error). The 4,096-taxel "
        "local row's error is against the finite layer at 1 mm on the same flat skin. The finite layer against "
        "analytic solutions and other solvers: `peers.md` (Hertz for the half-space). "
        f"Times: best of {rep} runs, wall and process CPU per frame; "
        f"load average {load[0]:.1f} / {load[1]:.1f} before / after."])
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6.4, 4.2))
    for k, model in enumerate(models):
        sel = [r for r in rows if r["model"] == model and r["taxels"] == len(layout) and np.isfinite(r["error"])]
        ax.plot([r["ms_per_frame"] for r in sel], [max(r["error"], 1e-6) for r in sel], "o-", label=model,
                   color=f"C{k}")
        for r in sel:
            ax.annotate(f"{r['grid_mm']:g}/{r['samples']}", (r["ms_per_frame"], max(r["error"], 1e-6)),
                        fontsize=6)
    ax.axvline(50, color="0.6", ls="--", lw=0.8)
    ax.text(50, ax.get_ylim()[1] if ax.get_ylim()[1] > 0 else 1, " 20 Hz", fontsize=7, va="top")
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("time per frame (ms)")
    ax.set_ylabel("relative error vs converged finite layer (finer mesh and grid)")
    ax.set_title("contact: accuracy vs time (labels: grid mm / samples per taxel)")
    ax.legend()
    save_png(fig, out / "accuracy_vs_time.png")
    return rows
