"""The resource guards (docs/inputs.md): a size a user sets is checked against the memory budget
(``VTCORE_MEMORY_BUDGET``, default 4 GiB) before allocating (:func:`need_memory`), and a loop's count
against ``VTCORE_TIME_BUDGET`` (default 1 h, :func:`need_time`).
"""

from __future__ import annotations

import math
import os
import re

from ..errors import InputError
from .text import clean, fmt_bytes

_UNITS = {"": 1, "K": 1 << 10, "M": 1 << 20, "G": 1 << 30, "T": 1 << 40}


def memory_budget() -> int:
    """Bytes one array (or one group of arrays) built from user-set sizes may take.

    ``VTCORE_MEMORY_BUDGET`` (``512M``, ``16G``, or bytes), default 4 GiB.
    """
    raw = os.environ.get("VTCORE_MEMORY_BUDGET", "").strip().upper().removesuffix("B").removesuffix("I")
    if not raw:
        return 4 << 30
    m = re.fullmatch(r"([0-9.]+)\s*([KMGT]?)", raw)
    if not m:
        raise InputError(f"must be a size like 4G or 512M, got {clean(raw, 40)!r}", key="VTCORE_MEMORY_BUDGET")
    return int(float(m.group(1)) * _UNITS[m.group(2)])


def need_memory(nbytes: float, *, key: str | None, what: str, file=None, line: int | None = None,
                remedy: str | None = None) -> None:
    """Refuse, before allocating, work whose arrays would take more than :func:`memory_budget`.

    ``key``: the setting that makes it so large (``task.readings``); ``what``: what it sizes.
    ``remedy``: what to do instead of "lower KEY" when no setting is to blame (a file's content);
    ``line``: the file's line (or record) that asks for it.
    """
    budget = memory_budget()
    if not math.isfinite(nbytes) or nbytes > budget:
        raise InputError(f"{what} would need {fmt_bytes(nbytes) if math.isfinite(nbytes) else 'unbounded memory'}, "
                         f"more than the memory budget of {fmt_bytes(budget)}; {remedy or f'lower {key}'}, or raise "
                         "the budget with VTCORE_MEMORY_BUDGET (e.g. 16G)", file=file, key=key, line=line)


_TIME_UNITS = {"": 1.0, "S": 1.0, "M": 60.0, "H": 3600.0}


def time_budget() -> float:
    """Seconds one piece of work sized by user-set values may be expected to take.

    ``VTCORE_TIME_BUDGET`` (``90s``, ``30m``, ``2h``, or seconds), default one hour.
    """
    raw = os.environ.get("VTCORE_TIME_BUDGET", "").strip().upper()
    if not raw:
        return 3600.0
    m = re.fullmatch(r"([0-9.]+)\s*([SMH]?)", raw)
    if not m:
        raise InputError(f"must be a duration like 90s, 30m or 2h, got {clean(raw, 40)!r}", key="VTCORE_TIME_BUDGET")
    return float(m.group(1)) * _TIME_UNITS[m.group(2)]


def need_time(steps: float, seconds_per_step: float, *, key: str | None, what: str, file=None,
              remedy: str | None = None) -> None:
    """Refuse, before starting, a loop of ``steps`` whose expected time (``seconds_per_step``, an
    optimistic per-step cost: the guard refuses only what is surely too long) exceeds :func:`time_budget`."""
    budget = time_budget()
    seconds = float(steps) * seconds_per_step
    if not math.isfinite(seconds) or seconds > budget:
        shown = f"at least {seconds:.3g} s" if math.isfinite(seconds) else "forever"
        raise InputError(f"{what} would take {shown}, more than the time budget of {budget:g} s; "
                         f"{remedy or f'lower {key}'}, or raise the budget with VTCORE_TIME_BUDGET (e.g. 2h)",
                         file=file, key=key)
