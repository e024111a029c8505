"""List the functions and modules that are too long to read on one screen.

A function's length is counted from its ``def`` line (decorators excluded) to its
last line, docstring and comments included, as ``ast`` reports it. Run from the
repository root::

    python scripts/function_lengths.py                 # functions >= 80 lines, modules > 600 lines
    python scripts/function_lengths.py --min 100       # only functions >= 100 lines
    python scripts/function_lengths.py vtcore/can      # one package

The last lines are the counts (functions >= 100, functions >= 80, modules > 600),
so two runs can be compared before and after a change. Exit status 0 always:
this is a report, not a check.
"""
from __future__ import annotations

import argparse
import ast
import sys
from pathlib import Path

ROOTS = ("vtcore", "addon")


def functions(path: Path):
    """Yield (qualified name, first line, length in lines) of every function in one file."""
    tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))

    def walk(node, prefix):
        for child in ast.iter_child_nodes(node):
            if isinstance(child, (ast.FunctionDef, ast.AsyncFunctionDef)):
                name = f"{prefix}{child.name}"
                yield name, child.lineno, child.end_lineno - child.lineno + 1
                yield from walk(child, name + ".")
            elif isinstance(child, ast.ClassDef):
                yield from walk(child, f"{prefix}{child.name}.")
            else:
                yield from walk(child, prefix)

    yield from walk(tree, "")


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("paths", nargs="*", default=list(ROOTS),
                        help="files or folders to scan (default: vtcore addon)")
    parser.add_argument("--min", type=int, default=80, help="list functions this long or longer")
    parser.add_argument("--module-max", type=int, default=600,
                        help="list modules longer than this many lines")
    args = parser.parse_args(argv)

    files = []
    for p in map(Path, args.paths):
        files.extend(sorted(p.rglob("*.py")) if p.is_dir() else [p])

    long_functions, long_modules = [], []
    for path in files:
        n_lines = len(path.read_text(encoding="utf-8").splitlines())
        if n_lines > args.module_max:
            long_modules.append((n_lines, str(path)))
        for name, line, length in functions(path):
            if length >= args.min:
                long_functions.append((length, f"{path}:{line}", name))

    for length, where, name in sorted(long_functions, reverse=True):
        print(f"{length:5d}  {where}  {name}")
    for n_lines, where in sorted(long_modules, reverse=True):
        print(f"{n_lines:5d}  {where}  (module)")
    n100 = sum(length >= 100 for length, _, _ in long_functions)
    print(f"functions >= 100 lines: {n100}")
    print(f"functions >= {args.min} lines: {len(long_functions)}")
    print(f"modules > {args.module_max} lines: {len(long_modules)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
