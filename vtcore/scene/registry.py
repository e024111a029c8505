"""Registries of scene sections, tasks and effects, and the effect pipeline.

Packages do not register themselves (they must not import ``vtcore.scene``);
small adapter modules under ``vtcore/scene/sections``, ``vtcore/scene/tasks``
and ``vtcore/scene/effects`` do, and are discovered by :func:`discover`, so
adding a task or an effect never edits a shared list.

An effect is listed in a scene by its table, ``[effects.noise]`` (possibly
empty). The pipeline instantiates exactly the listed effects; an unlisted
effect's factory is never called, so nothing of it is computed. Effects run in
physical order (``stage`` then ``order``), not in the order they are written.
"""

from __future__ import annotations

import importlib
import pkgutil
import time
from dataclasses import dataclass, field
from typing import Any, Callable

import numpy as np

from ..contact.grid import spread_timer
from ..errors import InputError
from .notices import scene_key
from .schema import Field, Section

#: Stages in the order data passes through them.
STAGES = ("contact", "sensor", "transport")
#: The effects of each stage, for the tasks' declarations of what they can apply (TaskSpec.effects).
CONTACT_EFFECTS = ("soft_layer", "object_compliance")
SENSOR_EFFECTS = ("gain", "baseline", "drift", "noise", "saturation", "quantisation", "sampling")


@dataclass
class EffectSpec:
    """An optional physical or sensor phenomenon.

    ``factory(params: dict, ctx) -> object`` builds the effect; the object's
    public methods (conventionally ``apply(state, ctx)``) are timed by the
    pipeline. ``stage`` is one of :data:`STAGES`.
    """

    name: str
    stage: str
    order: int
    factory: Callable[[dict, Any], Any]
    params: Section = field(default_factory=lambda: Section({}))
    doc: str = ""


@dataclass
class TaskSpec:
    """What a scene does (press, contour, augment, ...).

    ``run(scene, ctx) -> TaskResult``; ``params`` validates the ``[task]`` table;
    ``sections`` names the top-level tables the task needs (validated as required).
    ``sweep_summary(scene, rows, grid_keys) -> str`` (optional): a markdown block for
    ``vtcore sweep``'s report, built from the sweep's rows (``vtcore.sweep``'s records:
    ``grid`` values, ``seed``, ``status``, ``metrics``), e.g. the categorize designer's table.
    """

    name: str
    run: Callable
    params: Section = field(default_factory=lambda: Section({}))
    sections: tuple[str, ...] = ()
    doc: str = ""
    sweep_summary: Callable | None = None
    #: the effects the task can apply (the effect contract, docs/inputs.md): a scene listing any other
    #: is refused naming the effect and the task
    effects: tuple[str, ...] = ()


SECTIONS: dict[str, Field] = {}
TASKS: dict[str, TaskSpec] = {}
EFFECTS: dict[str, EffectSpec] = {}


def register_section(name: str, spec: Field) -> None:
    """Declare a top-level table (or array of tables) of scene files."""
    SECTIONS[name] = spec


def register_task(spec: TaskSpec) -> TaskSpec:
    TASKS[spec.name] = spec
    return spec


def register_effect(spec: EffectSpec) -> EffectSpec:
    if spec.stage not in STAGES:
        raise ValueError(f"effect {spec.name}: stage must be one of {STAGES}")
    EFFECTS[spec.name] = spec
    return spec


_DISCOVERED = False


def discover() -> None:
    """Import every adapter module under ``sections``, ``effects`` and ``tasks``."""
    global _DISCOVERED
    if _DISCOVERED:
        return
    for sub in ("sections", "effects", "tasks"):
        pkg = importlib.import_module(f"{__package__}.{sub}")
        for mod in sorted(pkgutil.iter_modules(pkg.__path__), key=lambda m: m.name):
            if not mod.name.startswith("_"):
                importlib.import_module(f"{pkg.__name__}.{mod.name}")
    _DISCOVERED = True


def _readings(state):
    """What an effect's ``apply`` works on, copied: ``(readings, keys)``, the array (or a state dict's
    ``frames`` or ``pressure``) and the dict's keys (an effect may add an output: a displacement);
    None when there is nothing to compare."""
    x = state.get("frames", state.get("pressure")) if isinstance(state, dict) else state
    keys = frozenset(state) if isinstance(state, dict) else frozenset()
    try:
        return (np.array(x, dtype=float, copy=True) if x is not None else np.zeros(0)), keys
    except (TypeError, ValueError):
        return None


def _changed(before, after) -> bool:
    """Whether ``apply`` changed its readings (or added an output), from two :func:`_readings`."""
    if before is None or after is None or before[1] != after[1]:
        return True
    a, b = before[0], after[0]
    return a.shape != b.shape or a.tobytes() != b.tobytes()


class _Timed:
    """Proxy that adds the time spent in every method call to its effect's total."""

    def __init__(self, name, obj, totals, used):
        self._name, self._obj, self._totals, self._used = name, obj, totals, used

    def __getattr__(self, attr):
        val = getattr(self._obj, attr)
        if not callable(val) or attr.startswith("_"):
            return val

        def timed(*args, **kwargs):
            t0 = time.perf_counter()
            before = _readings(args[0]) if attr == "apply" and args else None
            try:
                # its warnings name the effect; a spreading inside it is its own time, not a solver's
                with scene_key(f"effects.{self._name}"), spread_timer():
                    out = val(*args, **kwargs)
                # applied = changed what it was given (a floor of 0 on readings already >= 0 changes nothing)
                if attr != "apply" or _changed(before, _readings(out)):
                    self._used.add(self._name)
                return out
            except InputError as exc:
                if exc.file is not None or exc.key not in EFFECTS[self._name].params.fields:
                    raise
                # a parameter of the effect ("rate") as the scene names it ("effects.sampling.rate")
                raise InputError(exc.reason, key=f"effects.{self._name}.{exc.key}", line=exc.line) from None
            finally:
                self._totals[self._name] += time.perf_counter() - t0

        return timed


class Pipeline:
    """The effects a scene lists, built once, in the order they run.

    ``pipeline.apply(stage, state, ctx)`` runs every listed effect of ``stage``
    on ``state`` (each effect's ``apply`` returns the new state);
    ``pipeline.get(name)`` returns a listed effect (timed) or ``None``, for
    effects that a model consults rather than applies (a soft layer).
    An effect counts as applied once any of its methods runs, or once
    :meth:`add_time` adds work done for it elsewhere (a spreading inside a solver);
    :meth:`report` lists only the applied ones, :meth:`not_applied` the others.
    """

    def __init__(self, listed: dict[str, dict], ctx=None):
        discover()
        self.seconds: dict[str, float] = {}
        self.used: set[str] = set()
        self._effects: dict[str, _Timed] = {}
        order = sorted(listed, key=lambda n: (STAGES.index(EFFECTS[n].stage), EFFECTS[n].order, n))
        for name in order:
            self.seconds[name] = 0.0
            t0 = time.perf_counter()
            obj = EFFECTS[name].factory(listed[name], ctx)
            self.seconds[name] += time.perf_counter() - t0
            self._effects[name] = _Timed(name, obj, self.seconds, self.used)

    @property
    def names(self) -> list[str]:
        return list(self._effects)

    def has(self, name: str) -> bool:
        return name in self._effects

    def get(self, name: str):
        return self._effects.get(name)

    def stage(self, stage: str) -> list[str]:
        return [n for n in self._effects if EFFECTS[n].stage == stage]

    def apply(self, stage: str, state, ctx=None):
        for name in self.stage(stage):
            state = self._effects[name].apply(state, ctx)
        return state

    def add_time(self, name: str, seconds: float) -> None:
        """Count ``seconds`` of work done for the listed effect ``name`` outside its own methods."""
        self.seconds[name] += float(seconds)
        self.used.add(name)

    def report(self) -> list[dict]:
        """``[{"name", "seconds"}]`` of the applied effects, in the order they run (construction included)."""
        return [{"name": n, "seconds": round(self.seconds[n], 6)} for n in self._effects if n in self.used]

    def not_applied(self) -> list[str]:
        """The listed effects that changed nothing in this run (never applied)."""
        return [n for n in self._effects if n not in self.used]


def check_task_effects(task: TaskSpec, listed, error) -> None:
    """Refuse a listed effect the task cannot apply: ``error(key, message)`` builds the one-line error."""
    for name in listed:
        if name not in task.effects:
            can = ", ".join(task.effects) or "none"
            raise error(f"effects.{name}", f"task '{task.name}' cannot apply the effect '{name}' (it applies: "
                                           f"{can}); remove [effects.{name}]")
