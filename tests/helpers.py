"""Helpers shared by test modules across folders (tests/ is on sys.path through its conftest)."""

from __future__ import annotations

import contextlib
import signal


@contextlib.contextmanager
def wall_clock_limit(seconds: int, error: type[BaseException] = AssertionError):
    """Raise ``error("no answer after N s")`` in the block if it runs longer than ``seconds`` of wall
    clock (SIGALRM: main thread, POSIX), so a hang fails a test instead of blocking the suite."""
    def fire(signum, frame):
        raise error(f"no answer after {seconds} s")

    old = signal.signal(signal.SIGALRM, fire)
    signal.alarm(seconds)
    try:
        yield
    finally:
        signal.alarm(0)
        signal.signal(signal.SIGALRM, old)
