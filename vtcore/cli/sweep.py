"""``vtcore sweep SCENE.toml [--grid KEY=V1,V2 ...] [--seeds 1-8] --out DIR [--workers N | --scheduler ADDR]``."""

from __future__ import annotations

import shlex
import sys
from pathlib import Path

MAX_WORKERS = 1024  #: local worker processes (each is a Python process of its own)
MAX_RETRIES = 100   #: worker deaths one point may survive


def cmd_sweep(args) -> int:
    from ..inputs import to_int
    from ..sweep import plan_sweep, run_sweep

    if args.workers is not None:
        to_int(args.workers, lo=1, hi=MAX_WORKERS, key="--workers")
    to_int(args.retries, lo=0, hi=MAX_RETRIES, key="--retries")
    plan = plan_sweep(args.scene, args.grid, args.seeds, args.set)  # every point validated; nothing runs yet
    out = Path(args.out)
    where = args.scheduler or f"a local cluster of {args.workers or 'one worker per core'}"
    print(f"sweep: {len(plan.points)} point(s) of {plan.scene.name} on {where} -> {out}/", file=sys.stderr)
    command = shlex.join(["vtcore", "sweep", args.scene, *(f"--grid={g}" for g in args.grid),
                          *([f"--seeds={args.seeds}"] if args.seeds else []), *(f"--set={s}" for s in args.set),
                          "--out", args.out, *([f"--workers={args.workers}"] if args.workers else []),
                          *([f"--scheduler={args.scheduler}"] if args.scheduler else []),
                          *(["--resume"] if args.resume else [])])
    rows = run_sweep(plan, out, workers=args.workers, scheduler=args.scheduler, resume=args.resume,
                     retries=args.retries, command=command)
    counts = {}
    for r in rows:
        counts[r["status"]] = counts.get(r["status"], 0) + 1
    print(f"{len(rows)} points (" + ", ".join(f"{n} {s}" for s, n in sorted(counts.items()))
          + f") -> {out}/sweep.csv, {out}/report.md")
    return 0 if counts.get("ok", 0) == len(rows) else 1


def register(sub) -> None:
    p = sub.add_parser("sweep", help="run a scene over a grid of --set values and seeds (dask.distributed)")
    p.add_argument("scene", help="scene file (TOML); its [sweep] table gives the default grid and seeds")
    p.add_argument("--grid", action="append", default=[], metavar="KEY=V1,V2,...",
                   help="values of one --set key (repeatable: the points are the Cartesian product)")
    p.add_argument("--seeds", metavar="SEEDS", help="seeds of every grid point: 1-8, 1,3,5 or 1-4,9")
    p.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                   help="override a scene value at every point (repeatable)")
    p.add_argument("--out", required=True, help="output folder: one sub-folder per point, sweep.csv, report.md")
    where = p.add_mutually_exclusive_group()
    where.add_argument("--workers", type=int, metavar="N", help="local worker processes (default: one per core)")
    where.add_argument("--scheduler", metavar="tcp://HOST:PORT", help="a running dask scheduler to use instead")
    p.add_argument("--resume", action="store_true", help="skip points whose folder holds a finished run")
    p.add_argument("--retries", type=int, default=2, metavar="K",
                   help="worker deaths a point survives on the local cluster before it is recorded lost (default 2)")
    p.set_defaults(func=cmd_sweep)
