"""bpy and open3d in one process: with bpy loaded first (as inside Blender) vtcore's open3d
paths work on both generations; vtcore itself never loads open3d at import time
(tests/test_foundation_package.py walks every module for that)."""

from __future__ import annotations

import os
import subprocess
import sys

import pytest

pytest.importorskip("bpy")
pytestmark = pytest.mark.blender


def test_bpy_then_vtcore_open3d_paths(root):
    # A fresh process: the test process already has bpy (tests/conftest.py).
    code = (
        "import bpy, sys\n"
        "import numpy as np, trimesh\n"
        "from vtcore.contact.proximity import default_backend, signed_distance\n"
        "assert 'open3d' not in sys.modules\n"
        "assert default_backend() == 'open3d'\n"
        "ball = trimesh.creation.icosphere(subdivisions=3, radius=1.0)\n"
        "d = signed_distance(np.array([[0, 0, 2.0], [0, 0, 0.5]]), ball, 'open3d')\n"
        "assert 'open3d' in sys.modules\n"
        "bpy.ops.wm.read_factory_settings(use_empty=True)\n"
        "print(bpy.app.version_string, np.round(d, 2).tolist())\n"
    )
    res = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=root, timeout=300,
                         env={**os.environ, "PYTHONPATH": str(root)})
    assert res.returncode == 0, res.stderr[-3000:]
    version, dist = res.stdout.strip().rsplit(" [", 1)
    near, inside = (float(x) for x in dist.rstrip("]").split(","))
    assert near == pytest.approx(-1.0, abs=0.02) and inside == pytest.approx(0.5, abs=0.02), res.stdout  # + inside
