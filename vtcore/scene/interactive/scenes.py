"""Run a scene file for a front end and hand back what to show."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ...errors import InputError
from ...layout import Layout
from .skin import skin_triangles


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
    replay: object = None  # a vtcore.can.timeline.Replay for a ``replay`` scene
    output: dict = field(default_factory=dict)  # the scene's [output] (render settings)


def run_scene_file(path, out, overrides=None, fps: float | None = None) -> SceneOutput:
    """Run the scene file ``path`` into folder ``out`` and return what to display.

    For a ``replay`` scene, ``replay`` holds the recording prepared for playback on the
    timeline at ``fps`` (None: the scene's ``[output] fps``). Raises the scene's
    ``SceneError`` (naming file and key) on a bad scene and ``InputError`` when the run
    produced no per-taxel arrays.
    """
    from ..loader import load_scene
    from ..runner import run_scene
    from ..sections.layout import build_layout

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
    tri = skin_triangles(layout)
    replay = None
    if scene.task == "replay":
        from ...can.timeline import load_recording

        p = scene["task"]
        replay = load_recording(p["log"], layout, tri, kind=p["codec"], boards=p["boards"] or None,
                                fps=fps or scene["output"]["fps"], baseline_rows=p["baseline_rows"],
                                edge_fraction=p["edge_fraction"], min_response=p["min_response"],
                                period=p["period"] or None, window=p["window"])
    return SceneOutput(layout, tri, pressure, response, result, out, replay, dict(scene["output"]))


def _mean_frames(a, n):
    if a is None:
        return None
    a = np.asarray(a, dtype=np.float64)
    if a.ndim == 2 and a.shape[1] == n:
        return a.mean(axis=0)
    if a.ndim == 1 and a.shape[0] == n:
        return a
    return None
