"""Glue for interactive front ends (the Blender add-on): one call per user action.

Each function takes plain numpy arrays (SI units, one frame), composes the
``vtcore`` packages and returns plain arrays, so the add-on only gathers input,
calls ONE function here and writes the result. Nothing here imports ``bpy``;
everything is testable without Blender. No algorithm lives here: these are
thin compositions of ``vtcore.layout``, ``vtcore.contact``, ``vtcore.filters``
and ``vtcore.augment``.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..errors import InputError
from ..layout import Layout, skin_mesh


@dataclass
class SceneOutput:
    """What the add-on shows of a scene run.

    layout : the scene's skin layout (positions in the end-effector frame, metres).
    triangles : (F, 3) int, the skin mesh over the taxels.
    pressure : (N,) pascals at the taxels, mean over the readings.
    response : (N,) sensor counts (mean over readings) after the listed sensor
        effects, or the pressure when the scene lists none.
    result : the run's ``result.json`` object.
    out : the output folder.
    """

    layout: Layout
    triangles: np.ndarray
    pressure: np.ndarray
    response: np.ndarray
    result: dict = field(default_factory=dict)
    out: Path | None = None


def run_scene_file(path, out, overrides=None) -> SceneOutput:
    """Run the scene file ``path`` into folder ``out`` and return what to display.

    Raises the scene's ``SceneError`` (naming file and key) on a bad scene and
    ``InputError`` when the run produced no per-taxel arrays.
    """
    from .loader import load_scene
    from .runner import run_scene
    from .sections.layout import build_layout

    path = Path(path)
    if not path.is_file():
        raise InputError("is not a readable scene file", file=path)
    scene = load_scene(path, overrides)
    out = Path(out)
    result = run_scene(scene, out)
    npz = out / "arrays.npz"
    if not npz.is_file():
        raise InputError("the run wrote no arrays.npz (is [output] arrays = false?)", file=path)
    with np.load(npz) as z:
        arrays = {k: z[k] for k in z.files}
    if "positions" not in arrays:
        raise InputError(f"task {scene.task!r} writes no taxel positions to show", file=path)
    layout = build_layout(scene)
    if len(layout) != len(arrays["positions"]):
        # The task laid its own taxels: show those, without module information.
        n = len(arrays["positions"])
        layout = Layout(arrays["positions"], arrays.get("normals", np.tile([0.0, 0.0, 1.0], (n, 1))),
                        arrays.get("taxel_ids", np.arange(n)), np.zeros(n, np.int64))
    n = len(layout)
    pressure = _mean_frames(arrays.get("pressure"), n)
    response = _mean_frames(arrays.get("frames"), n)
    if response is None:
        response = pressure
    if pressure is None:
        pressure = response if response is not None else np.zeros(n)
        response = pressure
    try:
        tri = skin_mesh(layout).triangles
    except ValueError:
        tri = np.zeros((0, 3), np.int64)
    return SceneOutput(layout, np.asarray(tri, np.int64), pressure, response, result, out)


def _mean_frames(a, n):
    if a is None:
        return None
    a = np.asarray(a, dtype=np.float64)
    if a.ndim == 2 and a.shape[1] == n:
        return a.mean(axis=0)
    if a.ndim == 1 and a.shape[0] == n:
        return a
    return None
