"""Progress bars for long work (tqdm on stderr).

Shown when stderr is a terminal, hidden otherwise (tests, CI, Blender). Set
``VTCORE_PROGRESS=1`` to force them on, ``0`` to force them off. A step that
takes under a second never draws a bar (``delay=1``).
"""

from __future__ import annotations

import os
import sys


def _enabled() -> bool:
    flag = os.environ.get("VTCORE_PROGRESS")
    if flag is not None:
        return flag not in ("0", "", "false", "no")
    return sys.stderr.isatty()


def progress(iterable=None, *, desc: str = "", total: int | None = None, unit: str = "it"):
    """Wrap ``iterable`` in a tqdm bar that appears only after one second."""
    from tqdm.auto import tqdm

    return tqdm(iterable, desc=desc, total=total, unit=unit, delay=1.0,
                disable=not _enabled(), file=sys.stderr, leave=False, dynamic_ncols=True)
