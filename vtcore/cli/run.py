"""``vtcore run SCENE.toml --out DIR [--set key=value ...]`` and ``vtcore scenes``."""

from __future__ import annotations

import sys
from pathlib import Path


def _scenes_dir() -> Path:
    """``scenes/`` of the repository (next to the ``vtcore`` package), or of the working folder."""
    here = Path(__file__).resolve().parents[2] / "scenes"
    return here if here.is_dir() else Path.cwd() / "scenes"


def cmd_run(args) -> int:
    from ..inputs import check_output_dir
    from ..scene import load_scene, run_scene

    out = Path(args.out) if args.out else Path("out") / Path(args.scene).stem
    if args.check:
        scene = load_scene(args.scene, args.set)
        check_output_dir(out)
        print(f"{args.scene}: valid scene ({scene.task}, {len(scene.effects)} effects); {out} can be written")
        return 0
    result = run_scene(args.scene, out, overrides=args.set)
    for w in result.get("warnings", []):  # numpy's and our own warnings inside the run, one line each
        count = f" ({w['count']} times)" if w["count"] > 1 else ""
        print(f"vtcore: warning: {args.scene}: {w['key']}: {w['message']}{count}", file=sys.stderr)
    metrics = result["metrics"]
    shown = ", ".join(f"{k}={v:.4g}" if isinstance(v, float) else f"{k}={v}" for k, v in list(metrics.items())[:6])
    print(f"{result['name']}: {result['seconds']:.2f} s -> {out}/result.json" + (f" ({shown})" if shown else ""))
    return 0


def cmd_scenes(args) -> int:
    from ..scene import list_scenes

    folder = Path(args.dir) if args.dir else _scenes_dir()
    rows = list_scenes(folder)
    width = max((len(p.stem) for p, _, _ in rows), default=0)
    twidth = max((len(t) for _, t, _ in rows), default=0)
    for path, task, desc in rows:
        print(f"{path.stem:<{width}}  {task:<{twidth}}  {desc.splitlines()[0] if desc else ''}")
    return 0


def register(sub) -> None:
    p = sub.add_parser("run", help="run a scene file and write its results")
    p.add_argument("scene", help="scene file (TOML)")
    p.add_argument("--out", help="output folder (default out/<scene name>)")
    p.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                   help="override a scene value, e.g. --set layer.thickness=0.006 (repeatable)")
    p.add_argument("--details", action="store_true",
                   help="after the one error line, list every problem of the scene and the warnings of the run")
    p.add_argument("--check", action="store_true",
                   help="validate the scene, its overrides and the output folder, then stop (nothing is written)")
    p.set_defaults(func=cmd_run)
    s = sub.add_parser("scenes", help="list the scenes in scenes/, one per line")
    s.add_argument("--dir", help="folder to list (default: the repository's scenes/)")
    s.set_defaults(func=cmd_scenes)
