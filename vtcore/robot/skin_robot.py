"""Skin a whole robot in one call: every link that can carry a module filled, in parallel over links.

:func:`skin_robot` fills each selected link (:func:`.skin.lay_on_link`, ``patch="fill"``) in its own
worker process, writes each finished link's layout at once (``OUT/layouts/<link>.json``), then the
merged robot (``OUT/<name>_skinned.urdf`` for a URDF robot, and ``OUT/<name>_skinned.xml``, MJCF,
through :func:`.export.export_skinned`) and the report (``OUT/skin_report.json``, ``OUT/report.md``:
per link the modules, coverage, wall and CPU seconds, peak memory, or the one-line reason it was
refused or failed).

Workers: a ``concurrent.futures.ProcessPoolExecutor`` on this machine (a fresh process per link,
from a forkserver that has imported vtcore once, so each link's peak memory is its own), or with
``scheduler="tcp://host:port"`` the workers of a running dask scheduler (as ``vtcore sweep`` uses
it; each worker must see the robot and ``OUT`` at the same paths). A link's fill is the same in any
worker (one BLAS thread each, seeded anchors, no timing in the layout file), so the layouts are
byte-identical whatever the number of workers.

A link whose fill fails is recorded with its reason; the others go on. Ctrl-C or SIGTERM stops the
run: links already written stay, the others are recorded ``interrupted`` in the report, the merged
robot is not written (it would lack them), and the interrupt goes on to the caller. Every file is
written whole (a temporary name, then a rename).

``regions``: a face mask per link (``{link: (F,) bool}`` over the link's mesh as :func:`.link_mesh`
gives it), passed to the fill as its region: the faces the skin may cover (an exposure mask).
"""

from __future__ import annotations

import fnmatch
import json
import os
import re
import time
from pathlib import Path

import numpy as np

from ..errors import Cancelled, InputError

#: statuses a link ends with
STATUSES = ("ok", "refused", "failed", "interrupted", "skipped")
REPORT_FILE = "skin_report.json"
#: seconds between the parent's looks at the workers (progress bars, Ctrl-C)
POLL_S = 0.2
#: modules preloaded by the forkserver, so that each link's fresh process starts in milliseconds
PRELOAD = ["numpy", "scipy.sparse", "scipy.spatial", "trimesh", "potpourri3d", "vtcore.layout", "vtcore.robot"]

# set in each local worker by _init_worker: where its fill reports progress, and the stop flag
_QUEUE = None
_STOP = None


def select_links(robot, pattern: str | None, geometry: str) -> tuple[list[str], dict]:
    """The links of ``robot`` to fill (in the robot's order) and ``{link: reason}`` for those skipped:
    no ``geometry`` of that kind, or a name not matching ``pattern`` (fnmatch, comma-separated
    alternatives; None: every link). An InputError when the pattern matches no link."""
    names = list(robot.links)
    pats = [p.strip() for p in pattern.split(",") if p.strip()] if pattern else ["*"]
    chosen = [n for n in names if any(fnmatch.fnmatchcase(n, p) for p in pats)]
    if not chosen:
        raise InputError(f"no link matches {pattern!r}; the links are {', '.join(names[:12])}"
                         f"{', ...' if len(names) > 12 else ''}", file=robot.path, key="--links")
    skipped = {n: f"no {geometry} geometry" for n in chosen if not robot.links[n].geometry(geometry)}
    return [n for n in chosen if n not in skipped], skipped


def safe_name(link: str) -> str:
    """A file name for ``link``: characters other than letters, digits, ``.-_`` become ``_``."""
    return re.sub(r"[^A-Za-z0-9._-]", "_", link) or "_"


def _init_worker(queue, stop):
    global _QUEUE, _STOP
    _QUEUE, _STOP = queue, stop
    os.environ.setdefault("VTCORE_PROGRESS", "0")


def fill_link(robot_path: str, packages: dict, link: str, geometry: str, out_file: str, module: str = "cyskin10",
              region=None, options: dict | None = None) -> dict:
    """Fill ``link`` and write its layout to ``out_file``; the record of how it went (never raises
    for a failure of this link: ``status`` "refused" when no module fits, "failed" otherwise).

    Runs in a worker process: the record has ``seconds`` and ``cpu_seconds`` of the fill (loading
    the mesh included) and ``peak_mb``, the process's peak resident memory (its own process per
    link on this machine; on a dask worker, the worker's peak so far)."""
    import resource
    import warnings

    from ..errors import VtError
    from ..layout import save
    from ..layout.islands import NoModuleFits
    from .skin import NoExposedSurface
    from .export import load_robot
    from .skin import lay_on_link

    t0, c0 = time.perf_counter(), time.process_time()
    rec = {"link": link, "status": "ok", "modules": 0, "taxels": 0, "coverage": None, "faces": None,
           "reason": None, "file": None}

    def progress(fraction):
        if _QUEUE is not None:
            _QUEUE.put((link, float(fraction)))
        return _STOP is None or not _STOP.is_set()

    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            robot = load_robot(robot_path, packages)
            from .meshes import link_mesh

            mesh = link_mesh(robot, link, geometry)
            rec["faces"] = int(len(mesh.faces))
            opts = dict(options or {})
            if region is not None:
                opts["region"] = np.asarray(region, bool)
            layout, report = lay_on_link(robot, link, "fill", geometry=geometry, module=module, mesh=mesh,
                                         progress=progress, **opts)
        # no time in the file: the same fill gives the same bytes in any worker
        layout.meta.get("placement", {}).pop("seconds", None)
        save(layout, out_file)
        rec["lost"] = {k: int(v) for k, v in (layout.meta.get("fill_left_out") or {}).items() if v}
        rec.update(modules=int(layout.n_modules), taxels=int(len(layout)), file=out_file,
                   coverage=None if report.coverage is None or not np.isfinite(report.coverage)
                   else float(report.coverage))
    except Cancelled:
        rec.update(status="interrupted", reason="stopped before it finished")
    except (NoModuleFits, NoExposedSurface) as exc:  # nothing to lay there: a refusal, not a failure
        rec.update(status="refused", reason=one_line(exc.reason))
    except (VtError, InputError) as exc:
        rec.update(status="failed", reason=one_line(str(exc)))  # with the file and key it names
    except Exception as exc:  # any failure of one link is that link's result; the others go on
        rec.update(status="failed", reason=one_line(f"{type(exc).__name__}: {exc}"))
    rec.update(seconds=time.perf_counter() - t0, cpu_seconds=time.process_time() - c0,
               peak_mb=resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0)
    if _QUEUE is not None:
        _QUEUE.put((link, 1.0))
    return rec


#: what a fill's candidate modules were left out for (``layout.meta["fill_left_out"]``), as said
LOST_WORDS = {"off": "off the surface", "rules": "on an edge", "strain": "strained", "overlap": "overlapping",
              "existing": "over skin already there"}


def lost_text(lost: dict | None) -> str:
    """``{"off": 12, "rules": 3}`` -> ``"12 off the surface, 3 on an edge"`` ("" for none)."""
    return ", ".join(f"{n} {LOST_WORDS.get(k, k)}" for k, n in (lost or {}).items() if n)


def one_line(text: str, limit: int = 300) -> str:
    """``text`` on one line, at most ``limit`` characters."""
    s = " ".join(str(text).split())
    return s if len(s) <= limit else s[:limit - 3] + "..."


def skin_robot(robot_path, out, *, links: str | None = None, geometry: str = "visual", workers: int | None = None,
               scheduler: str | None = None, packages: dict | None = None, module: str = "cyskin10",
               regions: dict | None = None, formats=("urdf", "mjcf"), bars: bool = True, progress=None,
               **options) -> dict:
    """Fill every selected link of the robot at ``robot_path`` and write layouts, merged robot and report to ``out``.

    links : fnmatch pattern(s), comma-separated (default every link). geometry : "visual" or "collision".
    workers : local worker processes (default: cores, at most one per link); ignored with ``scheduler``
        (a dask scheduler address). regions : ``{link: (F,) bool}`` face masks (see the module doc).
    formats : merged robot files to write ("urdf" only for a URDF robot). options : passed to the fill.
    bars : a progress bar per link (tqdm on stderr, shown on a terminal; :mod:`vtcore._progress`).
    progress : None or ``progress(fraction) -> bool`` (0..1, the links' mean) for a user interface;
        False stops the run as Ctrl-C does, then raises :class:`vtcore.errors.Cancelled`.
    Returns the report: ``robot``, ``geometry``, ``workers``, ``seconds``, ``links`` (one record per
    link in the robot's order: ``link``, ``status``, ``modules``, ``taxels``, ``coverage``,
    ``seconds``, ``cpu_seconds``, ``peak_mb``, ``reason``, ``file``), ``robot_files``.
    On Ctrl-C or SIGTERM the report is written with what finished and the interrupt is raised.
    """
    from ..inputs import check_output_dir
    from .export import load_robot

    robot_path, out = Path(robot_path), check_output_dir(out)
    if geometry not in ("visual", "collision"):
        raise InputError(f"must be visual or collision, got {geometry!r}", key="--geometry")
    if workers is not None and (isinstance(workers, bool) or int(workers) < 1):
        raise InputError(f"needs at least 1 worker, got {workers}", key="--workers")
    robot = load_robot(robot_path, packages)
    todo, skipped = select_links(robot, links, geometry)
    regions = dict(regions or {})
    unknown = sorted(set(regions) - set(robot.links))
    if unknown:
        raise InputError(f"regions given for links the robot does not have: {', '.join(unknown)}", key="regions")
    (out / "layouts").mkdir(parents=True, exist_ok=True)
    records = {n: {"link": n, "status": "skipped", "reason": why} for n, why in skipped.items()}
    jobs = [(str(robot_path), dict(packages or {}), n, geometry, str(out / "layouts" / f"{safe_name(n)}.json"),
             module, regions.get(n), options) for n in todo]
    t0 = time.perf_counter()
    n_workers = 1
    try:
        if todo:
            if scheduler:
                n_workers = _run_dask(scheduler, jobs, records, bars)
            else:
                n_workers = min(int(workers or os.cpu_count() or 1), len(todo))
                _run_local(n_workers, jobs, records, bars, progress)
    except (KeyboardInterrupt, Cancelled):
        for n in todo:
            records.setdefault(n, {"link": n, "status": "interrupted", "reason": "stopped before it finished"})
        write_report(robot, geometry, records, out, n_workers, time.perf_counter() - t0, [])
        raise
    files = _merged(robot_path, robot, records, out, formats, packages)
    return write_report(robot, geometry, records, out, n_workers, time.perf_counter() - t0, files)


def _run_local(n: int, jobs: list, records: dict, bars: bool, progress=None) -> None:
    """Run ``jobs`` (argument tuples of :func:`fill_link`) on ``n`` local processes into ``records``;
    ``progress`` as for :func:`skin_robot` (False raises Cancelled after stopping the workers)."""
    import multiprocessing as mp
    from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, wait

    ctx = mp.get_context("forkserver")
    ctx.set_forkserver_preload(PRELOAD)
    queue, stop = ctx.Queue(), ctx.Event()
    shown = LinkBars([j[2] for j in jobs], bars)
    # one BLAS thread per worker: the workers are the parallelism (and results do not depend on it)
    env = {k: os.environ.get(k) for k in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS")}
    os.environ.update({k: "1" for k in env})
    pool = ProcessPoolExecutor(n, mp_context=ctx, initializer=_init_worker, initargs=(queue, stop),
                               max_tasks_per_child=1)
    try:
        futures = {pool.submit(fill_link, *j): j[2] for j in jobs}
        pending = set(futures)
        while pending:
            done, pending = wait(pending, timeout=POLL_S, return_when=FIRST_COMPLETED)
            _drain(queue, shown)
            for f in done:
                records[futures[f]] = _result(f, futures[f])
                shown.finish(futures[f], records[futures[f]])
            if progress is not None and progress(shown.fraction()) is False:
                raise Cancelled("skinning the robot was cancelled")
    except (KeyboardInterrupt, Cancelled):
        stop.set()  # running fills stop at their next progress step; queued ones never start
        for f in futures:
            f.cancel()
        wait([f for f in futures if not f.cancelled()], timeout=30)
        for f, name in futures.items():
            if f.done() and not f.cancelled():
                records[name] = _result(f, name)
        raise
    finally:
        pool.shutdown(wait=True, cancel_futures=True)
        shown.close()
        for k, v in env.items():
            os.environ.pop(k) if v is None else os.environ.__setitem__(k, v)


def _result(fut, name: str) -> dict:
    """The record of the done future ``fut`` of link ``name``: its worker's failure (killed, out of
    memory, interrupted) as that link's record. The future's exception is asked for, not caught: a
    Ctrl-C reaches the worker and this process together, and an ``except BaseException`` round
    ``fut.result()`` swallowed this process's own KeyboardInterrupt when it landed there (the run
    then finished the other links and exited 0: seen once in a loaded CI run)."""
    exc = fut.exception()
    if exc is None:
        return fut.result()
    status = "interrupted" if isinstance(exc, KeyboardInterrupt) else "failed"
    return {"link": name, "status": status, "reason": one_line(f"{type(exc).__name__}: {exc}")}


def _drain(queue, shown) -> None:
    import queue as q

    while True:
        try:
            link, fraction = queue.get_nowait()
        except (q.Empty, OSError, ValueError):
            return
        shown.update(link, fraction)


def _run_dask(address: str, jobs: list, records: dict, bars: bool) -> int:
    """Run ``jobs`` on the workers of the dask scheduler at ``address``; returns their number."""
    from distributed import Client, as_completed

    try:
        client = Client(address, timeout=5, set_as_default=False)
    except (OSError, TimeoutError, ValueError) as exc:
        raise InputError(f"cannot reach the dask scheduler at {address} ({exc}); is `dask scheduler` running "
                         "there?", key="--scheduler") from None
    shown = LinkBars([j[2] for j in jobs], bars)
    try:
        futures = {client.submit(fill_link, *j, key=f"vtcore-skin-{j[2]}-{os.getpid()}-{time.time_ns()}",
                                 pure=False): j[2] for j in jobs}
        try:
            for f in as_completed(futures, loop=client.loop):
                records[futures[f]] = _result(f, futures[f])
                shown.finish(futures[f], records[futures[f]])
        except KeyboardInterrupt:
            client.cancel(list(futures))
            raise
        return max(len(client.scheduler_info().get("workers", {})), 1)
    finally:
        shown.close()
        client.close(timeout=10)


class LinkBars:
    """One tqdm bar per link (``vtcore._progress`` decides whether they show)."""

    def __init__(self, links, enabled: bool = True):
        from .._progress import progress

        self.bars, self.done = {}, {n: 0.0 for n in links}
        if enabled:
            for i, n in enumerate(links):
                b = progress(total=100, desc=n, unit="%")
                b.position = i
                self.bars[n] = b

    def fraction(self) -> float:
        """The links' mean fraction done (0..1)."""
        return float(np.mean(list(self.done.values()))) if self.done else 1.0

    def update(self, link: str, fraction: float) -> None:
        self.done[link] = max(self.done.get(link, 0.0), float(fraction))
        b = self.bars.get(link)
        if b is not None:
            b.n = int(round(100 * fraction))
            b.refresh()

    def finish(self, link: str, rec: dict) -> None:
        b = self.bars.get(link)
        if b is not None:
            b.set_postfix_str(rec.get("status", ""))
            self.update(link, 1.0)

    def close(self) -> None:
        for b in self.bars.values():
            b.close()


def _merged(robot_path: Path, robot, records: dict, out: Path, formats, packages) -> list[dict]:
    """Write the robot with every finished link's skin; one ``{"format", "file"}`` or ``{"format",
    "error"}`` per format (an export that fails is reported, the layouts stay)."""
    from ..layout import load
    from .export import export_skinned

    done = [records[n] for n in robot.links if records.get(n, {}).get("status") == "ok"]
    if not done:
        return []
    layouts = [load(r["file"]) for r in done]
    files = []
    for fmt in formats:
        if fmt == "urdf" and robot.format != "urdf":
            continue
        path = out / f"{robot_path.stem}_skinned.{'urdf' if fmt == 'urdf' else 'xml'}"
        try:
            export_skinned(robot_path, layouts, path, format=fmt, packages=packages)
            files.append({"format": fmt, "file": str(path)})
        except InputError as exc:
            files.append({"format": fmt, "error": one_line(getattr(exc, "reason", None) or str(exc))})
    return files


def write_report(robot, geometry: str, records: dict, out: Path, workers: int, seconds: float, files) -> dict:
    """Write ``out/skin_report.json`` and ``out/report.md`` (atomically) and return the report."""
    from .._io import atomic_write

    rows = [records[n] for n in robot.links if n in records]
    rep = {"robot": str(robot.path), "geometry": geometry, "workers": int(workers), "seconds": float(seconds),
           "modules": int(sum(r.get("modules") or 0 for r in rows)),
           "counts": {s: sum(r["status"] == s for r in rows) for s in STATUSES}, "links": rows,
           "robot_files": list(files)}
    with atomic_write(out / REPORT_FILE, "w", encoding="utf-8") as fh:
        json.dump(rep, fh, indent=1)
    lines = [f"# Skin of {Path(robot.path).name} ({geometry} geometry)", "",
             f"{rep['modules']} modules on {rep['counts']['ok']} links in {seconds:.1f} s with {workers} worker(s); "
             + ", ".join(f"{v} {k}" for k, v in rep["counts"].items() if v and k != "ok"), "",
             "| link | status | modules | coverage | wall s | CPU s | peak MB | candidates lost | reason |",
             "|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        cov = "" if r.get("coverage") is None else f"{100 * r['coverage']:.0f} %"
        num = lambda k, f: "" if r.get(k) is None else format(r[k], f)  # noqa: E731
        why = str(r.get("reason") or "").replace("|", "\\|")
        lines.append(f"| {r['link']} | {r['status']} | {r.get('modules') or ''} | {cov} | {num('seconds', '.1f')} "
                     f"| {num('cpu_seconds', '.1f')} | {num('peak_mb', '.0f')} | {lost_text(r.get('lost'))} | {why} |")
    for f in files:
        lines.append("")
        lines.append(f"- {f['format']}: " + (f"`{Path(f['file']).name}`" if "file" in f else f"not written: {f['error']}"))
    with atomic_write(out / "report.md", "w", encoding="utf-8") as fh:
        fh.write("\n".join(lines) + "\n")
    return rep
