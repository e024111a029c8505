"""Numbers from files (docs/inputs.md): :func:`to_int`, :func:`to_float`, :func:`int_array` and
:func:`float_array` check the target dtype's bounds and finiteness before converting, and name the
file, key and line of a bad value.
"""

from __future__ import annotations

import math

import numpy as np

from ..errors import InputError
from .text import clean

def _where(file, key, line):
    return {"file": None if file is None else clean(file, 300), "key": key, "line": line}


def to_int(value, *, dtype=np.int64, lo: int | None = None, hi: int | None = None,
           file=None, key: str | None = None, line: int | None = None) -> int:
    """``value`` (int, or a decimal/0x string, or an integral float) as a Python int within
    ``dtype``'s range and ``[lo, hi]``; InputError naming file/key/line otherwise."""
    where = _where(file, key, line)
    if isinstance(value, (bool, np.bool_)):
        raise InputError("must be an integer, got a boolean", **where)
    if isinstance(value, (int, np.integer)):
        v = int(value)
    elif isinstance(value, (float, np.floating)):
        if not math.isfinite(value) or value != math.floor(value):
            raise InputError(f"must be an integer, got {clean(value)}", **where)
        v = int(value)
    elif isinstance(value, str):
        try:
            v = int(value.strip(), 0) if value.strip()[:2].lower() in ("0x", "0o", "0b") else int(value.strip())
        except ValueError:
            raise InputError(f"must be an integer, got {clean(repr(value))}", **where) from None
    else:
        raise InputError(f"must be an integer, got {type(value).__name__}", **where)
    info = np.iinfo(dtype)
    low = info.min if lo is None else max(lo, info.min)
    high = info.max if hi is None else min(hi, info.max)
    if not low <= v <= high:
        raise InputError(f"must be in {low}..{high}, got {clean(v, 40)}", **where)
    return v


def to_float(value, *, lo: float | None = None, hi: float | None = None, gt: float | None = None,
             file=None, key: str | None = None, line: int | None = None) -> float:
    """``value`` (a number or a numeric string) as a finite float within ``[lo, hi]`` and ``> gt``."""
    where = _where(file, key, line)
    if isinstance(value, (bool, np.bool_)):
        raise InputError("must be a number, got a boolean", **where)
    try:
        v = float(value) if isinstance(value, (int, float, np.number, str)) else None
    except (ValueError, OverflowError):
        v = None
    if v is None:
        raise InputError(f"must be a number, got {clean(repr(value))}", **where)
    if not math.isfinite(v):
        raise InputError(f"must be finite, got {clean(value)}", **where)
    if (lo is not None and v < lo) or (hi is not None and v > hi):
        raise InputError(f"must be in [{lo}, {hi}], got {v:g}" if lo is not None and hi is not None else
                         f"must be >= {lo:g}, got {v:g}" if lo is not None else f"must be <= {hi:g}, got {v:g}",
                         **where)
    if gt is not None and not v > gt:
        raise InputError(f"must be > {gt:g}, got {v:g}", **where)
    return v


def int_array(values, *, dtype=np.int64, lo: int | None = None, hi: int | None = None,
              file=None, key: str | None = None, line: int | None = None) -> np.ndarray:
    """``values`` (nested lists of ints or an array) as an array of ``dtype``, bounds checked first."""
    where = _where(file, key, line)
    try:
        try:
            a = np.asarray(values)
        except OverflowError:  # Python ints past int64/uint64: checked one by one below
            a = np.asarray(values, dtype=object)
        if a.dtype == object or a.dtype.kind in "US":
            a = np.asarray(values, dtype=np.float64) if a.dtype.kind in "US" else a
            if a.dtype == object:
                flat = [to_int(v, dtype=dtype, lo=lo, hi=hi, file=file, key=key, line=line)
                        for v in np.ravel(a)]
                a = np.array(flat, dtype=dtype).reshape(np.shape(a))
    except InputError:
        raise
    except (ValueError, OverflowError, TypeError):
        raise InputError("must be a list of integers", **where) from None
    if a.dtype.kind == "b" or a.dtype.kind not in "iuf":
        raise InputError(f"must be integers, got {a.dtype.kind!r} values", **where)
    if a.dtype.kind == "f":
        if not np.isfinite(a).all() or (a != np.floor(a)).any():
            raise InputError("must be integers (finite, no fraction)", **where)
    info = np.iinfo(dtype)
    low = info.min if lo is None else max(lo, info.min)
    high = info.max if hi is None else min(hi, info.max)
    if a.size:
        mn, mx = a.min(), a.max()
        if (a.dtype.kind == "f" and (float(mn) < low or float(mx) > high)) or \
                (a.dtype.kind != "f" and (int(mn) < low or int(mx) > high)):
            bad = mn if (float(mn) < low) else mx
            raise InputError(f"must be in {low}..{high}, got {clean(bad, 40)}", **where)
    return a.astype(dtype)


def float_array(values, *, finite: bool = True, shape: tuple | None = None,
                file=None, key: str | None = None, line: int | None = None) -> np.ndarray:
    """``values`` as float64, refusing strings, booleans, non-finite numbers (when ``finite``) and a
    wrong ``shape`` (``None`` entries match any length)."""
    where = _where(file, key, line)
    try:
        a = np.asarray(values)
        if a.dtype.kind in "bUSOV" and not (a.dtype == object and a.size == 0):
            if a.dtype == object:
                a = np.asarray(values, dtype=np.float64)
                if any(isinstance(v, (bool, str)) for v in np.ravel(np.asarray(values, dtype=object))):
                    raise TypeError
            else:
                raise TypeError
        a = a.astype(np.float64)
    except (ValueError, TypeError, OverflowError):
        raise InputError("must be numbers", **where) from None
    if shape is not None and a.size == 0 and a.ndim == 1 and len(shape) > 1 and shape[0] is None \
            and None not in shape[1:]:
        a = a.reshape((0,) + tuple(shape[1:]))  # [] is no rows: a PLY without faces has meta.faces == []
    if shape is not None and (a.ndim != len(shape) or any(s is not None and s != n for s, n in zip(shape, a.shape))):
        want = " x ".join("N" if s is None else str(s) for s in shape)
        raise InputError(f"must have shape ({want}), got {a.shape}", **where)
    if finite and not np.isfinite(a).all():
        raise InputError("must be finite numbers (no NaN or infinity)", **where)
    return a
