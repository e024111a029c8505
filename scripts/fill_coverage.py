"""Fill on the meshes of docs/layout.md's coverage table, and the table and picture against the
hand-placed reference (issue 26).

    # the fill of whatever vtcore is on the path (run once with the old code for "before"):
    PYTHONPATH=. .venv/bin/python scripts/fill_coverage.py run --out docs/data/fill_after.json
    # the table (markdown, printed) and docs/img/layout_fill_real.png from the three files:
    PYTHONPATH=. .venv/bin/python scripts/fill_coverage.py table --before docs/data/fill_before.json \\
        --after docs/data/fill_after.json --hand docs/data/hand_reference.json

The meshes and regions are ``scripts/hand_reference.py``'s; each fill starts where a designer
would put the 3D cursor: the CAD link on its side, the hulls on their top face (the flange).
"""

from __future__ import annotations

import argparse
import json
import sys
import time
import warnings
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(Path(__file__).resolve().parent))

NAMES = {"cad_link_side": "CAD-like link, side (cadmeshes.cad_link)",
         "cad_hull": "200-triangle convex hull (cadmeshes.convex_hull_link)",
         "panda_link7_hull": "Panda link 7, collision hull (200 triangles)",
         "panda_hand_hull": "Panda hand, collision hull",
         "ur10_wrist3_hull": "UR10 wrist 3, collision hull",
         "panda_link7_visual": "Panda link 7, visual mesh (COLLADA)",
         "ur10_shoulder_visual": "UR10 shoulder, visual mesh (COLLADA)"}
#: visual meshes: filled before and after, no hand-placed reference (each of its tries is a place()
#: on a 10-15k-face mesh: hours on the shared machine)
VISUAL = {"panda_link7_visual": "panda_description/meshes/visual/link7.dae",
          "ur10_shoulder_visual": "ur_description/meshes/ur10/visual/shoulder.dae"}


def all_meshes():
    """name -> (mesh, region or None): hand_reference's meshes and the visual meshes above."""
    import sysconfig

    from hand_reference import meshes

    from vtcore.layout.meshinput import load_mesh

    out = meshes()
    robots = Path(sysconfig.get_paths()["purelib"]) / "cmeel.prefix/share/example-robot-data/robots"
    for name, rel in VISUAL.items():
        if (robots / rel).is_file():
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                out[name] = (load_mesh(robots / rel), None)
    return out


def start(name, mesh):
    if name == "cad_link_side":
        return np.array([0.036, 0.0, 0.0]), (0.0, 0.0, 1.0)
    return np.array([0.0, 0.0, float(mesh.bounds[1, 2])]), None


def run(out: Path, only=None):
    from vtcore.layout import fill

    res = json.loads(out.read_text()) if out.is_file() else {}
    for name, (mesh, region) in all_meshes().items():
        if only and name not in only:
            continue
        at, d = start(name, mesh)
        t0 = time.perf_counter()
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            try:
                lay, rep = fill(mesh, at, d, region=region)
                res[name] = {"modules": int(lay.n_modules), "coverage": float(rep.coverage),
                             "strain_max": float(rep.strain_max), "charts": int(rep.charts),
                             "seconds": time.perf_counter() - t0, "positions": np.round(lay.positions, 5).tolist(),
                             "module_ids": lay.module_ids.tolist()}
            except ValueError as exc:
                res[name] = {"modules": 0, "coverage": 0.0, "error": str(exc)[:200],
                             "seconds": time.perf_counter() - t0}
        print(name, {k: v for k, v in res[name].items() if k not in ("positions", "module_ids")}, flush=True)
        out.parent.mkdir(parents=True, exist_ok=True)
        out.write_text(json.dumps(res))


def table(before: Path, after: Path, hand: Path, png: Path):
    from vtcore.plots import pyplot

    b, a, h = (json.loads(p.read_text()) for p in (before, after, hand))
    rows = ["| mesh | by hand: modules, coverage | fill before: modules, coverage | fill now: modules, coverage, s |",
            "|---|---|---|---|"]
    for name in NAMES:
        if name not in a:
            continue
        cell = lambda r: "-" if r is None else (f"0 ({r['error'][:40]}...)" if r.get("error")  # noqa: E731
                                                 else f"{r['modules']}, {100 * r['coverage']:.0f} %")
        rows.append(f"| {NAMES[name]} | {cell(h.get(name))} | {cell(b.get(name))} | {cell(a.get(name))}, "
                    f"{a[name]['seconds']:.1f} |")
    print("\n".join(rows))
    plt = pyplot()
    ms = all_meshes()
    names = [n for n in NAMES if n in a and n in ms]
    fig = plt.figure(figsize=(10, 3.2 * len(names)))
    for i, name in enumerate(names):
        mesh = ms[name][0]
        for j, (title, r) in enumerate((("by hand", h.get(name)), ("fill before", b.get(name)),
                                        ("fill now", a.get(name)))):
            ax = fig.add_subplot(len(names), 3, 3 * i + j + 1, projection="3d", computed_zorder=False)
            v = np.asarray(mesh.vertices) * 1e3
            ax.plot_trisurf(v[:, 0], v[:, 1], v[:, 2], triangles=np.asarray(mesh.faces), color="0.85",
                            alpha=0.35, linewidth=0.1, edgecolor="0.6", zorder=1)
            n = 0
            if r and r.get("positions"):
                p = np.asarray(r["positions"]) * 1e3
                ax.scatter(*p.T, c=np.asarray(r["module_ids"]) % 10, cmap="tab10", s=4, depthshade=False, zorder=2)
                n = r["modules"]
            lo, hi = v.min(axis=0), v.max(axis=0)
            c, span = (lo + hi) / 2, (hi - lo).max() / 2
            ax.set_xlim(c[0] - span, c[0] + span)
            ax.set_ylim(c[1] - span, c[1] + span)
            ax.set_zlim(c[2] - span, c[2] + span)
            ax.set_box_aspect((1, 1, 1))
            ax.view_init(elev=28, azim=-55)
            ax.set_axis_off()
            cov = f", {100 * r['coverage']:.0f} %" if r and "coverage" in r else ""
            what = "not run" if r is None else f"{n} modules{cov}"  # no result is not 0 modules
            ax.set_title(f"{NAMES[name].split(',')[0]}\n{title}: {what}", fontsize=8)
    fig.tight_layout()
    fig.savefig(png, dpi=90)
    plt.close(fig)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    sub = ap.add_subparsers(dest="cmd", required=True)
    r = sub.add_parser("run")
    r.add_argument("--out", type=Path, required=True)
    r.add_argument("--only", nargs="+", help="these meshes only (merged into --out)")
    t = sub.add_parser("table")
    for k in ("before", "after", "hand"):
        t.add_argument(f"--{k}", type=Path, required=True)
    t.add_argument("--png", type=Path, default=ROOT / "docs" / "img" / "layout_fill_real.png")
    args = ap.parse_args(argv)
    if args.cmd == "run":
        run(args.out, args.only)
    else:
        table(args.before, args.after, args.hand, args.png)


if __name__ == "__main__":
    main()
