"""Shared fixtures. Blender tests live in tests/test_blender_*.py and manage bpy themselves."""

from __future__ import annotations

import os
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
SCENES = ROOT / "scenes"

os.environ.setdefault("VTCORE_PROGRESS", "0")
os.environ.setdefault("MPLBACKEND", "Agg")


@pytest.fixture
def root() -> Path:
    return ROOT


@pytest.fixture
def scenes_dir() -> Path:
    return SCENES


def vtcore_cli(*args, cwd=None):
    """Run the ``vtcore`` command in a subprocess; returns CompletedProcess (text)."""
    import subprocess

    return subprocess.run([sys.executable, "-m", "vtcore", *map(str, args)], capture_output=True, text=True,
                          cwd=cwd or ROOT, env={**os.environ, "VTCORE_PROGRESS": "0"})


@pytest.fixture
def cli():
    return vtcore_cli


def pytest_addoption(parser):
    parser.addoption("--fuzz-long", action="store_true", default=False,
                     help="fuzz suite: 10,000 inputs per reader (or VTCORE_FUZZ_EXAMPLES=N) instead of a few dozen")
