"""``vtcore bench [NAME ...] --out DIR [--quick]``: benchmarks of time and accuracy side by side.

Every ``vtcore.<package>.bench`` module that defines ``run(out: Path, quick: bool)``
is a benchmark named after its package. Each writes its own table (Markdown and
CSV) and accuracy-vs-time plot into ``DIR/<name>/`` and returns the table rows;
this command writes ``DIR/README.md`` linking them.
"""

from __future__ import annotations

import importlib
import pkgutil
from pathlib import Path


def available() -> dict[str, str]:
    import vtcore

    out = {}
    for mod in pkgutil.iter_modules(vtcore.__path__):
        if mod.ispkg and importlib.util.find_spec(f"vtcore.{mod.name}.bench") is not None:
            out[mod.name] = f"vtcore.{mod.name}.bench"
    return dict(sorted(out.items()))


def cmd_bench(args) -> int:
    from ..errors import InputError

    benches = available()
    names = args.names or list(benches)
    for n in names:
        if n not in benches:
            raise InputError(f"unknown benchmark {n!r}; available: {', '.join(benches)}")
    out = Path(args.out)
    lines = ["# Benchmarks", "", "Each folder holds a table (`table.md`, `table.csv`) and a plot of accuracy against time.", ""]
    for n in names:
        module = importlib.import_module(benches[n])
        print(f"bench {n} ...", flush=True)
        module.run(out / n, quick=args.quick)
        lines.append(f"- [{n}]({n}/table.md)")
    out.mkdir(parents=True, exist_ok=True)
    (out / "README.md").write_text("\n".join(lines) + "\n", encoding="utf-8")
    print(f"benchmarks written to {out}/")
    return 0


def register(sub) -> None:
    p = sub.add_parser("bench", help="run benchmarks (time and accuracy side by side)")
    p.add_argument("names", nargs="*", help="benchmarks to run (default: all)")
    p.add_argument("--out", default="benchmarks/out", help="output folder")
    p.add_argument("--quick", action="store_true", help="small sizes, for a smoke run")
    p.set_defaults(func=cmd_bench)
