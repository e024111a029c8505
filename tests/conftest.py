"""Shared fixtures. Blender tests live in tests/test_blender_*.py and manage bpy themselves."""

from __future__ import annotations

import importlib.util
import os
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
SCENES = ROOT / "scenes"

os.environ.setdefault("VTCORE_PROGRESS", "0")
os.environ.setdefault("MPLBACKEND", "Agg")


def pytest_configure(config):
    """Load bpy first in every process that runs tests, as Blender itself does.

    bpy and open3d both bundle libtbb under one soname and the first one loaded serves both;
    bpy 5.2's OpenVDB needs the newer one, so open3d loaded first (vtcore imports it lazily,
    e.g. in contact/proximity.py) makes a later ``import bpy`` fail on Python 3.13.
    """
    if getattr(config.option, "numprocesses", None) and not hasattr(config, "workerinput"):
        return  # the pytest-xdist controller runs no test
    if importlib.util.find_spec("bpy") is not None:
        import bpy  # noqa: F401


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
