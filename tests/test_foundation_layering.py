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
    "inputs": set(),  # the reading discipline: only the shared modules (errors)
    "layout": set(),
    "robot": {"layout"},
    "contact": {"layout"},
    "filters": {"layout", "contact"},
    "augment": {"layout", "contact"},
    "categorize": {"layout", "contact"},
    "can": {"layout", "contact", "filters"},
    "calibrate": {"layout", "contact", "can", "filters"},
    "control": {"layout", "contact", "filters", "augment", "categorize"},
    "learn": {"layout", "contact", "augment"},
    "evaluate": {"layout", "contact", "filters"},
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


# ---------------------------------------------------------------------------
# Import cycles (also inside a package) and private names used across modules.
#
# The graph has one node per module file of a tree (``pkg/x/__init__.py`` is ``pkg.x``) and
# an edge for every import anywhere in a module, inside functions too: an import deferred
# into a function still ties the two modules together, it only hides the cycle from Python.


def module_names(root: Path) -> dict[str, Path]:
    """``{"pkg.sub.mod": path}`` for every .py file below ``root`` (a package folder)."""
    out = {}
    for path in sorted(root.rglob("*.py")):
        parts = path.relative_to(root.parent).with_suffix("").parts
        if parts[-1] == "__init__":
            parts = parts[:-1]
        out[".".join(parts)] = path
    return out


def _resolve(node: ast.ImportFrom, module: str, is_package: bool) -> list[str]:
    """Absolute dotted names ``node`` may refer to: ``base`` and ``base.<alias>`` for each alias."""
    if node.level:
        here = module.split(".") if is_package else module.split(".")[:-1]
        base = here[: len(here) - node.level + 1]
        base = ".".join(base + (node.module.split(".") if node.module else []))
    else:
        base = node.module or ""
    return [base] + [f"{base}.{a.name}" for a in node.names]


def import_graph(*roots: Path) -> tuple[dict[str, set[str]], list[tuple[str, int, str]]]:
    """Edges ``module -> modules it imports`` among the trees at ``roots`` (package folders),
    and every use of a private name of another module: ``(module, line, "other._name")``.

    A private name is one starting with a single underscore: imported with
    ``from other import _name``, or read as ``other._name`` from an imported module.
    """
    mods = {k: v for root in roots for k, v in module_names(root).items()}
    edges: dict[str, set[str]] = {m: set() for m in mods}
    private = []
    for mod, path in mods.items():
        is_pkg = path.name == "__init__.py"
        tree = ast.parse(path.read_text(encoding="utf-8"))
        aliases: dict[str, str] = {}  # local name -> module of the tree it is bound to
        for node in ast.walk(tree):
            if isinstance(node, ast.Import):
                for a in node.names:
                    if a.name in mods:
                        edges[mod].add(a.name)
                        aliases[a.asname or a.name] = a.name
            elif isinstance(node, ast.ImportFrom):
                base, *subs = _resolve(node, mod, is_pkg)
                for a, sub in zip(node.names, subs):
                    if sub in mods:  # the name is a module: from . import press
                        edges[mod].add(sub)
                        aliases[a.asname or a.name] = sub
                    elif base in mods:  # a name defined in (or re-exported by) base
                        edges[mod].add(base)
                        if a.name.startswith("_") and not a.name.startswith("__") and base != mod:
                            private.append((mod, node.lineno, f"{base}.{a.name}"))
        for node in ast.walk(tree):
            if (isinstance(node, ast.Attribute) and isinstance(node.value, ast.Name)
                    and node.value.id in aliases and node.attr.startswith("_")
                    and not node.attr.startswith("__") and aliases[node.value.id] != mod):
                private.append((mod, node.lineno, f"{aliases[node.value.id]}.{node.attr}"))
        edges[mod].discard(mod)
    return edges, sorted(set(private))


def import_cycles(edges: dict[str, set[str]]) -> list[list[str]]:
    """The import cycles of ``edges``: one list of modules per strongly connected component
    with more than one module (Tarjan's algorithm; iterative, so deep trees are fine)."""
    index, low, on_stack, stack, out = {}, {}, set(), [], []
    counter = 0
    for start in sorted(edges):
        if start in index:
            continue
        work = [(start, iter(sorted(edges[start])))]
        index[start] = low[start] = counter
        counter += 1
        stack.append(start)
        on_stack.add(start)
        while work:
            v, it = work[-1]
            w = next(it, None)
            if w is not None:
                if w not in index:
                    index[w] = low[w] = counter
                    counter += 1
                    stack.append(w)
                    on_stack.add(w)
                    work.append((w, iter(sorted(edges.get(w, ())))))
                elif w in on_stack:
                    low[v] = min(low[v], index[w])
                continue
            work.pop()
            if work:
                low[work[-1][0]] = min(low[work[-1][0]], low[v])
            if low[v] == index[v]:
                comp = []
                while True:
                    w = stack.pop()
                    on_stack.discard(w)
                    comp.append(w)
                    if w == v:
                        break
                if len(comp) > 1:
                    out.append(sorted(comp))
    return sorted(out)


TREES = (ROOT, ROOT.parent / "addon")  # the add-on's uses of vtcore count too


def test_no_import_cycles():
    edges, _ = import_graph(*TREES)
    cycles = import_cycles(edges)
    assert not cycles, "import cycles (modules that import each other, directly or round a loop): " + \
        "; ".join(" <-> ".join(c) for c in cycles)


def test_no_private_name_used_across_modules():
    _, private = import_graph(*TREES)
    assert not private, "private names used outside their module (make them public with a docstring, " \
        "or move them to where they are used): " + "; ".join(f"{m}:{line} uses {name}" for m, line, name in private)


def _plant(tmp_path, files: dict[str, str]) -> Path:
    root = tmp_path / "pkg"
    for rel, text in files.items():
        p = root / rel
        p.parent.mkdir(parents=True, exist_ok=True)
        p.write_text(text, encoding="utf-8")
    return root


def test_the_checker_finds_planted_cycles_and_private_imports(tmp_path):
    root = _plant(tmp_path, {
        "__init__.py": "from .a import f\n",
        "a.py": "from .b import g\n\ndef f():\n    return g()\n",
        # the cycle's other half hides in a function, as a deferred import would
        "b.py": "def g():\n    from .a import f\n    return 1\n",
        "sub/__init__.py": "",
        "sub/c.py": "from ..a import _hidden\nfrom .. import b as B\n\ndef h():\n    return B._secret\n",
        "sub/d.py": "from . import e\n",
        "sub/e.py": "import pkg.sub.d\n",
        "ok.py": "from .a import f\nfrom .sub import c\n\n_mine = 1\nprint(_mine, __name__)\n",
    })
    edges, private = import_graph(root)
    assert edges["pkg.sub.c"] == {"pkg.a", "pkg.b"} and edges["pkg.ok"] == {"pkg.a", "pkg.sub.c"}
    assert import_cycles(edges) == [["pkg.a", "pkg.b"], ["pkg.sub.d", "pkg.sub.e"]]
    assert private == [("pkg.sub.c", 1, "pkg.a._hidden"), ("pkg.sub.c", 5, "pkg.b._secret")]


def test_the_checker_passes_a_clean_tree(tmp_path):
    root = _plant(tmp_path, {
        "__init__.py": "from .a import f\nfrom .b import g\n",
        "a.py": "import numpy as np\n\ndef f():\n    return np.zeros(1)\n",
        "b.py": "from .a import f\nfrom . import a\n\ndef g():\n    return a.f(), f()\n",
    })
    edges, private = import_graph(root)
    assert import_cycles(edges) == [] and private == []
