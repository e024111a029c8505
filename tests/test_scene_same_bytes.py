"""The same scene gives the same bytes in any process (issue 34).

A scene run after other work in the same process (a contact solve outside any scene, caches of
kernels, operators, skin grids and meshes warm, a warm-up at another force, other scenes' state)
must write the same
``arrays.npz`` as the same scene run first in a fresh ``vtcore run`` process. The sweep
benchmark checks the same against dask workers (``vtcore bench sweep``: identical arrays).
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import numpy as np

from vtcore.scene import run_scene

ROOT = Path(__file__).resolve().parents[1]
DEMO = ROOT / "scenes" / "demo.toml"
CUBE = ROOT / "scenes" / "press_cube_3mm.toml"
FAST = ["output.plots=false", "task.readings=2"]
#: a grid fine enough that the FFTs run threaded and the solve iterates many times
DEMO_SETS = FAST + ["layer.grid_spacing=0.0003"]


def fresh_run(scene, out, sets):
    """``vtcore run`` in a new process, as a user runs it."""
    args = [a for s in sets for a in ("--set", s)]
    res = subprocess.run([sys.executable, "-m", "vtcore", "run", str(scene), "--out", str(out), *args],
                         capture_output=True, text=True, timeout=600,
                         env={**os.environ, "VTCORE_PROGRESS": "0", "PYTHONPATH": str(ROOT)})
    assert res.returncode == 0, res.stderr[-2000:]
    return out / "arrays.npz"


def test_scene_after_other_scenes_gives_fresh_bytes(tmp_path):
    # In this process: a contact solve outside any scene (all BLAS threads: the contact benchmark's
    # problems, which filled the finite layer's cached tables with other last bits and made the
    # sweep benchmark's serial loop differ from dask by 2e-10 Pa), another scene, then the demo at
    # another force (the sweep benchmark's warm-up), then the demo at the force compared.
    from vtcore.contact.peers import layer_domain

    layer_domain()
    run_scene(CUBE, tmp_path / "cube", overrides=FAST)
    run_scene(DEMO, tmp_path / "warm", overrides=DEMO_SETS + ["task.force=4.0"])
    run_scene(DEMO, tmp_path / "warm2", overrides=DEMO_SETS + ["task.force=4.5"])
    fresh = fresh_run(DEMO, tmp_path / "fresh", DEMO_SETS + ["task.force=4.5"])
    warm = tmp_path / "warm2" / "arrays.npz"
    if warm.read_bytes() != fresh.read_bytes():  # name the arrays that differ, and by how much
        a, b = np.load(warm), np.load(fresh)
        diff = {k: float(np.max(np.abs(a[k] - b[k]))) for k in a.files if a[k].tobytes() != b[k].tobytes()}
        raise AssertionError(f"arrays differ from a fresh process: {diff}")
    # and the other scene, run first in this process, is what a fresh process writes too
    cube = fresh_run(CUBE, tmp_path / "cube_fresh", FAST)
    assert (tmp_path / "cube" / "arrays.npz").read_bytes() == cube.read_bytes()
