"""What every benchmark (``vtcore.<package>.bench``) shares: timing, the table, the plot file.

Each benchmark writes ``table.csv``, ``table.md`` and ``accuracy_vs_time.png``
into its folder (see ``vtcore bench``); the helpers here keep those files
alike across packages and never half-written.
"""

from __future__ import annotations

import csv
import io
import time
from pathlib import Path
from typing import Callable, Iterable

from ._io import atomic_write

_CLOCKS = {"wall": time.perf_counter, "cpu": time.process_time}


def best_time(fn: Callable, repeat: int = 3, clock: str = "wall"):
    """Best of ``repeat`` calls of ``fn()``: ``(seconds, result of the last call)``.

    The minimum is the least disturbed estimate on a shared machine. ``clock="cpu"``
    measures the process's CPU time (all its threads), which other processes' load
    does not inflate.
    """
    now = _CLOCKS[clock]
    best, out = float("inf"), None
    for _ in range(max(1, int(repeat))):
        t0 = now()
        out = fn()
        best = min(best, now() - t0)
    return best, out


def in_child(fn):
    """``(seconds, cpu seconds, peak resident MB, result, error)`` of ``fn()`` in a forked child
    (CPU time is what other processes' load on the shared machine does not inflate; the peak is the
    child's own, so cases do not inherit each other's high-water mark). An exception becomes the
    ``error`` text: a case that fails is a row that says so."""
    import multiprocessing as mp
    import resource
    import warnings

    def work(q):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            t0 = time.perf_counter()
            try:
                res = fn()
                err = None
            except Exception as exc:  # noqa: BLE001  (reported in the row)
                res, err = None, f"{type(exc).__name__}: {exc}"
            sec = time.perf_counter() - t0
        ru = resource.getrusage(resource.RUSAGE_SELF)
        q.put((sec, ru.ru_utime + ru.ru_stime, ru.ru_maxrss / 1024.0, res, err))

    ctx = mp.get_context("fork")
    q = ctx.Queue()
    p = ctx.Process(target=work, args=(q,))
    p.start()
    out = q.get()
    p.join()
    return out


def _cell(v) -> str:
    if v is None:
        return "-"
    if isinstance(v, float):
        return f"{v:.4g}"
    if isinstance(v, int) and not isinstance(v, bool) and abs(v) >= 1000:
        return f"{v:,}"
    return str(v)


def markdown_table(rows: list[dict], columns: Iterable[str] | None = None) -> str:
    """A GitHub Markdown table of ``rows`` (floats to 4 significant digits, None as ``-``)."""
    cols = list(columns or (rows[0] if rows else []))
    lines = ["| " + " | ".join(cols) + " |", "|" + "---|" * len(cols)]
    lines += ["| " + " | ".join(_cell(r.get(c)) for c in cols) + " |" for r in rows]
    return "\n".join(lines)


def write_table(out: Path, rows: list[dict], *, title: str, notes: Iterable[str] = (),
                columns: Iterable[str] | None = None) -> None:
    """Write ``out/table.csv`` (all values) and ``out/table.md`` (title, notes, table)."""
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    cols = list(columns or (rows[0] if rows else []))
    buf = io.StringIO()
    w = csv.DictWriter(buf, fieldnames=cols, lineterminator="\n", extrasaction="ignore")
    w.writeheader()
    w.writerows(rows)
    with atomic_write(out / "table.csv", "w", encoding="utf-8", newline="") as fh:
        fh.write(buf.getvalue())
    md = [f"# {title}", ""]
    for note in notes:
        md += [note, ""]
    md.append(markdown_table(rows, cols))
    with atomic_write(out / "table.md", "w", encoding="utf-8") as fh:
        fh.write("\n".join(md) + "\n")


def save_png(fig, path: Path, dpi: int = 120) -> None:
    """Write a matplotlib figure as PNG (atomically) and close it."""
    import matplotlib.pyplot as plt

    with atomic_write(path, "wb") as fh:
        fig.savefig(fh, format="png", dpi=dpi, bbox_inches="tight")
    plt.close(fig)
