"""Progress bars for long work (tqdm on stderr).

Shown when stderr is a terminal, hidden otherwise (tests, CI, Blender). Set
``VTCORE_PROGRESS=1`` to force them on, ``0`` to force them off. A step that
takes under a second never draws a bar (``delay=1``).

Long computations that a user interface drives take a ``progress`` callback
(``progress(fraction) -> bool``, False stops them: :func:`keep_going`), and
:class:`Job` runs one in a worker thread so the interface can show the fraction and
offer to cancel.
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


def keep_going(progress, fraction: float, what: str = "the computation") -> None:
    """Tell ``progress`` that ``fraction`` (0..1) of a long computation is done.

    progress : None, or a callable ``progress(fraction) -> bool``; returning False (not
    None) asks to stop, and this raises :class:`~vtcore.errors.Cancelled` so that the
    computation unwinds without a result.
    """
    if progress is not None and progress(min(max(float(fraction), 0.0), 1.0)) is False:
        from .errors import Cancelled

        raise Cancelled(f"{what} was cancelled")


class Job:
    """Run ``fn(*args, progress=callback, **kwargs)`` in a worker thread, for a user interface
    that shows the progress and offers to cancel while it stays responsive.

    ``fraction`` is the last fraction ``fn`` reported (0..1); ``cancel()`` makes the next
    progress call return False (``fn`` then raises :class:`~vtcore.errors.Cancelled`);
    ``done`` says the thread has finished; ``result()`` waits and returns ``fn``'s result or
    raises its exception. ``fn`` must not touch the caller's UI objects (Blender's ``bpy``
    is not thread-safe): give it plain arrays. One step of ``fn`` that holds the GIL (a big
    sparse factorisation) still blocks the UI for its duration.
    """

    def __init__(self, fn, *args, **kwargs):
        import threading

        self.fraction = 0.0
        self._stop = threading.Event()
        self._result = self._error = None
        self._thread = threading.Thread(target=self._run, args=(fn, args, kwargs), daemon=True,
                                        name=f"vtcore-{getattr(fn, '__name__', 'job')}")
        self._thread.start()

    def _progress(self, fraction: float) -> bool:
        self.fraction = float(fraction)
        return not self._stop.is_set()

    def _run(self, fn, args, kwargs):
        try:
            self._result = fn(*args, progress=self._progress, **kwargs)
        except BaseException as exc:  # handed to the caller's thread by result()
            self._error = exc

    @property
    def done(self) -> bool:
        return not self._thread.is_alive()

    def cancel(self) -> None:
        self._stop.set()

    def wait(self, timeout: float | None = None) -> bool:
        """Wait for the thread (at most ``timeout`` seconds); True when it has finished."""
        self._thread.join(timeout)
        return self.done

    def result(self):
        self._thread.join()
        if self._error is not None:
            raise self._error
        return self._result
