"""Error types of vtcore.

Every error that bad input can cause is a subclass of :class:`VtError` *and* of
``ValueError`` or ``TypeError``, so callers can catch either. Messages name the
file, the key or line and what would be valid; the CLI prints them without a
traceback and exits 2.
"""

from __future__ import annotations

from pathlib import Path


class VtError(Exception):
    """Base of all vtcore errors caused by input (files, scenes, arguments)."""


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
    """Several scene problems at once; the message has one line per problem."""

    def __init__(self, errors: list[SceneError]):
        self.errors = list(errors)
        ValueError.__init__(self, "\n".join(str(e) for e in self.errors))
        self.reason = str(self)
        self.file = errors[0].file if errors else None
        self.key = errors[0].key if errors else None
        self.line = None
