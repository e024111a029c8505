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
import shutil
import subprocess
import sys
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


def write_report(out: Path, sections: list[list[str]], quick: bool, references: dict[str, str] | None = None,
                 jobs: int = 1) -> Path:
    """Write ``out/README.md`` from the sections (atomically), closing with what each area's error is
    measured against (``references``: area -> its REFERENCE); return its path. ``jobs`` > 1 says the
    areas ran that many at a time (their wall times then include each other's load)."""
    from .._io import atomic_write

    head = ["# Benchmarks", "",
            f"{'Quick (small sizes, a smoke run)' if quick else 'Full'} run. Each section is one area: "
            "its table of time next to accuracy, the paper numbers it is measured against "
            "(in the notes above each table) and its accuracy-vs-time plot. "
            "Each folder also holds the table as CSV.", "",
            *([f"The areas ran {jobs} at a time, each in its own process (`--jobs {jobs}`): their wall times "
               "include each other's load.", ""] if jobs > 1 else []),
            "Areas: " + ", ".join(f"[{s[0][3:]}](#{s[0][3:].lower()})" for s in sections) + ".", ""]
    out.mkdir(parents=True, exist_ok=True)
    path = out / "README.md"
    with atomic_write(path, "w", encoding="utf-8") as fh:
        tail = closing_note(references) if references else []
        fh.write("\n".join(head + [ln for s in sections for ln in s] + tail).rstrip("\n") + "\n")
    return path


# Started first under --jobs, so the hour-long areas do not start last (measured full runs: robot
# ~50 min, contact ~45, layout ~15; every other area a few minutes).
LONGEST_FIRST = ("robot", "contact", "layout")


def _area_kwargs(module, args) -> dict:
    """The options an area's ``run`` takes beyond ``out`` and ``quick``."""
    params = inspect.signature(module.run).parameters
    # --peers goes only to the benchmarks that run other solvers side by side (contact)
    kw = {"peers": True} if args.peers and "peers" in params else {}
    if args.cases and "cases" in params:  # the benchmarks that run their rows in groups (layout, robot)
        kw["cases"] = args.cases
    return kw


def _run_in_process(names, benches, out, args) -> dict[str, float]:
    """Run the areas one after another in this process; area -> wall seconds."""
    seconds = {}
    for n in names:
        module = importlib.import_module(benches[n])
        print(f"bench {n} ...", flush=True)
        t0 = time.perf_counter()
        module.run(out / n, quick=args.quick, **_area_kwargs(module, args))
        seconds[n] = time.perf_counter() - t0
    return seconds


def _child_command(name: str, out: Path, args) -> list[str]:
    """``vtcore bench NAME`` with this run's options, for a separate process; its own report goes to a
    scratch folder, its area's folder to ``out/NAME`` as in-process."""
    cmd = [sys.executable, "-m", "vtcore", "bench", name, "--out", str(out)]
    cmd += ["--quick"] * args.quick + ["--peers"] * args.peers
    return cmd + (["--cases", args.cases] if args.cases else [])


def _run_in_processes(names, out, args) -> tuple[dict[str, float], list[str]]:
    """Run the areas ``args.jobs`` at a time, each in its own process (``vtcore bench NAME``), its
    output in ``out/NAME/bench.log``; (area -> wall seconds, areas that failed).

    Separate processes rather than a fork pool: CoACD and the robot benchmark's own forked children
    hang in a forked worker, and each area then starts from a fresh interpreter as it does alone.
    """
    queue = sorted(names, key=lambda n: (n not in LONGEST_FIRST, LONGEST_FIRST.index(n)
                                         if n in LONGEST_FIRST else 0))
    running, seconds, failed = {}, {}, []
    scratch = out / ".areas"
    try:
        while queue or running:
            while queue and len(running) < args.jobs:
                n = queue.pop(0)
                running[n] = _start_area(n, out, scratch, args)
            time.sleep(0.5)
            for n, (proc, log, t0) in list(running.items()):
                if proc.poll() is None:
                    continue
                log.close()
                del running[n]
                seconds[n] = time.perf_counter() - t0
                if proc.returncode == 0:
                    shutil.copytree(scratch / n / n, out / n, dirs_exist_ok=True)
                else:
                    failed.append(n)
                print(f"bench {n}: {'done' if proc.returncode == 0 else f'FAILED (exit {proc.returncode})'} "
                      f"in {seconds[n]:.0f} s", flush=True)
    finally:
        # interrupted (Ctrl-C, SIGTERM): the areas' processes, and the children they fork for their rows,
        # go with the command instead of running on in the background
        for proc, log, _ in running.values():
            _stop_group(proc)
            log.close()
        shutil.rmtree(scratch, ignore_errors=True)
    return seconds, failed


def _start_area(name: str, out: Path, scratch: Path, args):
    """Start ``vtcore bench NAME`` in its own process, its output in ``out/NAME/bench.log``;
    (process, open log, start time)."""
    (out / name).mkdir(parents=True, exist_ok=True)
    log = open(out / name / "bench.log", "w", encoding="utf-8")
    # its own process group: an interrupted run stops the area with every child it forked (_stop_group)
    proc = subprocess.Popen(_child_command(name, scratch / name, args), stdout=log, stderr=subprocess.STDOUT,
                            start_new_session=True)
    print(f"bench {name} ... (log: {out / name / 'bench.log'})", flush=True)
    return proc, log, time.perf_counter()


def _stop_group(proc, grace_s: float = 10.0) -> None:
    """Stop an area's process group: SIGTERM (its runs clean up), SIGKILL after ``grace_s`` seconds (a
    C extension, or a forked row, that does not answer SIGTERM)."""
    import signal

    for sig in (signal.SIGTERM, signal.SIGKILL):
        try:
            os.killpg(proc.pid, sig)
        except ProcessLookupError:
            break
        try:
            proc.wait(timeout=grace_s)
            if sig == signal.SIGTERM:
                os.killpg(proc.pid, signal.SIGKILL)  # what it forked and left behind
        except ProcessLookupError:
            pass
        except subprocess.TimeoutExpired:
            continue
        break
    proc.wait()


def cmd_bench(args) -> int:
    from ..errors import InputError

    benches = available()
    names = args.names or list(benches)
    for n in names:
        if n not in benches:
            raise InputError(f"unknown benchmark {n!r}; available: {', '.join(benches)}")
    if args.jobs < 1:
        raise InputError(f"--jobs {args.jobs}: must be at least 1")
    extra = [Path(d) for d in args.with_dirs]
    for d in extra:
        if not (d / TABLE).is_file():
            raise InputError(f"--with {d}: no {TABLE} there (run that benchmark first)")
    out = Path(args.out)
    references = {n: getattr(importlib.import_module(benches[n]), "REFERENCE", None) for n in names}
    failed = []
    if args.jobs == 1:
        seconds = _run_in_process(names, benches, out, args)
    else:
        seconds, failed = _run_in_processes(names, out, args)
    sections = [section(out / n, n, n, seconds[n]) for n in names]
    for d in extra:
        # Linked relative to the report, wherever the folder is.
        rel = Path(os.path.relpath(d.resolve(), out.resolve())).as_posix()
        sections.append(section(d, d.name, rel))
    path = write_report(out, sections, args.quick, references, jobs=args.jobs)
    print(f"benchmarks written to {out}/ (report: {path})")
    if failed:
        logs = ", ".join(str(out / n / "bench.log") for n in failed)
        print(f"vtcore: error: benchmark {', '.join(failed)} failed; see {logs}", file=sys.stderr)
        return 1
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
    p.add_argument("--jobs", type=int, default=1, metavar="N",
                   help="run N areas at a time, each in its own process (its output in OUT/AREA/bench.log); "
                        "wall times then include the others' load")
    p.set_defaults(func=cmd_bench)
