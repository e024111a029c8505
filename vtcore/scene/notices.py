"""What a scene run says besides its results: the warnings raised inside it, one line each.

numpy's ``RuntimeWarning`` (overflow, invalid value) and the package's own warnings
(``LayoutWarning``, ...) raised while a scene runs are caught here, not printed by Python with a
source line: each becomes one line ``FILE: KEY: MESSAGE`` naming the scene file and the key that
was being worked on (``effects.NAME`` while an effect is applied, ``task`` otherwise), counted
once however often it repeats. ``vtcore run`` prints them as ``vtcore: warning:`` lines;
``result.json`` keeps them under ``warnings`` and ``report.md`` lists them. A library's note to
its programmers (``DeprecationWarning`` and kin, vtcore.errors.meant_for_users) is left out.
"""

from __future__ import annotations

import contextlib
import contextvars
import warnings
from pathlib import Path

from ..errors import meant_for_users
from ..inputs import clean

_KEY: contextvars.ContextVar[str] = contextvars.ContextVar("vtcore_scene_key", default="task")


@contextlib.contextmanager
def scene_key(key: str):
    """Attribute what is raised in the block (warnings, errors without a key) to the scene ``key``."""
    token = _KEY.set(key)
    try:
        yield
    finally:
        _KEY.reset(token)


def current_key() -> str:
    return _KEY.get()


class Notices:
    """The warnings of one run: ``items`` is a list of ``{"key", "message", "count"}`` in first-seen order."""

    def __init__(self, file):
        self.file = str(file)
        self.items: list[dict] = []
        self._index: dict[tuple[str, str], dict] = {}

    key = staticmethod(scene_key)

    def add(self, message, key: str | None = None) -> None:
        text = clean(" ".join(str(message).split()), 400)  # one line, control bytes escaped
        k = key or current_key()
        item = self._index.get((k, text))
        if item is None:
            item = self._index[(k, text)] = {"key": k, "message": text, "count": 0}
            self.items.append(item)
        item["count"] += 1

    def lines(self) -> list[str]:
        return [f"{self.file}: {it['key']}: {it['message']}" + (f" ({it['count']} times)" if it["count"] > 1 else "")
                for it in self.items]


@contextlib.contextmanager
def warnings_of(file: str | Path):
    """Collect every warning raised in the block into a :class:`Notices` for ``file`` (yielded)."""
    notes = Notices(file)
    with warnings.catch_warnings():
        warnings.simplefilter("always")

        def show(message, category, filename, lineno, file=None, line=None):
            if meant_for_users(category):  # a library's deprecation is for vtcore's programmers
                notes.add(message)

        warnings.showwarning = show
        yield notes
