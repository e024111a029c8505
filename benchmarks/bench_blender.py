"""Performance of the Blender add-on (bpy 4.5 wheel, headless), with the check that
each timed step produced the right data, side by side.

    .venv/bin/python benchmarks/bench_blender.py --out benchmarks/out/blender [--quick]

Writes ``table.md``, ``table.csv`` and ``accuracy_vs_time.png``. Goals (issue 7):
writing a 4,000-taxel frame to attributes <= 20 ms; laying a hexagonal patch on a
50k-face mesh <= 0.5 s; playback of a baked 1,000-frame contact >= 60 frames/s.
Issue 19: a 4,000-taxel, 1,000-row recording loaded (``vtskin.load_recording``) and
played back at >= 60 frames/s (``--only replay`` runs just those rows).
Issue 29: live touch on a 1,000-taxel skin, >= 30 updates/s with the local layer and >= 10 with
the finite layer (``--only live``).
Measured, not asserted.
"""

from __future__ import annotations

import argparse
import csv
import io
import os
import sys
import time
import warnings
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))


def _median_time(fn, reps):
    ts = []
    for _ in range(reps):
        t = time.perf_counter()
        fn()
        ts.append(time.perf_counter() - t)
    return float(np.median(ts))


def bench_frame_write(n, reps):
    import bpy

    from addon import bridge, display, skin
    from vtcore.layout import Layout

    rng = np.random.default_rng(0)
    ob = skin.new_object(bpy.context, f"bench {n}")
    pos = rng.normal(size=(n, 3)) * 0.05
    skin.write_layout(ob, Layout(pos, np.tile([0, 0, 1.0], (n, 1)), np.arange(n), np.zeros(n)))
    display.ensure_display(ob)
    frame = rng.uniform(0, 65535, n)
    t = _median_time(lambda: bridge.set_attribute(ob.data, "response", frame), reps)
    err = float(np.abs(bridge.get_attribute(ob.data, "response") - frame.astype(np.float32)).max())
    rows = [{"case": f"write a {n}-taxel frame (response attribute)", "seconds": t, "goal": "<= 0.020 s",
             "met": t <= 0.020, "accuracy": f"max abs(read - written) = {err:g} (float32)",
             "short": f"write {n}-taxel frame"}]
    # With the disc display re-evaluated (what the viewport does after the write).
    dg = bpy.context.evaluated_depsgraph_get()

    def write_and_eval():
        bridge.set_attribute(ob.data, "response", frame)
        dg.update()

    t2 = _median_time(write_and_eval, max(3, reps // 5))
    rows.append({"case": f"write a {n}-taxel frame + evaluate the disc display", "seconds": t2,
                 "goal": "(context)", "met": None, "accuracy": "same data", "short": "write + evaluate discs"})
    return rows, ob


def bench_lay_patch(segments, rings, solve_faces=20000):
    import bpy

    from addon import skin

    bpy.context.scene.vtskin.solve_faces = solve_faces
    bpy.ops.mesh.primitive_uv_sphere_add(segments=segments, ring_count=rings, radius=0.06)
    ee = bpy.context.active_object
    faces = len(ee.data.polygons)
    ee.data.calc_loop_triangles()
    faces = f"{faces}-face ({len(ee.data.loop_triangles)} triangles)"
    bpy.context.scene.cursor.location = (0.0, 0.0, 0.06)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        t = time.perf_counter()
        res = bpy.ops.vtskin.lay_patch()
        seconds = time.perf_counter() - t
    assert res == {"FINISHED"}
    ob = next(o for o in bpy.data.objects if skin.is_taxels(o) and o.vtskin.end_effector == ee)
    co = np.empty(3 * len(ob.data.vertices), np.float32)
    ob.data.vertices.foreach_get("co", co)
    r = np.linalg.norm(co.reshape(-1, 3), axis=1)
    acc = (f"{len(r)} taxels, max strain {ob.vtskin.strain_max:.2f} %, "
           f"max distance off the sphere {np.abs(r - 0.06).max() * 1e3:.3f} mm")
    return [{"case": f"lay a hexagonal patch on a {faces} mesh (operator, end to end; solve faces {solve_faces})",
             "seconds": seconds, "goal": "<= 0.5 s", "met": seconds <= 0.5, "accuracy": acc,
             "short": f"lay hexagon, 50k tris, solve {solve_faces or 'full'}", "strain_pct": ob.vtskin.strain_max,
             "solve": solve_faces}]


def bench_playback(n, frames, with_display):
    import bpy

    from addon import bake, bridge, display, skin
    from vtcore.layout import Layout

    rng = np.random.default_rng(1)
    ob = skin.new_object(bpy.context, f"playback {n}")
    skin.write_layout(ob, Layout(rng.normal(size=(n, 3)) * 0.05, np.tile([0, 0, 1.0], (n, 1)), np.arange(n),
                                 np.zeros(n)))
    if with_display:
        display.ensure_display(ob)
    # Synthetic baked values: playback cost does not depend on them.
    resp = rng.uniform(0, 1000, (frames, n)).astype(np.float32)
    t = time.perf_counter()
    bake.store(ob, np.arange(1, frames + 1), pressure=resp * 10, response=resp, edge=resp > 900)
    store_s = time.perf_counter() - t
    scene = bpy.context.scene
    scene.frame_start, scene.frame_end = 1, frames
    scene.frame_set(1)
    t = time.perf_counter()
    for f in range(1, frames + 1):
        scene.frame_set(f)
    seconds = time.perf_counter() - t
    fps = frames / seconds
    got = bridge.get_attribute(ob.data, "response")
    err = float(np.abs(got - resp[-1]).max())
    ob.hide_viewport = True
    label = "with disc display" if with_display else "attributes only"
    return [{"case": f"play back {frames} baked frames of {n} taxels ({label})", "seconds": seconds,
             "goal": ">= 60 frames/s", "met": fps >= 60,
             "accuracy": f"{fps:.0f} frames/s; last frame max error {err:g}; bake store {store_s:.2f} s",
             "short": f"play {frames} frames, {n} taxels" + (", discs" if with_display else "")}]


def live_skin(modules=100):
    """A flat skin of ``modules`` whole CySkin modules (10 taxels each) and its skin mesh."""
    from vtcore.layout import fill_patch, skin_mesh

    side = 0.03 * np.sqrt(modules)
    p = fill_patch("cyskin10", lambda xy: np.ones(len(xy), bool), [-side, -side], [side, side], angles=(0.0,),
                   offsets=1)
    keep = np.argsort(np.linalg.norm(p.poses[:, 1:], axis=1))[:modules]
    p = p.select_modules(np.isin(np.arange(p.n_modules), keep))
    lay = p.flat_layout()
    return lay, skin_mesh(lay).triangles


def bench_live_touch(model, moves, modules=100):
    """Live touch, headless: the indenter moved ``moves`` times over a 1,000-taxel skin, the view layer
    updated after each move (background mode solves and writes in the handler), against the goal
    (>= 30 updates/s with the local layer, >= 10 with the finite layer); the last frame checked against
    vtcore.scene.interactive.simulate at that pose."""
    import bpy

    from addon import bridge, skin
    from vtcore.contact import make_object, placement_pose
    from vtcore.scene import interactive

    bpy.ops.wm.read_factory_settings(use_empty=True)
    lay, tri = live_skin(modules)
    ob = skin.new_object(bpy.context, "live skin")
    skin.write_layout(ob, lay, tri)
    sph = make_object("sphere", radius=0.01)
    me = bpy.data.meshes.new("finger")
    bridge.write_mesh(me, sph.vertices, sph.faces)
    ind = bpy.data.objects.new("finger", me)
    bpy.context.scene.collection.objects.link(ind)
    path = np.linspace(-0.04, 0.04, moves)
    pose = placement_pose(sph, xy=(path[0], 0.0), top=0.003, gap=0.001)
    ind.matrix_world = bridge.to_matrix(pose)
    s = bpy.context.scene.vtskin
    s.indenter, s.thickness, s.force, s.use_force, s.live_model = ind, 0.003, 2.0, True, model
    bpy.context.view_layer.objects.active = ob
    s.live_touch = True  # builds the solver and answers the first pose (not timed)
    t = time.perf_counter()
    c0 = time.process_time()
    for x in path[1:]:
        ind.location.x = float(x)
        bpy.context.view_layer.update()
    seconds = time.perf_counter() - t
    cpu = time.process_time() - c0
    s.live_touch = False
    rate = (moves - 1) / seconds
    pose = placement_pose(sph, xy=(path[-1], 0.0), top=0.003, gap=0.001)
    ref = interactive.simulate(lay, tri, sph.vertices, sph.faces, pose, thickness=0.003, force=2.0, model=model)
    got = bridge.get_attribute(ob.data, "pressure")
    err = float(np.abs(got - ref.pressure).max() / max(ref.pressure.max(), 1e-300))
    goal = 30 if model == "local" else 10
    name = "local layer" if model == "local" else "finite layer"
    return [{"case": f"live touch, {len(lay)}-taxel skin, {name}: {moves - 1} indenter moves, view layer updated "
                     f"after each (load {os.getloadavg()[0]:.1f})",
             "seconds": seconds / (moves - 1), "goal": f">= {goal} updates/s", "met": rate >= goal,
             "accuracy": f"{rate:.0f} updates/s ({(moves - 1) / cpu:.0f} per CPU s); last frame vs Simulate at "
                         f"that pose: max pressure difference {err:.1e} of the peak",
             "short": f"live touch, {name}"}]


def replay_skin(n):
    """A flat skin of ``n`` taxels (4 mm pitch grid, Delaunay skin mesh) with CySkin UIDs
    ``module << 4 | sensor`` (10 sensors a module)."""
    import bpy
    from scipy.spatial import Delaunay

    from addon import skin
    from vtcore.layout import Layout

    side = int(np.ceil(np.sqrt(n)))
    g = np.stack(np.meshgrid(np.arange(side), np.arange(side)), -1).reshape(-1, 2)[:n] * 4e-3
    pos = np.column_stack([g, np.zeros(n)])
    ids = ((np.arange(n) // 10 + 1) << 4) | (np.arange(n) % 10 + 1)
    ob = skin.new_object(bpy.context, f"replay {n}")
    skin.write_layout(ob, Layout(pos, np.tile([0, 0, 1.0], (n, 1)), ids, np.arange(n) // 10 + 1),
                      Delaunay(g).simplices)
    return ob, ids


def bench_replay(n, frames, with_display, folder: Path):
    """Load a CySkin text recording of ``frames`` rows x ``n`` taxels (a pressed spot moving over
    the skin) with the operator, then play every frame."""
    import resource

    import bpy

    from addon import bridge, display

    rng = np.random.default_rng(2)
    ob, ids = replay_skin(n)
    bpy.context.view_layer.objects.active = ob
    # frames x taxels: a Gaussian spot sliding along the grid, on top of noise
    idx = np.arange(n)
    centre = np.linspace(0, n - 1, frames)
    vals = np.rint(800 * np.exp(-0.5 * ((idx[None, :] - centre[:, None]) / 30.0) ** 2)
                   + rng.uniform(0, 20, (frames, n))).astype(np.int64)
    path = folder / f"replay_{n}x{frames}.txt"
    if not path.exists():
        body = np.column_stack([np.arange(frames), np.arange(frames) / 100.0, vals])
        with open(path, "w") as fh:
            fh.write(" ".join(map(str, ids)) + "\n")
            np.savetxt(fh, body, fmt=["%d", "%.3f"] + ["%d"] * n)
    scene = bpy.context.scene
    scene.frame_start = 1
    s = scene.vtskin
    s.replay_rate = "RECORDING"
    rss0 = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    t = time.perf_counter()
    res = bpy.ops.vtskin.load_recording(filepath=str(path), codec="cyskin-txt")
    load_s = time.perf_counter() - t
    rss = (resource.getrusage(resource.RUSAGE_SELF).ru_maxrss - rss0) / 1024
    assert res == {"FINISHED"}
    sizes = []
    if not with_display:  # what the cache costs on disk, plain and compressed
        for compress in (False, True):
            blend = folder / f"replay_{compress}.blend"
            bpy.ops.wm.save_as_mainfile(filepath=str(blend), copy=True, compress=compress)
            sizes.append(blend.stat().st_size / 2**20)
            blend.unlink()
    if not with_display:  # the operator adds the disc display; measure the attribute copy alone
        ob.modifiers.remove(ob.modifiers[display.MODIFIER])
    scene.frame_set(1)
    t, cpu = time.perf_counter(), time.process_time()
    for f in range(1, frames + 1):
        scene.frame_set(f)
    seconds = time.perf_counter() - t
    cpu_fps = frames / (time.process_time() - cpu)
    fps = frames / seconds
    err = float(np.abs(bridge.get_attribute(ob.data, "response") - vals[-1]).max())
    bpy.data.objects.remove(ob)  # the playback handler would go on updating it
    label = "with disc display" if with_display else "attributes only"
    rows = [{"case": f"load a {frames}-row recording of {n} taxels (operator, end to end: read, baseline, "
                     f"edge filter, cache)", "seconds": load_s, "goal": "(context)", "met": None,
             "accuracy": f"peak RSS grew {rss:.0f} MB; .blend {sizes[0]:.0f} MB, saved compressed "
                         f"{sizes[1]:.0f} MB", "short": f"load recording {n}x{frames}"}] if not with_display else []
    rows.append({"case": f"play back a {frames}-frame recording of {n} taxels ({label}; response, compensated, "
                         "edge, held)", "seconds": seconds, "goal": ">= 60 frames/s", "met": fps >= 60,
                 "accuracy": f"{fps:.0f} frames/s ({cpu_fps:.0f} per CPU second of this process); last frame "
                             f"max error vs the file {err:g}",
                 "short": f"replay {frames} frames, {n} taxels" + (", discs" if with_display else "")})
    return rows


def run(out: Path, quick: bool = False, only: str = "") -> list[dict]:
    import bpy

    from tests.blender.bl_helpers import register_addon

    addon = register_addon()
    try:
        bpy.ops.wm.read_factory_settings(use_empty=True)
        out.mkdir(parents=True, exist_ok=True)
        rows = []
        frames = 100 if quick else 1000
        if only == "replay":
            for display_on in (False, True):
                rows += bench_replay(4000, frames, display_on, out)
            write(out, rows)
            return rows
        if only == "live":
            for model in ("local", "finite_layer"):
                rows += bench_live_touch(model, 31 if quick else 121)
            write(out, rows)
            return rows
        r, _ = bench_frame_write(4000, 20 if quick else 100)
        rows += r
        bench_lay_patch(32, 16)  # warm-up: first-use imports are not part of a placement
        for solve in (20000, 5000, 2000, 0):  # 0: full mesh, what the extension does without open3d
            rows += bench_lay_patch(256, 100, solve) if not quick else bench_lay_patch(64, 32, solve)
        rows += bench_playback(60, frames, True)
        rows += bench_playback(4000, frames, False)
        rows += bench_playback(4000, frames, True)
        for display_on in (False, True):
            rows += bench_replay(4000, frames, display_on, out)
        for model in ("local", "finite_layer"):
            rows += bench_live_touch(model, 31 if quick else 121)
        write(out, rows)
        return rows
    finally:
        addon.unregister()


def write(out: Path, rows):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from vtcore._io import atomic_write

    out.mkdir(parents=True, exist_ok=True)
    lines = ["| case | seconds | goal | met | check |", "|---|---|---|---|---|"]
    for r in rows:
        met = "" if r["met"] is None else ("yes" if r["met"] else "**no**")
        lines.append(f"| {r['case']} | {r['seconds']:.3g} | {r['goal']} | {met} | {r['accuracy']} |")
    with atomic_write(out / "table.md", "w", encoding="utf-8") as fh:
        fh.write("\n".join(lines) + "\n")
    buf = io.StringIO()
    w = csv.DictWriter(buf, fieldnames=["case", "seconds", "goal", "met", "accuracy"], extrasaction="ignore")
    w.writeheader()
    w.writerows(rows)
    with atomic_write(out / "table.csv", "w", encoding="utf-8") as fh:
        fh.write(buf.getvalue())
    fig, (ax, ax2) = plt.subplots(1, 2, figsize=(10, 4), gridspec_kw={"width_ratios": [1.6, 1]})
    colours = ["tab:green" if r["met"] else ("0.6" if r["met"] is None else "tab:red") for r in rows]
    ax.barh(range(len(rows)), [r["seconds"] for r in rows], color=colours)
    ax.set_yticks(range(len(rows)), [r.get("short", r["case"]) for r in rows], fontsize=7.5)
    ax.set_xscale("log")
    for goal, label in ((0.020, "20 ms"), (0.5, "0.5 s")):
        ax.axvline(goal, color="0.3", lw=0.8, ls=":")
        ax.text(goal, -0.7, label, fontsize=7, ha="center")
    ax.set_xlabel("seconds (log); green: goal met, red: missed, grey: context")
    ax.invert_yaxis()
    ax.set_title("time per step (playback: 1000 frames)", fontsize=9)
    lay = [r for r in rows if "strain_pct" in r]
    ax2.plot([r["seconds"] for r in lay], [r["strain_pct"] for r in lay], "o-")
    for r in lay:
        ax2.annotate(f"solve {r['solve'] or 'full'}", (r["seconds"], r["strain_pct"]), fontsize=7,
                     xytext=(4, 4), textcoords="offset points")
    ax2.axvline(0.5, color="0.3", lw=0.8, ls=":")
    ax2.set_xlabel("seconds to lay a hexagon (50k-triangle sphere)")
    ax2.set_ylabel("max module strain reported (%)")
    ax2.set_title("placement: accuracy knob vs time", fontsize=9)
    fig.suptitle("vtskin add-on, bpy 4.5 headless", fontsize=10)
    fig.tight_layout()
    with atomic_write(out / "accuracy_vs_time.png", "wb") as fh:
        fig.savefig(fh, format="png", dpi=120)
    plt.close(fig)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--out", default=str(ROOT / "benchmarks" / "out" / "blender"))
    ap.add_argument("--quick", action="store_true")
    ap.add_argument("--only", choices=("replay", "live"), default="", help="run only these rows")
    args = ap.parse_args()
    rows = run(Path(args.out), args.quick, args.only)
    for r in rows:
        print(f"{r['seconds']:9.3g} s  {r['case']}  [{r['goal']}]  {r['accuracy']}")
    sys.stdout.flush()
    os._exit(0)  # skip bpy's slow teardown


if __name__ == "__main__":
    main()
