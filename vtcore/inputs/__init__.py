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

from .conversions import float_array, int_array, to_float, to_int
from .outputs import check_output_dir, check_output_file, finite_json, os_error
from .records import Spec, validate
from .resources import memory_budget, need_memory, need_time, time_budget
from .text import MAX_LINE_BYTES, TextLines, check_input, clean, decode, open_binary, read_bytes, read_text

__all__ = ["MAX_LINE_BYTES", "Spec", "TextLines", "check_input", "check_output_dir", "check_output_file", "clean",
           "decode", "finite_json", "float_array", "int_array", "memory_budget", "need_memory", "need_time",
           "open_binary", "os_error", "read_bytes", "read_text", "time_budget", "to_float", "to_int", "validate"]
