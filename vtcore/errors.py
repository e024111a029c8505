"""Error types of vtcore.

Every error that bad input can cause is a subclass of :class:`VtError` *and* of
``ValueError`` or ``TypeError``, so callers can catch either. Messages name the
file, the key or line and what would be valid; the CLI prints them without a
traceback and exits 2.
"""

from __future__ import annotations

from pathlib import Path


class VtError(Exception):
    """Base of all vtcore errors caused by input (files, scenes, arguments).

    ``details``: optional lines that say more than the one-line message (every problem of a scene,
    the warnings of a run before it failed); the CLI shows them only when asked (``--details``).
    """

    details: list[str] = []


class Cancelled(VtError):
    """The caller stopped a long computation: its progress callback returned False."""


def _locate(file=None, key=None, line=None) -> str:
    parts = []
    if file is not None:
        loc = str(file)
        if line is not None:
            loc += f":{line}"
        parts.append(loc)
    elif line is not None:
        parts.append(f"line {line}")
    if key:
        parts.append(str(key))
    return ": ".join(parts)


class InputError(VtError, ValueError):
    """A value is invalid. ``file``, ``key`` and ``line`` locate it."""

    def __init__(self, reason: str, *, file: str | Path | None = None,
                 key: str | None = None, line: int | None = None):
        self.reason = reason
        self.file = None if file is None else str(file)
        self.key = key
        self.line = line
        where = _locate(file, key, line)
        super().__init__(f"{where}: {reason}" if where else reason)


class SceneError(InputError):
    """A scene file is invalid (unknown key, wrong type, out of range, missing file)."""


class FormatError(InputError):
    """A data file (layout, log, recording, mesh) cannot be read."""


class InputTypeError(VtError, TypeError):
    """An argument has the wrong type or shape."""


class UnreachableTargetError(VtError, ValueError):
    """A control target (force, mean response) cannot be reached."""


class SceneErrors(SceneError):
    """Several scene problems at once. The message is one line (the first problems, then how many
    more); ``details`` lists every problem, one per line (``vtcore run --details``)."""

    #: problems written out in the one-line message; the rest are counted
    SHOWN = 3

    def __init__(self, errors: list[SceneError]):
        self.errors = list(errors)
        self.file = errors[0].file if errors else None
        self.key = errors[0].key if errors else None
        self.line = None
        self.details = [str(e) for e in self.errors]
        if len(self.errors) == 1:
            text = str(self.errors[0])
        else:
            parts = [_locate(None, e.key, e.line) + f": {e.reason}" if (e.key or e.line) else e.reason
                     for e in self.errors[: self.SHOWN]]
            more = len(self.errors) - self.SHOWN
            text = (f"{self.file}: " if self.file else "") + f"{len(self.errors)} problems: " + "; ".join(parts) + (
                f"; and {more} more (--details lists them all)" if more > 0 else "")
        ValueError.__init__(self, text)
        self.reason = text


# ----------------------------------------------------------------------------- warnings shown to users
#: What a library says to the programmers who call it (an API that will change or go, a missed
#: import, an unclosed file): the fix is in vtcore's code, never in the user's input, so it is not
#: shown to the user (Python itself hides DeprecationWarning outside ``__main__`` for that reason).
#: Judged by category, not by the file it points at: a library's deprecation points at its caller,
#: which is often vtcore. The test suite sees them (pytest's warning summary).
DEVELOPER_WARNINGS = (DeprecationWarning, PendingDeprecationWarning, FutureWarning, ImportWarning,
                      ResourceWarning, SyntaxWarning, BytesWarning)


def meant_for_users(category: type[Warning]) -> bool:
    """Whether a warning of ``category`` is for the person running vtcore: vtcore's own categories
    (``LayoutWarning``, ``LargeDeformationWarning``, ...), the numerical ones (``RuntimeWarning``:
    overflow, invalid value in their data) and ``UserWarning``; not :data:`DEVELOPER_WARNINGS`."""
    if getattr(category, "__module__", "").partition(".")[0] == "vtcore":
        return True
    return not issubclass(category, DEVELOPER_WARNINGS)


def for_users(caught) -> list:
    """The records of ``warnings.catch_warnings(record=True)`` that are :func:`meant_for_users`, in order."""
    return [w for w in caught if meant_for_users(w.category)]


def did_you_mean(name: str, known) -> str:
    """`` (did you mean 'x'?)`` for the entry of ``known`` closest to a mistyped ``name``
    (difflib, cutoff 0.6), or ``""`` when none is close: one hint instead of a list of every name."""
    import difflib

    m = difflib.get_close_matches(str(name), [str(k) for k in known], n=1, cutoff=0.6)
    return f" (did you mean {m[0]!r}?)" if m else ""
