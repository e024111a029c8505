"""One sweep point, as it runs inside a dask worker process.

:func:`run_point` is what the scheduler ships to a worker: its arguments are
three short strings (the scene path, the ``--set`` texts, the output folder)
and it returns a small record (status, seconds, the metrics, the error if
any). The arrays, plots and ``result.json`` stay in the point's folder on the
worker's file system, written by the ordinary :func:`vtcore.scene.run_scene`,
so a point's files are those of ``vtcore run`` with the same ``--set`` values.
"""

from __future__ import annotations

import json
import os
import platform
import socket
import time
import traceback
from pathlib import Path

from .. import __version__
from .._io import atomic_write
from ..errors import VtError

#: Written into a point's folder when the point fails (the full traceback for the curious).
ERROR_FILE = "error.json"


def worker_info() -> dict:
    """What a worker runs (checked against the client's before a sweep starts)."""
    return {"vtcore": __version__, "python": platform.python_version(), "host": socket.gethostname()}


def where() -> str:
    return f"{socket.gethostname()}:{os.getpid()}"


def error_record(exc: BaseException) -> dict:
    """``{"type", "file", "key", "line", "message"}`` of an exception.

    A vtcore input error names its own file, key and line; any other exception
    is located at the source line that raised it.
    """
    if isinstance(exc, VtError):
        return {"type": type(exc).__name__, "file": getattr(exc, "file", None), "key": getattr(exc, "key", None),
                "line": getattr(exc, "line", None), "message": str(exc)}
    frames = traceback.extract_tb(exc.__traceback__)
    last = frames[-1] if frames else None
    return {"type": type(exc).__name__, "file": last.filename if last else None, "key": None,
            "line": last.lineno if last else None, "message": f"{type(exc).__name__}: {exc}"}


def run_point(scene: str, overrides: list[str], out: str) -> dict:
    """Run one point: ``run_scene(scene, out, overrides)``; return its small record.

    Returns ``{"status": "ok" | "failed", "seconds", "cpu_seconds", "metrics", "error", "worker"}``
    (``cpu_seconds``: this process's CPU time during the point, all its threads);
    a failure is recorded (and written to ``out/error.json``), never raised, so the
    other points go on.
    """
    from ..scene import run_scene

    out_dir = Path(out)
    (out_dir / ERROR_FILE).unlink(missing_ok=True)  # a failure of an earlier attempt
    t0, c0 = time.perf_counter(), time.process_time()
    try:
        result = run_scene(scene, out_dir, overrides=list(overrides))
    except Exception as exc:  # any failure of one point is that point's result; the sweep goes on
        err = error_record(exc)
        with atomic_write(out_dir / ERROR_FILE, "w", encoding="utf-8") as fh:
            json.dump({**err, "overrides": list(overrides),
                       "traceback": traceback.format_exception(exc)}, fh, indent=2)
        return {"status": "failed", "seconds": time.perf_counter() - t0, "cpu_seconds": time.process_time() - c0,
                "metrics": {}, "error": err, "worker": where()}
    return {"status": "ok", "seconds": time.perf_counter() - t0, "cpu_seconds": time.process_time() - c0,
            "metrics": result["metrics"], "error": None, "worker": where()}


def completed(out: str | Path) -> dict | None:
    """The record of a point whose run finished (``result.json`` and ``report.md`` written), else None.

    ``run_scene`` writes ``result.json`` after the arrays and plots and ``report.md``
    last, each atomically, so both present means the run completed.
    """
    out = Path(out)
    try:
        result = json.loads((out / "result.json").read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None
    if not isinstance(result, dict) or not isinstance(result.get("metrics"), dict) \
            or not (out / "report.md").is_file():
        return None
    return {"status": "ok", "seconds": result.get("seconds"), "metrics": result["metrics"], "error": None,
            "worker": "resumed"}
