"""Declarative checks of decoded records (JSON objects, docs/inputs.md): :class:`Spec` per key and
:func:`validate`, in the scene schema's "file, key, reason" style.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Callable

import numpy as np

from ..errors import InputError
from .conversions import float_array, int_array, to_float, to_int
from .text import clean

@dataclass
class Spec:
    """One key of a decoded record (a JSON object).

    kind: ``int``, ``float``, ``str``, ``bool``, ``list``, ``dict``, ``ints``/``floats`` (arrays),
    ``strs``/``bools`` (lists of strings / booleans), ``record`` (a nested object checked against
    ``fields``), ``any``. ``required``: the key must be present; else ``default`` (``null`` counts as
    absent). ``lo``/``hi``: bounds (numbers and array elements). ``shape``: for ``ints``/``floats``
    (``None`` entries match any length). ``dtype``: for ints. ``choices``: for ``str`` and ``int``.
    ``check``: a callable on the converted value returning an error text or None; ``each``: the same
    for every item of a ``strs`` list (the error names ``key[i]``). Arrays read from JSON are strict:
    a string or a boolean where a number belongs is an error, never converted.
    """

    kind: str
    required: bool = True
    default: Any = None
    lo: float | None = None
    hi: float | None = None
    shape: tuple | None = None
    dtype: Any = np.int64
    choices: tuple | None = None
    check: Callable[[Any], str | None] | None = None
    each: Callable[[Any], str | None] | None = None
    fields: "dict[str, Spec] | None" = None


def _has_text(value) -> bool:
    """True if a nested list holds a string, a boolean or null where numbers belong."""
    if isinstance(value, (list, tuple)):
        return any(_has_text(v) for v in value)
    return isinstance(value, (str, bool)) or value is None


def validate(record, specs: dict[str, Spec], *, file=None, prefix: str = "", line: int | None = None,
             extra: bool = True) -> dict:
    """Check ``record`` against ``specs``; return the converted values (defaults filled).

    Raises InputError naming ``file`` and ``prefix.key`` for the first problem. ``extra``:
    unknown keys are allowed (formats written by others carry fields we do not read); they are
    not in the returned dict.
    """
    def key_of(k):
        return f"{prefix}.{k}" if prefix else k

    if not isinstance(record, dict):
        raise InputError(f"must be an object (a JSON {{...}}), got {_tname(record)}", file=file,
                         key=prefix or None, line=line)
    if not extra:
        for k in record:
            if k not in specs:
                raise InputError(f"unknown key; valid keys: {', '.join(sorted(specs))}", file=file,
                                 key=key_of(clean(k, 40)), line=line)
    out = {}
    for k, s in specs.items():
        kk = key_of(k)
        if k not in record or record[k] is None:
            if s.required:
                raise InputError("is required", file=file, key=kk, line=line)
            out[k] = s.default
            continue
        out[k] = _convert(record[k], s, file, kk, line)
    return out


def _convert(v, s: Spec, file, kk: str, line):
    where = {"file": file, "key": kk, "line": line}
    if s.kind == "int":
        v = to_int(v, dtype=s.dtype, lo=s.lo, hi=s.hi, **where)
    elif s.kind == "float":
        v = to_float(v, lo=s.lo, hi=s.hi, **where)
    elif s.kind in ("ints", "floats"):
        if _has_text(v) if isinstance(v, (list, tuple)) else isinstance(v, (str, bool)):
            raise InputError("must be numbers (integers)" if s.kind == "ints" else "must be numbers",
                             **where)
        if s.kind == "ints":
            v = int_array(v, dtype=s.dtype, lo=s.lo, hi=s.hi, **where)
            if s.shape is not None:
                v = v.reshape(float_array(v, shape=s.shape, **where).shape)
        else:
            v = float_array(v, shape=s.shape, finite=False, **where)
            bad = ~np.isfinite(v)
            if bad.any():  # where, as the file's own reader says it: the row, or the number of a matrix
                k = int(np.flatnonzero(bad.ravel())[0])
                raise InputError(f"row {int(np.flatnonzero(bad.any(axis=1))[0])} is not finite (NaN or infinity)"
                                 if v.ndim == 2 and v.shape != (4, 4) else
                                 f"number {k} is {v.ravel()[k]}, not finite" if v.ndim == 2 else
                                 f"must be finite numbers: number {k} is {v.ravel()[k]}", **where)
            if (s.lo is not None and v.size and v.min() < s.lo) or (s.hi is not None and v.size and v.max() > s.hi):
                raise InputError(f"values must be in [{s.lo:g}, {s.hi:g}], got {np.abs(v).max():.3g}"
                                 if s.lo is not None and s.hi is not None else
                                 f"values must be in [{s.lo}, {s.hi}]", **where)
    elif s.kind in ("strs", "bools"):
        t = str if s.kind == "strs" else bool
        if not isinstance(v, list):
            raise InputError(f"must be a list of {'strings' if t is str else 'booleans'}, got {_tname(v)}", **where)
        for i, item in enumerate(v):
            if not isinstance(item, t):
                raise InputError(f"must be {_tname(t())}, got {_tname(item)}", file=file, key=f"{kk}[{i}]",
                                 line=line)
            msg = s.each(item) if s.each is not None else None
            if msg:
                raise InputError(msg, file=file, key=f"{kk}[{i}]", line=line)
    elif s.kind == "record":
        v = validate(v, s.fields or {}, file=file, prefix=kk, line=line)
    elif s.kind in ("str", "bool", "list", "dict"):
        t = {"str": str, "bool": bool, "list": list, "dict": dict}[s.kind]
        if not isinstance(v, t):
            raise InputError(f"must be {_tname(t())}, got {_tname(v)}", **where)
    if s.choices is not None and s.kind in ("str", "int") and v not in s.choices:
        raise InputError(f"must be one of {', '.join(map(str, s.choices))}; got {clean(repr(v), 40)}", **where)
    if s.check is not None:
        msg = s.check(v)
        if msg:
            raise InputError(msg, **where)
    return v


def _tname(v):
    return {dict: "an object", list: "a list", str: "a string", bool: "a boolean",
            int: "an integer", float: "a number", type(None): "null"}.get(type(v), type(v).__name__)
