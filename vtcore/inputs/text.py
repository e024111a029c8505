"""Files and text (docs/inputs.md): :func:`check_input` refuses what is not a regular file before
opening it; :func:`read_text` / :class:`TextLines` decode UTF-8 (a byte-order mark accepted) and refuse
anything else with the byte offset of the first bad byte; :func:`clean` keeps control bytes out of messages.
"""

from __future__ import annotations

import codecs
import os
import re
import stat
from pathlib import Path
from typing import Any

from ..errors import FormatError, InputError

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


def fmt_bytes(n: float) -> str:
    """``n`` bytes in binary units for a message: ``"1.5 GiB"``."""
    for unit in ("B", "KiB", "MiB", "GiB", "TiB", "PiB"):
        if abs(n) < 1024 or unit == "PiB":
            return f"{n:.3g} {unit}"
        n /= 1024
    return f"{n:.3g} PiB"


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
        raise InputError(f"{what} is larger than {fmt_bytes(limit)}", file=clean(path, 300))
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
                raise FormatError(f"a line longer than {fmt_bytes(MAX_LINE_BYTES)} near byte offset "
                                  f"{self._offset}: binary data, not text lines", file=clean(self.path, 300))
            if self._eof or not self._fill():
                line, self._rest = self._rest, ""
                if line.endswith("\r"):
                    line = line[:-1]
                return line + "\n" if line else ""
