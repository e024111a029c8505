"""Layering (DESIGN.md): data flows layout -> contact -> filters/augment/categorize -> control.

A package imports only packages to its left; ``scene`` composes them and ``cli``
drives everything. Checked on the source, so imports inside functions count too.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

import vtcore

ROOT = Path(vtcore.__file__).resolve().parent
SHARED = {"errors", "geometry", "inputs", "_io", "_bench", "_progress", "plots", "tolerances", "__version__"}
PACKAGES = sorted(p.name for p in ROOT.iterdir() if (p / "__init__.py").exists())
ALLOWED = {
    "layout": set(),
    "contact": {"layout"},
    "filters": {"layout", "contact"},
    "augment": {"layout", "contact"},
    "categorize": {"layout", "contact"},
    "can": {"layout", "contact", "filters"},
    "control": {"layout", "contact", "filters", "augment", "categorize"},
    "scene": set(PACKAGES) - {"cli", "scene", "sweep"},
    "sweep": set(PACKAGES) - {"cli", "sweep"},
    "cli": set(PACKAGES) - {"cli"},
}


def vtcore_imports(path: Path) -> set[str]:
    """First-level vtcore names a module imports (absolute or relative, anywhere in it)."""
    pkg = path.relative_to(ROOT.parent).with_suffix("").parts[:-1]  # e.g. ("vtcore", "filters")
    return imports_in(path.read_text(encoding="utf-8"), pkg)


def imports_in(source: str, pkg: tuple[str, ...]) -> set[str]:
    out = set()
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.ImportFrom):
            if node.level:
                base = list(pkg[: len(pkg) - node.level + 1]) + (node.module.split(".") if node.module else [])
                names = [base + [a.name] for a in node.names] if not node.module else [base]
            else:
                names = [(node.module or "").split(".")]
        elif isinstance(node, ast.Import):
            names = [a.name.split(".") for a in node.names]
        else:
            continue
        out.update(parts[1] for parts in names if parts[0] == "vtcore" and len(parts) > 1)
    return out


def test_every_package_has_a_rule():
    assert set(PACKAGES) == set(ALLOWED)


def test_the_checker_sees_relative_imports_inside_functions():
    source = "import vtcore.can\ndef f():\n    from ..control import contour\n    from .. import scene\n"
    assert imports_in(source, ("vtcore", "filters")) == {"can", "control", "scene"}


@pytest.mark.parametrize("package", PACKAGES)
def test_packages_import_only_to_their_left(package):
    bad = {}
    for path in sorted((ROOT / package).rglob("*.py")):
        wrong = vtcore_imports(path) - ALLOWED[package] - SHARED - {package}
        if wrong:
            bad[str(path.relative_to(ROOT))] = sorted(wrong)
    assert not bad, f"imports against the data flow: {bad}"
