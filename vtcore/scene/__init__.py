"""Scenes: the TOML schema, the effect pipeline and the runner.

``load_scene(path, overrides)`` validates a scene; ``run_scene(scene, out)``
runs it and writes ``result.json``, ``arrays.npz``, PNGs and ``report.md``.
"""

from .loader import Scene, list_scenes, load_scene
from .registry import EFFECTS, SECTIONS, TASKS, EffectSpec, Pipeline, TaskSpec, discover
from .runner import RunContext, TaskResult, run_scene

__all__ = ["Scene", "load_scene", "list_scenes", "run_scene", "RunContext", "TaskResult",
           "Pipeline", "EffectSpec", "TaskSpec", "EFFECTS", "TASKS", "SECTIONS", "discover"]
