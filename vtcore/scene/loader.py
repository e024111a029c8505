"""Reading and validating scene files.

A scene file has these top-level tables:

``[scene]``     name, description, ``seed``, ``task`` (what happens)
``[task]``      the task's own parameters (validated by the task)
``[effects.X]`` one table per effect to simulate, with its parameters
``[output]``    what to write besides ``result.json``
``[sweep]``     the grid and seeds of ``vtcore sweep`` (read by ``vtcore.sweep``; a plain
                run ignores it and runs the scene's own values once)
and the tables that sections register (``end_effector``, ``layout``, ``layer``,
``[[objects]]``, ...). Every table is checked; unknown keys are errors.
"""

from __future__ import annotations

import copy
import re
import tomllib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from ..errors import InputError, SceneError, SceneErrors
from ..inputs import clean, read_text
from . import registry
from .schema import Context, Field, Section

SCENE_SECTION = Section({
    "name": Field("str", default="", doc="short name shown in reports"),
    "description": Field("str", default=""),
    "seed": Field("int", default=0, ge=0, doc="seed of every random step"),
    "task": Field("str", choices=lambda: tuple(sorted(registry.TASKS)), doc="what the scene does"),
})

#: A scene file is a few kilobytes; anything past this is not a scene (and is not read into memory).
MAX_SCENE_BYTES = 16 << 20

OUTPUT_SECTION = Section({
    "plots": Field("bool", default=True, doc="write PNG plots and show them in report.md"),
    "arrays": Field("bool", default=True, doc="write arrays.npz"),
    # Rendering needs Blender: the add-on's Run Scene (also `blender -b`) renders what these ask;
    # `vtcore run` alone validates them and renders nothing.
    "video": Field("str", default="", choices=("", "frames", "mp4"),
                   doc="Blender: render the replay as PNG frames or an MP4 into the output folder"),
    "engine": Field("str", default="workbench", choices=("workbench", "cycles"), doc="Blender render engine"),
    "resolution": Field("vec", default=[640, 480], length=2, doc="rendered image size, pixels"),
    "samples": Field("int", default=16, ge=1, le=4096, doc="Cycles samples per pixel"),
    "fps": Field("float", default=24.0, gt=0, le=1000, unit="1/s", doc="frame rate of the rendered replay"),
})


@dataclass
class Scene:
    """A validated scene. ``data`` holds every table with defaults filled."""

    path: Path
    data: dict[str, Any]
    effects: dict[str, dict] = field(default_factory=dict)

    @property
    def seed(self) -> int:
        return self.data["scene"]["seed"]

    @property
    def task(self) -> str:
        return self.data["scene"]["task"]

    @property
    def name(self) -> str:
        return self.data["scene"]["name"] or self.path.stem

    def __getitem__(self, key):
        return self.data[key]

    def get(self, key, default=None):
        return self.data.get(key, default)

    def error(self, key: str, reason: str) -> SceneError:
        """An error about ``key`` of this scene, to raise from a task or builder."""
        return SceneError(reason, file=self.path, key=key)


def split_assignment(text: str, option: str = "--set", form: str = "key=value") -> tuple[str, str]:
    """``"a.b=rest"`` -> ``("a.b", "rest")``; an error naming ``option`` and ``form`` without a key."""
    key, eq, raw = text.partition("=")
    key = key.strip()
    if not eq or not key:
        raise SceneError(f"{option} expects {form}, got {text!r}")
    return key, raw


def parse_override(text: str) -> tuple[list[str], Any]:
    """``"layer.thickness=0.01"`` -> (["layer", "thickness"], 0.01); values are TOML."""
    key, raw = split_assignment(text)
    try:
        value = tomllib.loads(f"v = {raw}")["v"]
    except tomllib.TOMLDecodeError:
        value = raw  # a bare word: take it as a string
    return key.split("."), value


def apply_overrides(data: dict, overrides: list[str], file) -> dict:
    data = copy.deepcopy(data)
    for text in overrides or []:
        keys, value = parse_override(text)
        node = data
        for i, k in enumerate(keys[:-1]):
            nxt = node.get(k) if isinstance(node, dict) else None
            if nxt is None:
                nxt = node[k] = {}
            if isinstance(nxt, list):
                raise SceneError("--set cannot address items of an array of tables; edit the scene file",
                                 file=file, key=".".join(keys))
            if not isinstance(nxt, dict):
                raise SceneError(f"--set: {'.'.join(keys[:i + 1])} is not a table", file=file,
                                 key=".".join(keys))
            node = nxt
        node[keys[-1]] = value
    return data


def load_scene(path: str | Path, overrides: list[str] | None = None) -> Scene:
    """Read, override (``--set``) and validate a scene file.

    Raises :class:`SceneErrors` listing every problem, each naming the file and key.
    """
    registry.discover()
    path = Path(path)
    raw = apply_overrides(_read_toml(path), overrides, path)
    ctx = Context(file=str(path), base=path.parent.resolve())
    _check_tables(raw, ctx)
    data: dict[str, Any] = {}
    data["scene"] = SCENE_SECTION.validate(raw["scene"], ctx, prefix="scene")
    task = registry.TASKS.get(data["scene"].get("task") or "")

    data["output"] = OUTPUT_SECTION.validate(raw.get("output", {}), ctx, prefix="output")
    data["sweep"] = raw.get("sweep", {})
    if not isinstance(data["sweep"], dict):
        ctx.fail("sweep", "must be a table ([sweep] with grid and seeds)")
    _validate_sections(raw, data, task, ctx)
    effects = _validate_effects(raw.get("effects", {}), ctx)
    data["effects"] = effects

    if ctx.errors:
        raise SceneErrors(ctx.errors)
    return Scene(path=path, data=data, effects=effects)


def _read_toml(path: Path) -> dict:
    """The scene file's tables; a SceneError naming the file (and the line) when it cannot be read or parsed."""
    try:
        text = read_text(path, "scene file", limit=MAX_SCENE_BYTES)
    except InputError as exc:
        raise SceneError(exc.reason, file=exc.file, line=exc.line) from None
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        # Python 3.11's TOMLDecodeError has no lineno attribute; the message has it.
        m = re.search(r"at line (\d+)", str(exc))
        line = int(m.group(1)) if m else None
        raise SceneError(f"not valid TOML: {clean(exc, 200)}", file=path, line=line) from None


def _check_tables(raw: dict, ctx: Context) -> None:
    """Every top-level table is known, [scene] is there and [scene], [output] are tables; else
    SceneErrors listing every problem (the rest of the checks need these)."""
    top = {"scene": Field("table", section=SCENE_SECTION), "task": Field("any", default={}),
           "effects": Field("any", default={}),
           "output": Field("table", default=None, section=OUTPUT_SECTION),
           "sweep": Field("any", default={}), **registry.SECTIONS}
    for key in raw:
        if key not in top:
            known = ", ".join(sorted(top))
            ctx.fail(key, f"unknown table; valid tables: {known}")
    if "scene" not in raw:
        ctx.fail("scene", "is required: a [scene] table with at least task = \"...\"")
        raise SceneErrors(ctx.errors)
    for key in ("scene", "output"):
        if key in raw and not isinstance(raw[key], dict):
            ctx.fail(key, f"must be a table ([{key}]), got {type(raw[key]).__name__}")
    if ctx.errors:
        raise SceneErrors(ctx.errors)


def _validate_sections(raw: dict, data: dict, task, ctx: Context) -> None:
    """Into ``data``: the [task] table (checked by ``task``, the scene's task, None when unknown) and
    every registered section's table, defaults filled; the sections the task needs are required."""
    if task is not None:
        if not isinstance(raw.get("task", {}), dict):
            ctx.fail("task", "must be a table")
        else:
            data["task"] = task.params.validate(raw.get("task", {}), ctx, prefix="task")
        for sec in task.sections:
            if sec not in raw and registry.SECTIONS[sec].required:
                ctx.fail(sec, f"is required by task {task.name!r}")
    for name, spec in registry.SECTIONS.items():
        if name in raw:
            data[name] = spec.validate(raw[name], name, ctx)
        elif not spec.required or task is None or name not in task.sections:
            data[name] = spec.default if spec.kind != "table" or spec.default is None \
                else spec.section.validate({}, ctx, prefix=name)


def _validate_effects(raw_eff, ctx: Context) -> dict:
    """The [effects.NAME] tables, each checked by its registered effect (``{}`` or ``true``: its defaults)."""
    effects = {}
    if not isinstance(raw_eff, dict):
        ctx.fail("effects", "must be a table of effect tables, e.g. [effects.noise]")
        raw_eff = {}
    for name, params in raw_eff.items():
        spec = registry.EFFECTS.get(name)
        if spec is None:
            known = ", ".join(sorted(registry.EFFECTS))
            ctx.fail(f"effects.{name}", f"unknown effect; valid effects: {known}")
            continue
        if params is True or params == {}:
            params = {}
        if not isinstance(params, dict):
            ctx.fail(f"effects.{name}", "must be a table of parameters ([effects.NAME], may be empty)")
            continue
        effects[name] = spec.params.validate(params, ctx, prefix=f"effects.{name}")
    return effects


def list_scenes(folder: str | Path) -> list[tuple[Path, str, str]]:
    """``(path, task, description)`` of every ``*.toml`` in ``folder``, sorted by name.

    Only the ``[scene]`` table is read; an unreadable file is listed with its error.
    """
    out = []
    for p in sorted(Path(folder).glob("*.toml")):
        try:
            head = tomllib.loads(read_text(p, "scene file", limit=MAX_SCENE_BYTES)).get("scene", {})
            if not isinstance(head, dict):
                raise InputError("[scene] is not a table", file=p)
            out.append((p, clean(head.get("task", "?")), clean(head.get("description", ""), 400)))
        except (tomllib.TOMLDecodeError, InputError) as exc:
            out.append((p, "invalid", clean(exc, 400)))
    return out
