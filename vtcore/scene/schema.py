"""A small declarative schema for scene files.

Why not jsonschema or pydantic: scene errors must read like
``scenes/x.toml: layer.thickness: must be > 0, got -0.003`` and name the key a
user typed, paths must be checked relative to the scene file, and each
package registers the sections it owns. Forty lines of our own do that more
plainly than adapting a general validator's messages.

A :class:`Field` describes one value; a :class:`Section` is a TOML table of
fields and rejects keys it does not know. ``Section.validate`` returns the data
with defaults filled and appends one :class:`SceneError` per problem.
"""

from __future__ import annotations

import copy
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable

from ..errors import SceneError

REQUIRED = object()

_KINDS = ("float", "int", "bool", "str", "path", "vec", "list", "table", "tables", "any")


@dataclass
class Field:
    """One value of a scene file.

    kind: ``float``, ``int``, ``bool``, ``str``, ``path`` (a file that must exist,
    relative to the scene file), ``vec`` (list of numbers, ``length`` items),
    ``list`` (list of ``item`` fields), ``table`` (a nested :class:`Section`),
    ``tables`` (an array of tables, each a ``section``), ``any`` (free-form, the
    owner checks it).
    """

    kind: str
    default: Any = REQUIRED
    doc: str = ""
    unit: str = ""
    gt: float | None = None
    ge: float | None = None
    lt: float | None = None
    le: float | None = None
    choices: tuple | Callable[[], tuple] | None = None
    length: int | tuple[int, int] | None = None
    item: "Field | None" = None
    section: "Section | None" = None
    check: Callable[[Any], str | None] | None = None

    def __post_init__(self):
        if self.kind not in _KINDS:
            raise ValueError(f"unknown field kind {self.kind!r}")

    @property
    def required(self) -> bool:
        return self.default is REQUIRED

    def _choices(self):
        return self.choices() if callable(self.choices) else self.choices

    def validate(self, value, key: str, ctx: "Context"):
        k = self.kind
        if k == "table":
            if not isinstance(value, dict):
                return ctx.fail(key, f"must be a table, got {_tname(value)}")
            return self.section.validate(value, ctx, prefix=key)
        if k == "tables":
            if isinstance(value, dict):
                value = [value]
            if not isinstance(value, list) or not all(isinstance(v, dict) for v in value):
                return ctx.fail(key, f"must be an array of tables ([[{key}]]), got {_tname(value)}")
            return [self.section.validate(v, ctx, prefix=f"{key}[{i}]") for i, v in enumerate(value)]
        if k == "any":
            return value
        if k in ("vec", "list"):
            if not isinstance(value, list):
                return ctx.fail(key, f"must be a list, got {_tname(value)}")
            if self.length is not None:
                lo, hi = (self.length, self.length) if isinstance(self.length, int) else self.length
                if not lo <= len(value) <= hi:
                    want = lo if lo == hi else f"{lo} to {hi}"
                    return ctx.fail(key, f"must have {want} items, got {len(value)}")
            item = self.item or (Field("float") if k == "vec" else Field("any"))
            out = [item.validate(v, f"{key}[{i}]", ctx) for i, v in enumerate(value)]
            return self._bounds(out, key, ctx)
        if k == "bool":
            if not isinstance(value, bool):
                return ctx.fail(key, f"must be true or false, got {_tname(value)}")
            return value
        if k == "int":
            if isinstance(value, bool) or not isinstance(value, int):
                return ctx.fail(key, f"must be an integer, got {_tname(value)}")
            return self._bounds(value, key, ctx)
        if k == "float":
            if isinstance(value, bool) or not isinstance(value, (int, float)):
                return ctx.fail(key, f"must be a number, got {_tname(value)}")
            value = float(value)
            if not math.isfinite(value):
                return ctx.fail(key, f"must be finite, got {value}")
            return self._bounds(value, key, ctx)
        if k in ("str", "path"):
            if not isinstance(value, str):
                return ctx.fail(key, f"must be a string, got {_tname(value)}")
            choices = self._choices()
            if choices is not None and value not in choices:
                return ctx.fail(key, f"must be one of {', '.join(map(str, choices))}; got {value!r}")
            if k == "path":
                p = ctx.resolve(value)
                if not p.exists():
                    return ctx.fail(key, f"file not found: {value} (looked at {p})")
                value = str(p)
            if self.check is not None:
                msg = self.check(value)
                if msg:
                    return ctx.fail(key, msg)
            return value
        raise AssertionError(k)

    def _bounds(self, value, key, ctx):
        vals = value if isinstance(value, list) else [value]
        for v in vals:
            if v is None or not isinstance(v, (int, float)):
                continue
            for op, bound, text in ((lambda a, b: a > b, self.gt, ">"), (lambda a, b: a >= b, self.ge, ">="),
                                    (lambda a, b: a < b, self.lt, "<"), (lambda a, b: a <= b, self.le, "<=")):
                if bound is not None and not op(v, bound):
                    unit = f" {self.unit}" if self.unit else ""
                    return ctx.fail(key, f"must be {text} {bound}{unit}, got {v}")
        choices = self._choices()
        if choices is not None and not isinstance(value, list) and value not in choices:
            return ctx.fail(key, f"must be one of {', '.join(map(str, choices))}; got {value!r}")
        if self.check is not None:
            msg = self.check(value)
            if msg:
                return ctx.fail(key, msg)
        return value


@dataclass
class Section:
    """A TOML table with known keys; unknown keys are errors."""

    fields: dict[str, Field]
    doc: str = ""
    check: Callable[[dict], list[tuple[str, str]]] | None = None

    def defaults(self) -> dict:
        """The table a scene gets when it leaves this one out: every field's default (copied).

        A section with a required field has no such table: ValueError names the field.
        """
        missing = [k for k, f in self.fields.items() if f.required]
        if missing:
            raise ValueError(f"no defaults: {', '.join(missing)} required")
        return {k: copy.deepcopy(f.default) for k, f in self.fields.items()}

    def validate(self, data: dict, ctx: "Context", prefix: str = "") -> dict:
        out = {}
        for key in data:
            if key not in self.fields:
                known = ", ".join(sorted(self.fields)) or "(none)"
                hint = _close_match(key, self.fields)
                ctx.fail(_join(prefix, key), f"unknown key{hint}; valid keys: {known}")
        for key, f in self.fields.items():
            full = _join(prefix, key)
            if key in data:
                out[key] = f.validate(data[key], full, ctx)
            elif f.required:
                ctx.fail(full, f"is required ({f.doc})" if f.doc else "is required")
            else:
                out[key] = f.default
        if self.check is not None and not ctx.errors:
            for key, msg in self.check(out) or []:
                ctx.fail(_join(prefix, key), msg)
        return out


@dataclass
class Context:
    """Where validation of one scene file stands: the file (for messages), the folder that
    relative paths start from, and the problems found so far (:class:`SceneError`)."""

    file: str
    base: Path
    errors: list = field(default_factory=list)

    def fail(self, key, reason):
        self.errors.append(SceneError(reason, file=self.file, key=key))
        return None

    def resolve(self, value: str) -> Path:
        p = Path(value).expanduser()
        return p if p.is_absolute() else (self.base / p).resolve()


def _join(prefix, key):
    return f"{prefix}.{key}" if prefix else key


def _tname(v):
    return {dict: "a table", list: "a list", str: "a string", bool: "a boolean",
            int: "an integer", float: "a number"}.get(type(v), type(v).__name__)


def _close_match(key, known):
    from ..errors import did_you_mean

    return did_you_mean(key, known)
