"""Layering (DESIGN.md): vtcore.filters imports only layout and contact (and the shared
helpers), never a package to its right; the contour code in vtcore.control never imports
vtcore.scene. Checked on the source, including imports inside functions."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

import vtcore

ROOT = Path(vtcore.__file__).resolve().parent
RIGHT_OF_FILTERS = {"control", "scene", "augment", "categorize", "can", "cli"}


def vtcore_imports(path: Path) -> set[str]:
    """First-level vtcore packages a module imports (absolute or relative, anywhere in it)."""
    pkg = path.relative_to(ROOT.parent).with_suffix("").parts[:-1]  # e.g. ("vtcore", "filters")
    out = set()
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.ImportFrom):
            if node.level:
                base = list(pkg[: len(pkg) - node.level + 1]) + (node.module.split(".") if node.module else [])
                names = [base + [a.name] for a in node.names] if not node.module else [base]
            else:
                names = [(node.module or "").split(".")]
            for parts in names:
                if parts[0] == "vtcore" and len(parts) > 1:
                    out.add(parts[1])
        elif isinstance(node, ast.Import):
            for a in node.names:
                parts = a.name.split(".")
                if parts[0] == "vtcore" and len(parts) > 1:
                    out.add(parts[1])
    return out


def test_the_checker_sees_relative_imports_inside_functions(tmp_path):
    fake = ROOT / "filters" / "bench.py"
    assert "layout" in vtcore_imports(fake) and "_io" in vtcore_imports(fake)


@pytest.mark.parametrize("path", sorted((ROOT / "filters").glob("*.py")), ids=lambda p: p.name)
def test_filters_import_nothing_to_their_right(path):
    bad = vtcore_imports(path) & RIGHT_OF_FILTERS
    assert not bad, f"{path.name} imports vtcore.{', vtcore.'.join(sorted(bad))}"


@pytest.mark.parametrize("name", ["contour.py", "bench.py"])
def test_contour_control_does_not_import_the_scene_runner(name):
    bad = vtcore_imports(ROOT / "control" / name) & {"scene", "cli", "augment", "categorize", "can"}
    assert not bad, f"control/{name} imports vtcore.{', vtcore.'.join(sorted(bad))}"
