"""The reading discipline every vtcore file reader follows (docs/inputs.md).

One place decides how a file becomes text and numbers, so every reader refuses
the same bad input the same way, as an :class:`~vtcore.errors.InputError` that
names the file, the line or key, and the reason:

- :func:`check_input` refuses what is not a regular file (a folder, a named pipe,
  a device) *before* opening it: opening a named pipe blocks until a writer comes.
- :func:`read_text` / :class:`TextLines`: UTF-8, a byte-order mark accepted;
  anything else (UTF-16, Latin-1, binary data with NUL bytes) is refused with the
  byte offset of the first bad byte. CR, LF and CRLF line ends are all lines.
- :func:`to_int`, :func:`int_array`, :func:`float_array`: conversions that check the
  target dtype's bounds and finiteness first (``np.array([2**70], np.int64)`` raises a bare
  ``OverflowError``; ``np.uint32(2**32)`` wraps onto a real id).
- :class:`Spec` and :func:`validate`: declarative checks of decoded records
  (JSON objects) in the scene schema's "file, key, reason" style.
- :func:`need_memory`: the resource guard. A size a user sets is checked against the
  memory budget (``VTCORE_MEMORY_BUDGET``, default 4 GiB) *before* allocating;
  :func:`need_time` the same for a loop's count against ``VTCORE_TIME_BUDGET`` (default 1 h).
- :func:`clean`: messages never copy control bytes from a file into a terminal.

Why not chardet/charset-normalizer: guessing an encoding turns a wrong file into
wrong numbers; the formats we read are ASCII/UTF-8 by definition, so refusing is right.
"""

from __future__ import annotations

import codecs
import errno
import math
import os
import re
import stat
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable

import numpy as np

from .errors import FormatError, InputError

#: Longest text line a reader accepts (bytes); a binary file without newlines is refused, not buffered.
MAX_LINE_BYTES = 1 << 20

_CONTROL = re.compile(r"[\x00-\x08\x0b-\x1f\x7f-\x9f\u2028\u2029\ufeff]")


def clean(text: Any, limit: int = 120) -> str:
    """``text`` safe to print: control bytes as ``\\xNN`` escapes, at most ``limit`` characters."""
    s = str(text)
    if len(s) > limit:
        s = s[:limit] + "..."
    return _CONTROL.sub(lambda m: f"\\x{ord(m.group()):02x}" if ord(m.group()) < 256
                        else f"\\u{ord(m.group()):04x}", s)


# ----------------------------------------------------------------------------- files
def _kind(mode: int) -> str | None:
    if stat.S_ISREG(mode):
        return None
    if stat.S_ISDIR(mode):
        return "a folder"
    if stat.S_ISFIFO(mode):
        return "a named pipe"
    if stat.S_ISSOCK(mode):
        return "a socket"
    if stat.S_ISCHR(mode) or stat.S_ISBLK(mode):
        return "a device"
    return "not a regular file"


def check_input(path, what: str = "file") -> Path:
    """``path`` as a Path after checking it names an existing regular file (not opened).

    Raises InputError: not found, a folder, a named pipe, a socket or a device.
    """
    path = Path(path)
    try:
        st = os.stat(path)  # stat never blocks, unlike open() on a FIFO
    except FileNotFoundError:
        raise InputError(f"{what} not found", file=clean(path, 300)) from None
    except OSError as exc:
        raise InputError(f"cannot read {what}: {exc.strerror}", file=clean(path, 300)) from None
    kind = _kind(st.st_mode)
    if kind:
        raise InputError(f"is {kind}, not a regular {what}", file=clean(path, 300))
    return path


def open_binary(path, what: str = "file"):
    """Open a regular file for reading in binary mode, refusing anything else first.

    Opened with ``O_NONBLOCK`` and checked again with ``fstat``, so a file swapped for a
    pipe between the check and the open cannot block either.
    """
    path = check_input(path, what)
    try:
        fd = os.open(path, os.O_RDONLY | getattr(os, "O_NONBLOCK", 0))
    except OSError as exc:
        raise InputError(f"cannot read {what}: {exc.strerror}", file=clean(path, 300)) from None
    kind = _kind(os.fstat(fd).st_mode)
    if kind:
        os.close(fd)
        raise InputError(f"is {kind}, not a regular {what}", file=clean(path, 300))
    return os.fdopen(fd, "rb")


def read_bytes(path, what: str = "file", limit: int | None = None) -> bytes:
    """The whole file as bytes; ``limit`` bytes at most (InputError when larger)."""
    with open_binary(path, what) as fh:
        try:
            data = fh.read() if limit is None else fh.read(limit + 1)
        except OSError as exc:
            raise InputError(f"cannot read {what}: {exc.strerror}", file=clean(path, 300)) from None
    if limit is not None and len(data) > limit:
        raise InputError(f"{what} is larger than {_fmt_bytes(limit)}", file=clean(path, 300))
    return data


def _encoding_error(data: bytes, path, start: int, base: int = 0) -> FormatError:
    if data[:2] in (b"\xff\xfe", b"\xfe\xff") and base == 0:
        return FormatError("UTF-16 text (byte-order mark at byte offset 0); save the file as UTF-8",
                           file=clean(path, 300))
    bad = data[start:start + 1]
    what = "a NUL byte: binary data or UTF-16, not UTF-8 text" if bad == b"\x00" else \
        f"byte 0x{bad.hex()} is not UTF-8 (Latin-1 or another encoding?); save the file as UTF-8"
    return FormatError(f"at byte offset {base + start}: {what}", file=clean(path, 300))


def decode(data: bytes, path, base: int = 0) -> str:
    """UTF-8 bytes -> str (a leading byte-order mark dropped); FormatError with the byte offset otherwise."""
    skip = 3 if base == 0 and data.startswith(codecs.BOM_UTF8) else 0
    nul = data.find(b"\x00", skip)
    try:
        text = data[skip:].decode("utf-8")
    except UnicodeDecodeError as exc:
        first = skip + exc.start
        raise _encoding_error(data, path, min(first, nul) if nul >= 0 else first, base) from None
    if nul >= 0:
        raise _encoding_error(data, path, nul, base)
    return text


def read_text(path, what: str = "file", limit: int | None = None) -> str:
    """A text file under the reading discipline: regular file, UTF-8 (BOM accepted), no NUL bytes.

    Line ends are left as they are (``str.splitlines`` treats CR, LF and CRLF alike).
    """
    data = read_bytes(path, what, limit)
    return decode(data, path)


class TextLines:
    """Lines of a large text file, read lazily under the same rules as :func:`read_text`.

    ``readline()`` returns one line ending in ``"\\n"`` (CR and CRLF ends are translated)
    or ``""`` at the end; ``push_back(line)`` returns a line to be read again. Lines longer
    than :data:`MAX_LINE_BYTES` are refused. Use as a context manager.

    ``strict=False`` (line-oriented logs, where one corrupt line must not cost the rest):
    bytes that are not UTF-8 become U+FFFD, so the line fails to parse and is counted by
    the caller with its line number; a UTF-16 file is still refused as a whole.
    """

    def __init__(self, path, what: str = "file", block: int = 1 << 16, strict: bool = True):
        self.path = Path(path)
        self.strict = strict
        self._fh = open_binary(path, what)
        self._block = block
        self._offset = 0          # bytes consumed from the file
        self._pending: list[str] = []
        self._rest = ""
        self._raw_rest = b""
        self._eof = False
        self._first = True

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

    def close(self):
        self._fh.close()

    def push_back(self, line: str) -> None:
        self._pending.insert(0, line)

    def _fill(self) -> bool:
        raw = self._fh.read(self._block)
        if not raw:
            self._eof = True
            if self._raw_rest:  # a multi-byte sequence cut by the end of the file
                raise _encoding_error(self._raw_rest, self.path, 0, self._offset - len(self._raw_rest))
            return False
        base = self._offset - len(self._raw_rest)
        data = self._raw_rest + raw
        self._offset += len(raw)
        if self._first:
            self._first = False
            if data[:2] in (b"\xff\xfe", b"\xfe\xff"):
                raise _encoding_error(data, self.path, 0, 0)
            if data.startswith(codecs.BOM_UTF8):
                data, base = data[3:], 3
        # keep an incomplete trailing UTF-8 sequence (at most 3 bytes) for the next block
        cut = len(data)
        for k in range(1, min(4, len(data)) + 1):
            b = data[-k]
            if b & 0xC0 == 0x80:
                continue
            if b >= 0xC0 and k < (2 if b < 0xE0 else 3 if b < 0xF0 else 4):
                cut = len(data) - k
            break
        self._raw_rest = data[cut:]
        self._rest += decode(data[:cut], self.path, base=base) if self.strict else \
            data[:cut].decode("utf-8", "replace")
        return True

    def readline(self) -> str:
        if self._pending:
            return self._pending.pop(0)
        while True:
            i = self._rest.find("\n")
            j = self._rest.find("\r")
            if j >= 0 and (i < 0 or j < i) and (j + 1 < len(self._rest) or self._eof):
                # CR or CRLF end
                line = self._rest[:j] + "\n"
                self._rest = self._rest[j + 2:] if self._rest[j + 1:j + 2] == "\n" else self._rest[j + 1:]
                return line
            if i >= 0 and (j < 0 or i < j):
                line, self._rest = self._rest[:i + 1], self._rest[i + 1:]
                return line
            if len(self._rest.encode("utf-8", "surrogatepass")) > MAX_LINE_BYTES:
                raise FormatError(f"a line longer than {_fmt_bytes(MAX_LINE_BYTES)} near byte offset "
                                  f"{self._offset}: binary data, not text lines", file=clean(self.path, 300))
            if self._eof or not self._fill():
                line, self._rest = self._rest, ""
                if line.endswith("\r"):
                    line = line[:-1]
                return line + "\n" if line else ""


# ----------------------------------------------------------------------------- numbers
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


# ----------------------------------------------------------------------------- records
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


# ----------------------------------------------------------------------------- resources
def _fmt_bytes(n: float) -> str:
    for unit in ("B", "KiB", "MiB", "GiB", "TiB", "PiB"):
        if abs(n) < 1024 or unit == "PiB":
            return f"{n:.3g} {unit}"
        n /= 1024
    return f"{n:.3g} PiB"


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
        raise InputError(f"{what} would need {_fmt_bytes(nbytes) if math.isfinite(nbytes) else 'unbounded memory'}, "
                         f"more than the memory budget of {_fmt_bytes(budget)}; {remedy or f'lower {key}'}, or raise "
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


# ----------------------------------------------------------------------------- outputs
def check_output_dir(path, key: str = "--out") -> Path:
    """Check, before any work, that ``path`` can be an output folder.

    It must be a folder or not exist yet; its nearest existing parent must be a folder we
    can write into (no regular file on the way, not read-only). Nothing is created.
    """
    path = Path(path)
    shown = clean(path, 300)
    if path.exists() and not path.is_dir():
        raise InputError("exists and is a file, not a folder; name a folder", file=shown, key=key)
    probe = path
    while not probe.exists():
        if probe.parent == probe:
            break
        probe = probe.parent
    if probe.exists() and not probe.is_dir():
        raise InputError(f"cannot be made: {clean(probe, 300)} is a file, not a folder", file=shown, key=key)
    if probe.exists() and not os.access(probe, os.W_OK | os.X_OK):
        raise InputError(f"cannot write into {clean(probe, 300)} (permission denied)", file=shown, key=key)
    return path


def check_output_file(path, key: str = "--out") -> Path:
    """Check, before any work, that a file can be written at ``path`` (its folder may be made)."""
    path = Path(path)
    if path.is_dir():
        raise InputError("is a folder; name a file", file=clean(path, 300), key=key)
    check_output_dir(path.parent, key=key)
    return path


def os_error(exc: OSError, path, key: str | None = None) -> InputError:
    """An OSError of writing as an InputError naming the path (read-only folder, disk full...)."""
    reason = exc.strerror or str(exc)
    if exc.errno == errno.ENOTDIR:
        reason = "a part of the path is a file, not a folder"
    return InputError(f"cannot write: {reason}", file=clean(path, 300), key=key)


def finite_json(obj, where: str = ""):
    """Raise InputError if ``obj`` (JSON-ready: dicts, lists, numbers) holds NaN or infinity.

    Writers call it before writing: JSON has no NaN, and a text file with ``nan`` is
    not re-readable by the readers that refuse it.
    """
    if not where:
        import json

        try:  # the common case, at C speed: plain JSON types, all finite
            json.dumps(obj, allow_nan=False)
            return
        except (ValueError, TypeError, RecursionError):
            pass  # a non-finite number (found and named below) or numpy values the walk handles
    if isinstance(obj, float) or isinstance(obj, np.floating):
        if not math.isfinite(obj):
            raise InputError(f"is {obj}; refusing to write a non-finite number", key=where or None)
    elif isinstance(obj, dict):
        for k, v in obj.items():
            finite_json(v, f"{where}.{k}" if where else str(k))
    elif isinstance(obj, (list, tuple)):
        for i, v in enumerate(obj):
            finite_json(v, f"{where}[{i}]")
    elif isinstance(obj, np.ndarray) and obj.dtype.kind == "f" and not np.isfinite(obj).all():
        raise InputError("holds NaN or infinity; refusing to write a non-finite number", key=where or None)


__all__ = ["MAX_LINE_BYTES", "Spec", "TextLines", "check_input", "check_output_dir", "check_output_file", "clean",
           "decode", "finite_json", "float_array", "int_array", "memory_budget", "need_memory", "need_time",
           "open_binary", "os_error", "read_bytes", "read_text", "time_budget", "to_float", "to_int", "validate"]
