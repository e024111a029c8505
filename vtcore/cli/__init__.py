"""The ``vtcore`` command.

Each module in this package that defines ``register(subparsers)`` adds one
command group (``run``, ``scenes``, ``layout``, ``can``, ...), so a new group
never edits a shared list. Errors from bad input (``vtcore.errors.VtError``)
are printed as one message without a traceback, exit status 2.
"""

from __future__ import annotations

import argparse
import functools
import importlib
import pkgutil
import sys
import warnings

from .. import __version__
from .._io import Terminated, check_terminated, sigterm_raises
from ..errors import VtError, meant_for_users


class _Parser(argparse.ArgumentParser):
    """argparse with the one-line error every other vtcore error has (sub-commands inherit it)."""

    def error(self, message):
        self.exit(2, f"vtcore: error: {_error_lines(f'{self.prog}: {message} (see {self.prog} -h)')}\n")


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(
        prog="vtcore", description="Robot-skin simulation and tools: run scenes, lay out skins, decode CAN.")
    parser.add_argument("--version", action="version", version=f"vtcore {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    for mod in sorted(pkgutil.iter_modules(__path__), key=lambda m: m.name):
        if mod.name.startswith("_"):
            continue
        module = importlib.import_module(f"{__name__}.{mod.name}")
        if hasattr(module, "register"):
            module.register(sub)
    return parser


def _error_lines(text) -> str:
    """``text`` as one line: line breaks (a message quoting a file's lines) become `` / ``, control
    bytes are escaped (docs/inputs.md: an error is one line)."""
    from ..inputs import clean

    return " / ".join(clean(line.strip(), 2000) for line in str(text).splitlines() if line.strip()) or ""


def error_text(exc) -> str:
    """The one ``vtcore: error:`` line of an error."""
    return f"vtcore: error: {_error_lines(exc)}"


def print_error(exc, details: bool = False) -> None:
    """Print ``exc`` as one line on stderr; with ``details``, its detail lines after it, indented."""
    print(error_text(exc), file=sys.stderr)
    if details:
        from ..inputs import clean

        for line in getattr(exc, "details", None) or []:
            print(f"  {clean(line, 2000)}", file=sys.stderr)


def show_warning(message, category, filename, lineno, file=None, line=None) -> None:
    """How a command shows a warning no sub-command collected: one ``vtcore: warning:`` line (no
    source line) if it is meant for the user (vtcore's own, numerical), nothing if it is a library's
    note to its programmers (``DeprecationWarning`` and kin: vtcore.errors.meant_for_users)."""
    if meant_for_users(category):
        print(f"vtcore: warning: {_error_lines(message)}", file=sys.stderr)


@functools.lru_cache(maxsize=1)
def _parser() -> argparse.ArgumentParser:
    """The parser, built once a process: building it registers every command group (and argparse looks
    up its messages' translations), a third of a small command's time when main() is called in a loop."""
    return build_parser()


def main(argv: list[str] | None = None) -> int:
    parser = _parser()
    try:
        args = parser.parse_args(argv)
    except SystemExit as exc:  # --help, --version (0) or a usage error (2): a status, like every other outcome
        return exc.code if isinstance(exc.code, int) else 2
    if not getattr(args, "func", None):
        parser.print_help(sys.stderr)
        return 2
    try:
        with sigterm_raises(), warnings.catch_warnings():
            warnings.showwarning = show_warning
            rc = int(args.func(args) or 0)
            check_terminated()  # a SIGTERM deferred (during an import) or swallowed still ends in 143
            return rc
    except VtError as exc:
        print_error(exc, details=bool(getattr(args, "details", False)))
        return 2
    except OSError as exc:
        if isinstance(exc, BrokenPipeError):
            # `vtcore scenes | head`: the reader left; stop quietly like other Unix tools.
            sys.stderr.close()
            return 0
        # the file system refused (read-only folder, disk full, permission): not a bug, one line
        where = f"{exc.filename}: " if exc.filename else ""
        print(f"vtcore: error: {_error_lines(where + (exc.strerror or str(exc)))}", file=sys.stderr)
        return 2
    except Terminated:
        print("vtcore: terminated", file=sys.stderr)
        return 143
    except KeyboardInterrupt:
        print("vtcore: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
