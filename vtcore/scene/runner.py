"""Running a scene and writing its results (the results contract of DESIGN.md).

``DIR/result.json``: ``scene``, ``task``, ``seed``, ``effects`` (``[{"name",
"seconds"}]`` in run order: the listed effects that changed an output, docs/inputs.md "The
effect contract"), ``effects_not_applied`` (the listed ones that changed none), ``metrics``
(flat name -> number), ``versions``, ``seconds``, ``arrays`` (name -> shape), ``figures``.
``DIR/arrays.npz``: standard names (``positions``, ``normals``, ``timestamps``,
``frames``, ``pressure``, ``force``, ``edge``) where the task produces them.
``DIR/*.png`` and ``DIR/report.md``.
"""

from __future__ import annotations

import functools
import math
import os
import platform
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable

import numpy as np

from .. import __version__
from .._io import atomic_write, check_terminated, save_npz, staged_into, write_json
from ..errors import Cancelled, VtError
from .._progress import progress
from ..contact.grid import spread_timer
from . import registry
from .loader import Scene, load_scene
from .notices import Notices, warnings_of


@dataclass
class TaskResult:
    """What a task hands back to the runner.

    metrics: flat name -> float (snake_case, unit suffix: ``force_n``).
    arrays: name -> ndarray (standard names where they apply).
    figures: file stem -> callable ``(path) -> None`` writing a PNG, or a matplotlib Figure.
    sections: extra markdown blocks for ``report.md`` (tables, notes), in order.
    files: names of extra files the task wrote into the output folder.
    """

    metrics: dict[str, float] = field(default_factory=dict)
    arrays: dict[str, np.ndarray] = field(default_factory=dict)
    figures: dict[str, Any] = field(default_factory=dict)
    sections: list[str] = field(default_factory=list)
    files: list[str] = field(default_factory=list)
    extra: dict[str, Any] = field(default_factory=dict)
    #: name -> what NaN means in that array (documented where the task documents its arrays): any
    #: other array holding NaN or infinity is reported as a warning of the run (:func:`nonfinite_arrays`)
    nan_meaning: dict[str, str] = field(default_factory=dict)


@dataclass
class RunContext:
    """Everything a task needs besides the scene.

    rng: the run's generator (seeded from the scene); use ``ctx.child_rng(tag)``
    for independent, reproducible streams. pipeline: the listed effects.
    out: the output folder (tasks may write extra files there).
    """

    scene: Scene
    pipeline: registry.Pipeline
    out: Path
    rng: np.random.Generator
    progress: Callable = progress

    def child_rng(self, tag: str) -> np.random.Generator:
        """A generator for one purpose, independent of the call order of others."""
        import zlib

        return np.random.default_rng([self.scene.seed, zlib.crc32(tag.encode())])


def versions() -> dict[str, str]:
    """The versions of vtcore, Python and the packages a result depends on (a fresh dict each call)."""
    return dict(_versions())


@functools.lru_cache(maxsize=1)
def _versions() -> dict[str, str]:
    # read once a process: the packages' metadata lookups took 50 ms of every scene run (a fuzz run's
    # or a sweep's runs in one process import the same packages)
    import importlib.metadata as md

    out = {"vtcore": __version__, "python": platform.python_version()}
    for pkg in ("numpy", "scipy", "scikit-learn", "trimesh", "open3d", "potpourri3d",
                "python-can", "cantools", "scikit-image", "matplotlib"):
        try:
            out[pkg] = md.version(pkg)
        except md.PackageNotFoundError:
            pass
    return out


def _clean_metrics(metrics: dict) -> dict:
    out = {}
    for k, v in metrics.items():
        if isinstance(v, (bool, np.bool_)):
            out[k] = bool(v)
        elif isinstance(v, (int, np.integer)):
            out[k] = int(v)
        else:
            v = float(v)
            out[k] = v if math.isfinite(v) else None  # JSON has no NaN; None says "undefined"
    return out


def single_threaded_blas():
    """A context in which numpy's and scipy's BLAS use one thread.

    A BLAS product sums in an order that depends on its thread count, so without
    this a run's last bits (1e-11 Pa in the contact solver) depend on the machine's
    cores and on who started the process (dask starts its workers with one thread):
    the same seed would not give the same bytes everywhere. The products of a scene
    are small, so one thread costs little; parallel work is several runs at once
    (``vtcore sweep``). scipy's BLAS is loaded first, as threadpoolctl limits only
    loaded libraries.
    """
    import scipy.linalg  # noqa: F401  (loads scipy's own OpenBLAS, so it is limited too)
    from threadpoolctl import threadpool_limits

    return threadpool_limits(limits=1, user_api="blas")


#: Keys of the library functions a scene's values reach, as the scene names them: an error raised
#: deep inside (``grid.spacing`` in vtcore.contact) names the value the user set.
SCENE_KEYS = {"grid.spacing": "layer.grid_spacing", "thickness": "layer.thickness",
              "samples_per_taxel": "layer.samples_per_taxel", "geometry": "layer.geometry",
              "direction": "task.direction", "dt": "task.dt"}


def nonfinite_arrays(arrays: dict, documented: dict | None = None) -> dict[str, int]:
    """``{name: count}`` of the float arrays in ``arrays`` holding NaN or infinity, except those whose
    NaN is ``documented`` (name -> meaning)."""
    out = {}
    for name, a in arrays.items():
        a = np.asarray(a)
        if a.dtype.kind in "fc" and name not in (documented or {}):
            bad = int(a.size - np.count_nonzero(np.isfinite(a)))
            if bad:
                out[name] = bad
    return out


def run_scene(scene: Scene | str | Path, out: str | Path, overrides: list[str] | None = None) -> dict:
    """Run ``scene`` and write its results into ``out``; return the ``result.json`` object.

    Warnings raised inside the run are collected (:mod:`.notices`), not printed: ``result["warnings"]``
    lists them. An error of bad input (or of a target the physics cannot reach) raised without a file
    names the scene file and the scene's key (:data:`SCENE_KEYS`), ``task`` where it has none.
    """
    if not isinstance(scene, Scene):
        scene = load_scene(scene, overrides)
    with warnings_of(scene.path) as notes:
        try:
            return _run_staged(scene, out, notes)
        except VtError as exc:  # bad input, or a target the physics cannot reach: one line naming file and key
            err = exc
            if getattr(exc, "file", None) is None and not isinstance(exc, Cancelled):
                key = getattr(exc, "key", None)
                err = scene.error(SCENE_KEYS.get(key, key) or "task", getattr(exc, "reason", None) or str(exc))
            err.details = list(getattr(err, "details", None) or []) + notes.lines()  # `vtcore run --details`
            if err is exc:
                raise
            raise err from None


def _run_staged(scene: Scene, out, notes) -> dict:
    # Everything is written into a staging folder inside ``out`` and moved in at the end: a run
    # that fails or is interrupted (Ctrl-C, SIGTERM) leaves no half set of files. The commit is
    # all or nothing: a SIGTERM that arrived before it (or was swallowed by a C extension) stops
    # it; one that arrives during it is raised by the CLI once every file is in (exit 143).
    with staged_into(out, prefix=".vtcore-run-") as stage:
        return _run(scene, stage, notes)


def _run(scene: Scene, out: Path, notes: Notices | None = None) -> dict:
    t0 = time.perf_counter()
    ctx = RunContext(scene=scene, pipeline=None, out=out, rng=np.random.default_rng(scene.seed))
    task = registry.TASKS[scene.task]
    registry.check_task_effects(task, scene.effects, scene.error)
    ctx.pipeline = registry.Pipeline(scene.effects, ctx)
    notes = notes if notes is not None else Notices(scene.path)
    with single_threaded_blas(), spread_timer() as spread:
        res: TaskResult = task.run(scene, ctx)
    _count_spreading(ctx.pipeline, spread, notes)
    seconds = time.perf_counter() - t0

    figures = []
    if scene["output"]["plots"]:
        from ..plots import pyplot

        plt = pyplot()
        for stem, fig in res.figures.items():
            check_terminated()
            name = f"{stem}.png"
            with atomic_write(out / name, "wb") as fh:
                if callable(fig) and not hasattr(fig, "savefig"):
                    fig(fh)
                else:
                    fig.savefig(fh, format="png", dpi=120, bbox_inches="tight")
                    plt.close(fig)
            figures.append(name)
    for name in ctx.pipeline.not_applied():
        notes.add("listed, but changed no output in this run (not applied, or applied with no effect on "
                  "these readings)", key=f"effects.{name}")
    for name, bad in nonfinite_arrays(res.arrays, res.nan_meaning).items():
        notes.add(f"{bad} of its values are NaN or infinity (not a documented meaning of this array)",
                  key=f"arrays.{name}")
    if scene["output"]["arrays"] and res.arrays:
        save_npz(out / "arrays.npz", res.arrays)

    result = {
        "scene": str(scene.path),
        "name": scene.name,
        "task": scene.task,
        "seed": scene.seed,
        "effects": ctx.pipeline.report(),
        "effects_not_applied": ctx.pipeline.not_applied(),
        "metrics": _clean_metrics(res.metrics),
        "versions": versions(),
        "seconds": round(seconds, 4),
        "arrays": {k: list(np.shape(v)) for k, v in sorted(res.arrays.items())},
        # what a NaN means in the arrays whose task documents one (docs/inputs.md); NaN elsewhere is a warning
        "arrays_nan": {k: v for k, v in sorted(res.nan_meaning.items()) if k in res.arrays},
        "figures": figures,
        "files": sorted(res.files),
        **res.extra,
        "warnings": [dict(w) for w in notes.items],
    }
    write_json(out / "result.json", result)
    with atomic_write(out / "report.md", "w", encoding="utf-8") as fh:
        fh.write(render_report(scene, result, res))
    return result


def _count_spreading(pipeline, clock: dict, notes) -> None:
    """Count the stress spread through the layer inside solvers and probers (``clock``, from
    :func:`~vtcore.contact.grid.spread_timer`) as the soft_layer effect's work; spreading without
    ``[effects.soft_layer]`` breaks the effect contract and is said, not hidden."""
    if not clock["calls"]:
        return
    if pipeline.has("soft_layer"):
        pipeline.add_time("soft_layer", clock["seconds"])
    else:
        notes.add(f"the task spread the stress through the layer {clock['calls']} times without "
                  "[effects.soft_layer] (a bug of the task: please report it)", key="effects.soft_layer")


def render_report(scene: Scene, result: dict, res: TaskResult) -> str:
    lines = [f"# {scene.name}", ""]
    desc = scene["scene"]["description"]
    if desc:
        lines += [desc, ""]
    lines += [f"Scene `{scene.path}`, task `{scene.task}`, seed {scene.seed}, "
              f"{result['seconds']:.2f} s, vtcore {__version__}.", ""]
    if result["metrics"]:
        lines += ["## Metrics", "", "| metric | value |", "|---|---|"]
        for k, v in result["metrics"].items():
            lines.append(f"| `{k}` | {_fmt(v)} |")
        lines.append("")
    for block in res.sections:
        lines += [block.rstrip(), ""]
    lines += ["## Effects", ""]
    if result["effects"]:
        lines += ["| effect | seconds |", "|---|---|"]
        lines += [f"| {e['name']} | {e['seconds']:.4f} |" for e in result["effects"]]
    elif not result.get("effects_not_applied"):
        lines.append("None listed: an ideal sensor, no soft layer, no noise.")
    if result.get("effects_not_applied"):
        lines += ["", "Listed but changing no output in this run: "
                  + ", ".join(f"`{n}`" for n in result["effects_not_applied"]) + "."]
    lines.append("")
    if result.get("warnings"):
        lines += ["## Warnings", ""]
        lines += [f"- `{w['key']}`: {w['message']}" + (f" ({w['count']} times)" if w["count"] > 1 else "")
                  for w in result["warnings"]]
        lines.append("")
    if result["figures"]:
        lines += ["## Plots", ""]
        lines += [f"![{f}]({f})" for f in result["figures"]]
        lines.append("")
    return "\n".join(lines)


def _fmt(v):
    if v is None:
        return "undefined"
    if isinstance(v, float):
        return f"{v:.6g}"
    return str(v)
