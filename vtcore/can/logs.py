"""Reading and writing python-can log files in chunks: candump ``.log``, ``.asc``, ``.blf``, ``.trc``, ``.csv``.

python-can parses and writes every format. What this module adds:

- streaming: :func:`iter_batches` yields :class:`~vtcore.can.frames.FrameBatch` chunks of at
  most ``chunk`` frames, so a log larger than memory is decoded with one chunk in memory;
- nothing lost silently: python-can's text readers either stop at the first bad
  line (candump, csv) or skip lines they do not recognise (asc, trc). We hand
  python-can blocks of lines; when a block yields fewer messages than it has
  frame lines, or raises, it is split in halves until the bad lines are
  isolated (a few extra parses per bad line), and each is counted as
  ``unparsable_line`` with its line number. Lines that are legitimately not
  frames (headers, comments, events) are counted as ``meta_lines``.
- BLF (binary): frames missing against the object count in the file header are
  counted as ``truncated``; a corrupt object ends the read and is counted too.
"""

from __future__ import annotations

import contextlib
import io
import math
import os
import re
from pathlib import Path

import numpy as np

from ..errors import FormatError, InputError
from ..inputs import TextLines, check_input, check_output_file, clean, open_binary, os_error
from .frames import MAX_TIMESTAMP_S, FrameBatch, Summary

FORMATS = (".log", ".asc", ".blf", ".trc", ".csv")

_ASC_HEADER = re.compile(r"^(date\s|base\s|//|(no\s+)?internal\s+events\s+logged|begin\s+triggerblock|"
                         r"end\s+triggerblock|\d+\.\d+\s+start\s+of\s+measurement)", re.IGNORECASE)
_ASC_EVENT = re.compile(r"^\d+\.\d+\s+(\d+\s+(statistic:|chipstat|sv:|j1939tp)|CAN\s+\d+\s+Status)", re.IGNORECASE)


def log_format(path) -> str:
    suffix = Path(path).suffix.lower()
    if suffix not in FORMATS:
        raise InputError(f"unknown log format {suffix!r}; valid: {', '.join(FORMATS)}", file=path)
    return suffix


# ----------------------------------------------------------------------------- reading
def _reader_for(fmt: str, text: str):
    import can

    buf = io.StringIO(text)
    if fmt == ".log":
        return can.io.CanutilsLogReader(buf)
    if fmt == ".asc":
        return can.io.ASCReader(buf)
    if fmt == ".trc":
        return can.io.TRCReader(buf)
    if fmt == ".csv":
        return can.io.CSVReader(buf)
    raise AssertionError(fmt)


def _is_frame_line(fmt: str, line: str) -> bool | None:
    """True: must yield one message. False: legitimately not a frame (meta). None: blank."""
    s = line.strip()
    if not s:
        return None
    if fmt == ".asc":
        return not (_ASC_HEADER.match(s) or _ASC_EVENT.match(s))
    if fmt == ".trc":
        return not s.startswith(";")
    return True


def _header_lines(fmt: str, fh) -> list[str]:
    """Lines at the top of the file that every block handed to python-can must start with.

    ``fh``: a :class:`~vtcore.inputs.TextLines` (``readline`` and ``push_back``).
    """
    header = []
    if fmt == ".csv":
        first = fh.readline()
        if first:
            header.append(first)
    elif fmt in (".trc", ".asc"):
        while True:
            line = fh.readline()
            if not line:
                break
            s = line.strip()
            if (fmt == ".trc" and (s.startswith(";") or not s)) or \
                    (fmt == ".asc" and (not s or re.match(r"^(date\s|base\s|//|(no\s+)?internal\s+events)", s, re.I))):
                header.append(line)
                continue
            fh.push_back(line)
            break
        if fmt == ".asc":
            # ASCReader consumes the first line after its header; make sure it is ours.
            if not any(re.match(r"^\s*(no\s+)?internal\s+events", h, re.I) for h in header):
                header.append("no internal events logged\n")
    return header


def _parse_block(fmt, header, lines, linenos, out_msgs, out_lines, summary, first_call=True):
    """Parse ``lines`` with python-can; isolate bad lines by halving. Appends to ``out_*``."""
    kinds = [_is_frame_line(fmt, ln) for ln in lines]
    expect = sum(1 for k in kinds if k)
    try:
        msgs = list(_reader_for(fmt, "".join(header) + "".join(lines)))
    except Exception:  # python-can raises ValueError, IndexError, binascii.Error, ...
        msgs = None
    if msgs is not None and len(msgs) == expect:
        fl = [n for n, k in zip(linenos, kinds) if k]
        out_msgs.extend(msgs)
        out_lines.extend(fl)
        summary.meta_lines += sum(1 for k in kinds if k is False)
        return
    if len(lines) == 1:
        if msgs:            # python-can found a frame where we did not expect one: keep it
            out_msgs.extend(msgs)
            out_lines.extend([linenos[0]] * len(msgs))
        elif kinds[0] is False:
            summary.meta_lines += 1
        elif kinds[0]:
            summary.reject("unparsable_line", 1, [linenos[0]])
        return
    h = len(lines) // 2
    _parse_block(fmt, header, lines[:h], linenos[:h], out_msgs, out_lines, summary, False)
    _parse_block(fmt, header, lines[h:], linenos[h:], out_msgs, out_lines, summary, False)


def _valid_id_time(m) -> bool:
    """An identifier that fits its 11 or 29 bits and a finite timestamp: python-can parses
    ``FFFFFFFFFFF#..``, ``(nan)`` and ``(1e308)`` without complaint, and either would wrap or poison the columns."""
    limit = 0x1FFFFFFF if m.is_extended_id else 0x7FF
    t = m.timestamp
    return isinstance(m.arbitration_id, int) and 0 <= m.arbitration_id <= limit and \
        isinstance(t, (int, float)) and math.isfinite(t) and abs(t) <= MAX_TIMESTAMP_S


def _messages_to_batch(msgs, lines, summary) -> FrameBatch:
    """Columns of ``msgs``; error/remote/FD frames and DLC/data mismatches are counted, not kept."""
    keep, keep_lines = [], []
    for m, ln in zip(msgs, lines):
        if m.is_error_frame or m.is_remote_frame or m.is_fd or len(m.data) > 8:
            summary.frames_read += 1
            summary.reject("not_data_frame", 1, [ln])
        elif m.dlc != len(m.data) or not _valid_id_time(m):
            summary.frames_read += 1
            summary.reject("malformed_frame", 1, [ln])
        else:
            keep.append(m)
            keep_lines.append(ln)
    return FrameBatch.from_messages(keep, np.asarray(keep_lines, np.int64))


def iter_batches(path, chunk: int = 65536, summary: Summary | None = None):
    """Yield :class:`FrameBatch` chunks (at most ``chunk`` frames each) of the log at ``path``.

    ``summary`` (a :class:`Summary`) receives line counts and the rejections of
    this stage (unparsable lines, truncation, non-data frames). The file is read
    lazily: memory holds one chunk.
    """
    path = Path(path)
    fmt = log_format(path)
    check_input(path, "log file")  # a folder or a named pipe is refused before opening
    summary = summary if summary is not None else Summary()
    chunk = max(int(chunk), 1)
    if fmt == ".blf":
        yield from _iter_blf(path, chunk, summary)
        return
    # not strict: a line that is not UTF-8 is one unparsable line (counted), not a lost log
    with TextLines(path, "log file", strict=False) as fh:
        header = _header_lines(fmt, fh)
        lineno = sum(1 for h in header if h != "no internal events logged\n")
        summary.lines_read += lineno
        summary.meta_lines += lineno
        # python-can cost per block is dominated by per-line work; blocks of ~4k lines keep
        # the halving search for bad lines cheap.
        block = min(chunk, 4096)
        pend_msgs, pend_lines = [], []
        while True:
            lines = []
            for _ in range(block):
                ln = fh.readline()
                if not ln:
                    break
                lines.append(ln)
            if not lines:
                break
            nos = list(range(lineno + 1, lineno + 1 + len(lines)))
            lineno += len(lines)
            summary.lines_read += len(lines)
            _parse_block(fmt, header, lines, nos, pend_msgs, pend_lines, summary)
            while len(pend_msgs) >= chunk:
                yield _messages_to_batch(pend_msgs[:chunk], pend_lines[:chunk], summary)
                pend_msgs, pend_lines = pend_msgs[chunk:], pend_lines[chunk:]
        if pend_msgs:
            yield _messages_to_batch(pend_msgs, pend_lines, summary)


class _Bounded(io.RawIOBase):
    """A binary file whose ``read(n)`` asks for at most the bytes left in it.

    python-can's BLFReader reads ``size - header`` bytes for the file header and each object,
    sizes taken from the file (up to 4 GiB); a buffered ``read(n)`` allocates ``n`` bytes
    before it reads, so one corrupt size field was a 4 GiB allocation (MemoryError under a
    memory limit) for a file of a few kB.
    """

    def __init__(self, fh):
        super().__init__()
        self._fh = fh
        self._size = os.fstat(fh.fileno()).st_size

    def readable(self):
        return True

    def read(self, n=-1):
        left = max(self._size - self._fh.tell(), 0)
        return self._fh.read(left if n is None or n < 0 else min(n, left))

    def close(self):
        self._fh.close()
        super().close()


def _iter_blf(path, chunk, summary):
    import can

    fh = _Bounded(open_binary(path, "log file"))
    try:
        reader = can.io.BLFReader(fh)
    except Exception as exc:
        fh.close()
        raise FormatError(f"not a BLF file: {clean(exc)}", file=path) from None
    announced = int(reader.object_count)
    got = 0
    pend = []
    try:
        it = iter(reader)
        while True:
            try:
                m = next(it)
            except StopIteration:
                break
            except Exception as exc:  # BLFParseError, zlib.error: the rest of the file is lost
                summary.notes.append(f"BLF read stopped after {got} objects: {type(exc).__name__}: {clean(exc)}")
                break
            got += 1
            pend.append(m)
            if len(pend) >= chunk:
                yield _messages_to_batch(pend, np.arange(got - len(pend) + 1, got + 1), summary)
                pend = []
        if pend:
            yield _messages_to_batch(pend, np.arange(got - len(pend) + 1, got + 1), summary)
    finally:
        reader.stop()
    summary.lines_read += got
    if announced > got:
        summary.reject("truncated", announced - got)


def read_log(path, summary: Summary | None = None) -> FrameBatch:
    """The whole log as one :class:`FrameBatch` (use :func:`iter_batches` for large logs)."""
    return FrameBatch.concat(list(iter_batches(path, summary=summary)))


# ----------------------------------------------------------------------------- writing
def write_log(path, batches, channel: str = "vcan0") -> int:
    """Write frames (one :class:`FrameBatch` or an iterable of them) with python-can's writer
    for the suffix of ``path``. Atomic: written to a temporary file renamed at the end.

    Note: the asc, trc and blf writers store times relative to the first frame
    (their formats say so); candump .log and .csv keep absolute times. All
    python-can writers clamp a timestamp that goes backwards to the previous one.
    Returns the number of frames written.
    """
    import can

    path = Path(path)
    fmt = log_format(path)
    if isinstance(batches, FrameBatch):
        batches = [batches]
    check_output_file(path, key="output")
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise os_error(exc, path, key="output") from None
    tmp = path.with_name(f".{path.stem}.{os.getpid()}.tmp{fmt}")
    n = 0
    try:
        kwargs = {"channel": channel} if fmt == ".log" else {}
        writer = {".log": can.io.CanutilsLogWriter, ".asc": can.io.ASCWriter, ".blf": can.io.BLFWriter,
                  ".trc": can.io.TRCWriter, ".csv": can.io.CSVWriter}[fmt](str(tmp), **kwargs)
        try:
            for b in batches:
                if len(b) and not np.isfinite(b.timestamps).all():
                    # candump would write "(nan)", a line no reader takes back
                    raise InputError("frames with non-finite timestamps; refusing to write them", file=path,
                                     key="timestamps")
                for msg in b.to_messages(channel=None if fmt == ".log" else 0):
                    writer.on_message_received(msg)
                    n += 1
        finally:
            writer.stop()
        os.replace(tmp, path)
    except OSError as exc:
        with contextlib.suppress(OSError):
            tmp.unlink()
        raise os_error(exc, path, key="output") from None
    except BaseException:
        if tmp.exists():
            tmp.unlink()
        raise
    return n
