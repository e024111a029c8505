"""``vtcore bench [NAME ...] --out DIR [--quick] [--with DIR ...]``: benchmarks of time and accuracy side by side.

Every ``vtcore.<package>.bench`` module that defines ``run(out: Path, quick: bool)``
is a benchmark named after its package. Each writes its own table (``table.md``
with the paper numbers it is measured against, ``table.csv``) and an
accuracy-vs-time plot into ``DIR/<name>/``; this command then writes one
``DIR/README.md`` that puts every table and plot on one page. ``--with`` adds a
folder some other benchmark wrote the same three files into (the Blender
benchmark, ``benchmarks/bench_blender.py``, which needs ``bpy`` and so is not
part of ``vtcore``).
"""

from __future__ import annotations

import importlib
import inspect
import os
import pkgutil
import time
from pathlib import Path

TABLE = "table.md"
PLOT = "accuracy_vs_time.png"


def available() -> dict[str, str]:
    """Benchmark name -> module (``{"layout": "vtcore.layout.bench", ...}``), sorted by name.

    A package's ``bench`` module counts only if it defines ``run``: this very
    module is ``vtcore.cli.bench`` and is the command, not a benchmark.
    """
    import vtcore

    out = {}
    for mod in pkgutil.iter_modules(vtcore.__path__):
        name = f"vtcore.{mod.name}.bench"
        if not mod.ispkg or importlib.util.find_spec(name) is None:
            continue
        if callable(getattr(importlib.import_module(name), "run", None)):
            out[mod.name] = name
    return dict(sorted(out.items()))


def section(folder: Path, name: str, link: str, seconds: float | None = None) -> list[str]:
    """The report lines for one benchmark folder: its table (title demoted a level) and its plot.

    ``folder`` holds ``table.md`` and ``accuracy_vs_time.png``; ``link`` is the
    folder relative to the report (``"layout"``, ``"blender"``). A missing table
    is said, not skipped, so a broken benchmark shows in the report.
    """
    lines = [f"## {name}", ""]
    if seconds is not None:
        lines += [f"Ran in {seconds:.1f} s (whole benchmark, wall clock).", ""]
    table = folder / TABLE
    if not table.is_file():
        return lines + [f"No `{TABLE}` in `{folder}`.", ""]
    for line in table.read_text(encoding="utf-8").splitlines():
        # The table's own headings go two levels down, under this section's.
        lines.append("##" + line if line.startswith("#") else line)
    lines.append("")
    if (folder / PLOT).is_file():
        lines += [f"![{name}: accuracy against time]({link}/{PLOT})", ""]
    return lines


def closing_note(references: dict[str, str]) -> list[str]:
    """The report's last section: what each area's error is measured against (its bench module's
    ``REFERENCE``); an area that names none is said to."""
    lines = ["## What each area's error is measured against", ""]
    lines += [f"- **{n}**: {ref or 'no reference named (its bench module has no REFERENCE)'}"
              for n, ref in references.items()]
    return lines + [""]


def write_report(out: Path, sections: list[list[str]], quick: bool, references: dict[str, str] | None = None) -> Path:
    """Write ``out/README.md`` from the sections (atomically), closing with what each area's error is
    measured against (``references``: area -> its REFERENCE); return its path."""
    from .._io import atomic_write

    head = ["# Benchmarks", "",
            f"{'Quick (small sizes, a smoke run)' if quick else 'Full'} run. Each section is one area: "
            "its table of time next to accuracy, the paper numbers it is measured against "
            "(in the notes above each table) and its accuracy-vs-time plot. "
            "Each folder also holds the table as CSV.", "",
            "Areas: " + ", ".join(f"[{s[0][3:]}](#{s[0][3:].lower()})" for s in sections) + ".", ""]
    out.mkdir(parents=True, exist_ok=True)
    path = out / "README.md"
    with atomic_write(path, "w", encoding="utf-8") as fh:
        tail = closing_note(references) if references else []
        fh.write("\n".join(head + [ln for s in sections for ln in s] + tail).rstrip("\n") + "\n")
    return path


def cmd_bench(args) -> int:
    from ..errors import InputError

    benches = available()
    names = args.names or list(benches)
    for n in names:
        if n not in benches:
            raise InputError(f"unknown benchmark {n!r}; available: {', '.join(benches)}")
    extra = [Path(d) for d in args.with_dirs]
    for d in extra:
        if not (d / TABLE).is_file():
            raise InputError(f"--with {d}: no {TABLE} there (run that benchmark first)")
    out = Path(args.out)
    sections, references = [], {}
    for n in names:
        module = importlib.import_module(benches[n])
        references[n] = getattr(module, "REFERENCE", None)
        print(f"bench {n} ...", flush=True)
        t0 = time.perf_counter()
        # --peers goes only to the benchmarks that run other solvers side by side (contact)
        params = inspect.signature(module.run).parameters
        extra_kw = {"peers": True} if args.peers and "peers" in params else {}
        if args.cases and "cases" in params:  # the benchmarks that run their rows in groups (layout, robot)
            extra_kw["cases"] = args.cases
        module.run(out / n, quick=args.quick, **extra_kw)
        sections.append(section(out / n, n, n, time.perf_counter() - t0))
    for d in extra:
        # Linked relative to the report, wherever the folder is.
        rel = Path(os.path.relpath(d.resolve(), out.resolve())).as_posix()
        sections.append(section(d, d.name, rel))
    path = write_report(out, sections, args.quick, references)
    print(f"benchmarks written to {out}/ (report: {path})")
    return 0


def register(sub) -> None:
    p = sub.add_parser("bench", help="run benchmarks (time and accuracy side by side)")
    p.add_argument("names", nargs="*", help="benchmarks to run (default: all)")
    p.add_argument("--out", default="benchmarks/out", help="output folder")
    p.add_argument("--quick", action="store_true", help="small sizes, for a smoke run")
    p.add_argument("--with", dest="with_dirs", action="append", default=[], metavar="DIR",
                   help="also report the table and plot another benchmark wrote into DIR "
                        "(e.g. benchmarks/bench_blender.py's folder)")
    p.add_argument("--peers", action="store_true",
                   help="contact: also run tamaas and ContactMechanics on the same problems, in a throwaway "
                        "venv created under the output folder (needs the package index)")
    p.add_argument("--cases", default=None, metavar="PATTERNS",
                   help="layout, robot: only the groups of rows whose case matches one of these comma-separated "
                        "patterns (e.g. 'fill_scale', 'skin_command'); the others run everything")
    p.set_defaults(func=cmd_bench)
