"""The contact package's one root finder, and its modules' import graph (no cycles, no private names)."""

from __future__ import annotations

import ast
from pathlib import Path

import numpy as np
import pytest

import vtcore.contact
from vtcore.contact.roots import illinois
from vtcore.errors import UnreachableTargetError


def test_illinois_finds_the_root_of_a_monotone_function_inside_the_bracket():
    calls = []

    def f(x):
        calls.append(x)
        return x ** 3 + x

    x, fx, steps = illinois(f, 10.0, 0.0, 0.0, 4.0, 68.0, ftol=1e-12, max_steps=100)
    assert abs(x ** 3 + x - 10.0) <= 1e-12 and fx == pytest.approx(10.0, abs=1e-12)
    assert all(0.0 < c < 4.0 for c in calls) and steps == len(calls) < 30  # regula falsi alone stalls


def test_illinois_treats_an_unreachable_evaluation_as_too_far():
    def f(x):
        if x > 1.5:
            raise UnreachableTargetError("beyond the layer")
        return x

    x, fx, _ = illinois(f, 1.0, 0.0, 0.0, 3.0, 3.0, ftol=1e-9, max_steps=200)
    assert fx == pytest.approx(1.0, abs=1e-9) and x == pytest.approx(1.0, abs=1e-9)


def test_illinois_stops_at_the_step_limit_and_reports_the_last_value():
    x, fx, steps = illinois(np.tanh, 0.5, -1.0, np.tanh(-1.0), 30.0, 1.0, ftol=0.0, max_steps=3)
    assert steps == 3 and fx == pytest.approx(np.tanh(x))


def _contact_imports():
    root = Path(vtcore.contact.__file__).parent
    graph, private = {}, []
    for path in root.glob("*.py"):
        deps = set()
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.ImportFrom) and node.level == 1:
                mods = [node.module] if node.module else [a.name for a in node.names]
                deps.update(m.split(".")[0] for m in mods)
                if node.module:
                    private += [f"{path.stem} <- {node.module}.{a.name}" for a in node.names
                                if a.name.startswith("_") and not a.name.startswith("__")]
        graph[path.stem] = deps & {p.stem for p in root.glob("*.py")}
    return graph, private


def test_contact_modules_import_each_other_without_cycles_or_private_names():
    graph, private = _contact_imports()
    assert not private, private
    state = {}

    def visit(n, trail):
        if state.get(n) == 1:
            raise AssertionError(f"import cycle: {' -> '.join(trail + [n])}")
        if state.get(n) == 2:
            return
        state[n] = 1
        for m in sorted(graph.get(n, ())):
            visit(m, trail + [n])
        state[n] = 2

    for n in sorted(graph):
        visit(n, [])
    assert "press" not in graph["curved"] and "curved" in graph["press"]
