"""Running a sweep's points on dask.distributed.

By default a ``LocalCluster`` of N single-threaded worker *processes* on this
machine (N = the number of cores); with ``scheduler="tcp://host:port"`` the
workers of a running ``dask scheduler``. dask does the scheduling, the retries
of points whose worker died and the transport: we write no scheduler or
process pool of our own (DESIGN.md, "Beyond one machine").

What crosses the network: to a worker, the scene's path, the point's ``--set``
texts and its output folder (strings); back, a record of a few hundred bytes
(status, seconds, metrics, error). Arrays and plots never travel: each point
writes them into its own folder, which must therefore be on a file system the
worker sees at the same path (the local disk for a ``LocalCluster``; a shared
mount for a real cluster).

A point whose worker dies is retried by dask on another worker; after
``retries`` deaths it is recorded as ``lost``. Every point of the plan ends up
in ``sweep.csv`` with a status: ``ok``, ``failed`` (the scene raised: file,
key, message), ``lost``, ``interrupted`` (Ctrl-C came first) or ``pending``
(only in the copy written while the sweep runs).
"""

from __future__ import annotations

import logging
import os
import time
from pathlib import Path

from .. import __version__
from .._progress import progress
from ..errors import InputError
from . import report
from .point import completed, run_point, worker_info
from .spec import Plan

#: Seconds to wait for a named scheduler to answer (and to show at least one worker).
CONNECT_TIMEOUT = 5.0


class SchedulerError(InputError):
    """The named dask scheduler does not answer, has no workers, or its workers cannot run vtcore."""


def local_client(workers: int | None = None, retries: int = 2):
    """A ``Client`` on a fresh ``LocalCluster`` of ``workers`` processes (default: cores), one thread each.

    retries : how many worker deaths a point survives before it is recorded as lost
    (dask's ``distributed.scheduler.allowed-failures``).
    Returns ``(client, cluster)``; close both.
    """
    import dask
    from distributed import Client, LocalCluster

    if workers is not None and (isinstance(workers, bool) or int(workers) < 1):
        raise InputError(f"needs at least 1 worker, got {workers}", key="--workers")
    if int(retries) < 0:
        raise InputError(f"must be >= 0, got {retries}", key="--retries")
    n = int(workers or os.cpu_count() or 1)
    # worker-saturation 1.0: a worker holds only the point it runs, so a point waits in the
    # scheduler's queue (not behind a slow point on a busy worker) and a dead worker takes one point with it.
    # pre-spawn-environ: dask's default also sets MALLOC_TRIM_THRESHOLD_=65536, which made every
    # point ~1.5x slower in CPU (large temporary arrays given back to the OS and faulted in again).
    # One BLAS/OpenMP thread per worker: the workers are the parallelism (run_scene pins BLAS anyway).
    with dask.config.set({"distributed.scheduler.allowed-failures": int(retries),
                          "distributed.scheduler.worker-saturation": 1.0,
                          "distributed.nanny.pre-spawn-environ": {"OMP_NUM_THREADS": 1, "MKL_NUM_THREADS": 1,
                                                                  "OPENBLAS_NUM_THREADS": 1}}):
        # The scheduler always serves HTTP (health checks; the dashboard needs bokeh): on a free
        # local port, not 8787, which another cluster on this machine may hold.
        # silence_logs=CRITICAL: a worker whose heartbeat meets the scheduler already closing logs
        # an ERROR with two tracebacks ("Failed to communicate with scheduler during heartbeat",
        # StreamClosedError) on the user's terminal after a sweep that succeeded (seen in the
        # py313 lane); a point's own failure reaches the sweep's report through its future instead.
        cluster = LocalCluster(n_workers=n, threads_per_worker=1, processes=True, host="127.0.0.1",
                               dashboard_address="127.0.0.1:0", silence_logs=logging.CRITICAL)
    return Client(cluster, set_as_default=False), cluster


def remote_client(address: str, timeout: float = CONNECT_TIMEOUT):
    """A ``Client`` of the running scheduler at ``address``; a clear error within ``timeout`` seconds.

    Checks that at least one worker is there and that every worker runs this vtcore version.
    """
    from distributed import Client

    try:
        client = Client(address, timeout=timeout, set_as_default=False)
    except (OSError, TimeoutError, ValueError) as exc:
        raise SchedulerError(f"cannot reach the dask scheduler at {address} within {timeout:g} s ({exc}); "
                             "is `dask scheduler` running there, and is the port open?",
                             key="--scheduler") from None
    try:
        client.wait_for_workers(1, timeout=timeout)
    except TimeoutError:
        client.close()
        raise SchedulerError(f"the dask scheduler at {address} has no workers (waited {timeout:g} s); start "
                             f"some with `dask worker {address}`", key="--scheduler") from None
    return client


def check_workers(client) -> dict:
    """``{worker address: worker_info()}``; raises :class:`SchedulerError` if a worker cannot run this vtcore."""
    try:
        info = client.run(worker_info)
    except Exception as exc:  # whatever a worker raised (ModuleNotFoundError: no vtcore there) is the message
        raise SchedulerError(f"a worker cannot run vtcore ({type(exc).__name__}: {exc}); install the same vtcore "
                             f"({__version__}) on every worker machine", key="--scheduler") from None
    wrong = {addr: i["vtcore"] for addr, i in info.items() if i["vtcore"] != __version__}
    if wrong:
        raise SchedulerError(f"workers run another vtcore than this one ({__version__}): "
                             + ", ".join(f"{a} has {v}" for a, v in wrong.items()), key="--scheduler")
    return info


def lost_record(exc: BaseException, status: str = "lost") -> dict:
    return {"status": status, "seconds": None, "metrics": {}, "worker": None,
            "error": {"type": type(exc).__name__, "file": None, "key": None, "line": None,
                      "message": f"{type(exc).__name__}: {exc}"}}


def run_sweep(plan: Plan, out: str | Path, *, workers: int | None = None, scheduler: str | None = None,
              resume: bool = False, retries: int = 2, timeout: float = CONNECT_TIMEOUT,
              command: str = "", client=None) -> list[dict]:
    """Run every point of ``plan`` into ``out/<point>/`` and write ``out/sweep.csv`` and ``out/report.md``.

    workers : LocalCluster size (default: cores); ignored with ``scheduler`` or ``client``.
    scheduler : address of a running scheduler (``tcp://host:port``).
    resume : skip points whose folder holds a completed run.
    retries : worker deaths a point survives on a LocalCluster before it is recorded ``lost``.
    client : an existing ``distributed.Client`` to use (not closed here).
    Returns one record per point, in plan order: ``name``, ``grid``, ``seed``, ``status``,
    ``seconds``, ``metrics``, ``error``, ``worker``. On Ctrl-C the finished points stay,
    the rest are recorded ``interrupted``, both files are written, and the
    ``KeyboardInterrupt`` goes on to the caller.
    """
    out = Path(out)
    records: dict[str, dict] = {}
    if resume:
        for p in plan.points:
            rec = completed(out / p.name)
            if rec is not None:
                records[p.name] = rec
    todo = [p for p in plan.points if p.name not in records]
    t0 = time.perf_counter()
    cluster = own = None
    started = False
    try:
        if todo:
            if client is None:
                if scheduler:
                    client = own = remote_client(scheduler, timeout)
                else:
                    client, cluster = local_client(workers, retries)
                    own = client
            check_workers(client)
            out.mkdir(parents=True, exist_ok=True)  # only once a cluster is there to fill it
            started = True
            _gather(client, plan, todo, out, records, command)
    except BaseException as exc:  # Ctrl-C, or the cluster went away: record every point, then stop
        if not started:  # no cluster came up (unreachable scheduler): nothing was started or written
            raise
        stop = (lost_record(KeyboardInterrupt("stopped by Ctrl-C before it finished"), "interrupted")
                if isinstance(exc, KeyboardInterrupt) else lost_record(exc))
        for p in todo:
            records.setdefault(p.name, stop)
        report.write_csv(plan, _ordered(plan, records), out)
        if isinstance(exc, KeyboardInterrupt):
            report.write(plan, _ordered(plan, records), out, command=command, seconds=time.perf_counter() - t0)
        raise
    finally:
        if own is not None:
            own.close(timeout=10)
        if cluster is not None:
            cluster.close(timeout=10)
    rows = _ordered(plan, records)
    report.write(plan, rows, out, command=command, seconds=time.perf_counter() - t0)
    return rows


def _gather(client, plan, todo, out, records, command):
    """Submit ``todo`` and collect records as points finish (sweep.csv rewritten after each)."""
    from distributed import as_completed

    futures = {}
    for p in todo:
        fut = client.submit(run_point, str(plan.scene), list(p.overrides), str((out / p.name).resolve()),
                            key=f"vtcore-point-{p.name}-{os.getpid()}-{time.time_ns()}", pure=False)
        futures[fut] = p
    bar = progress(total=len(todo), desc="sweep", unit="point")
    failed = 0
    try:
        for fut in as_completed(futures, loop=client.loop):
            p = futures[fut]
            try:
                rec = fut.result()
            except Exception as exc:  # KilledWorker (retries spent) or a lost connection: the point is lost
                rec = lost_record(exc)
            records[p.name] = rec
            failed += rec["status"] != "ok"
            bar.update(1)
            if failed:
                bar.set_postfix(failed=failed)
            report.write_csv(plan, _ordered(plan, records, pending=True), out)
    except KeyboardInterrupt:
        client.cancel(list(futures))
        raise
    finally:
        bar.close()


def _ordered(plan, records, pending=False):
    rows = []
    for p in plan.points:
        rec = records.get(p.name)
        if rec is None:
            if not pending:
                continue
            rec = {"status": "pending", "seconds": None, "metrics": {}, "error": None, "worker": None}
        rows.append({"name": p.name, "grid": p.grid, "seed": p.seed, **rec})
    return rows
