"""What a sweep is: a scene, a grid of ``--set`` values, seeds, and the points they make.

A grid is an ordered mapping ``key -> [value, ...]`` over the keys a ``--set``
accepts (``layer.thickness``, ``task.force``, ``effects.noise.sigma``, ...). The
points are the Cartesian product of the grid times the seeds, in a fixed order
(first key slowest, seeds fastest). Every point is validated with the scene's
own loader *before* anything runs, so a misspelt key or a value of the wrong
type is reported with the scene's usual message (file, key, reason) and no
worker is started.

Where the grid comes from: the scene file's ``[sweep]`` table (``grid`` and
``seeds``) and the command line (``--grid KEY=V1,V2``, ``--seeds 1-8``); a
command-line key replaces the file's values for that key, ``--seeds`` replaces
the file's seeds.
"""

from __future__ import annotations

import hashlib
import itertools
import json
import math
import re
import tomllib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from ..errors import SceneError
from ..scene.loader import load_scene, parse_override, split_assignment

#: Most points one sweep may have; checked on the product of the sizes before any list is built.
MAX_POINTS = 10_000
#: Longest point folder name; longer names are shortened with a hash of the full one.
MAX_NAME = 120

SWEEP_KEYS = ("grid", "seeds")


@dataclass(frozen=True)
class Point:
    """One run of the sweep.

    name : the folder under the sweep's output (``layer.thickness=0.003__seed=1``).
    grid : key -> value, in the grid's key order.
    seed : the run's ``scene.seed`` (None: the scene's own seed).
    overrides : the ``--set`` texts of this run, in order (the sweep's ``--set``
        values, then the grid values, then ``scene.seed``): ``vtcore run SCENE
        --set ...`` with these gives the same arrays.
    """

    name: str
    grid: dict
    seed: int | None
    overrides: tuple[str, ...]


@dataclass
class Plan:
    """A validated sweep: the scene (absolute path), grid keys, seeds and points."""

    scene: Path
    keys: list[str]
    seeds: list[int] | None
    sets: list[str]
    points: list[Point] = field(default_factory=list)


# -- values as --set text ------------------------------------------------------------------

def toml_literal(value: Any) -> str:
    """The TOML text of ``value`` (what ``--set key=TEXT`` reads back as ``value``)."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, int):
        return str(value)
    if isinstance(value, float):
        if math.isnan(value):
            return "nan"
        if math.isinf(value):
            return "inf" if value > 0 else "-inf"
        return repr(value)
    if isinstance(value, str):
        # JSON's escapes are TOML's, except DEL, which TOML wants escaped too.
        return json.dumps(value, ensure_ascii=False).replace("\x7f", "\\u007f")
    if isinstance(value, list):
        return "[" + ", ".join(toml_literal(v) for v in value) + "]"
    if isinstance(value, dict):
        return "{" + ", ".join(f"{json.dumps(str(k))} = {toml_literal(v)}" for k, v in value.items()) + "}"
    if hasattr(value, "isoformat"):  # TOML dates and times
        return value.isoformat()
    raise SceneError(f"cannot sweep a value of type {type(value).__name__}: {value!r}")


def shown(value: Any) -> str:
    """A value as a CSV cell and folder-name part: strings bare, everything else as TOML."""
    return value if isinstance(value, str) else toml_literal(value)


def parse_values(raw: str, key: str) -> list:
    """``"0.001,0.002"`` -> ``[0.001, 0.002]``; TOML values, bare words as strings.

    The whole text is first read as the inside of one TOML array, so lists and
    quoted strings with commas work (``--grid 'task.methods=["mesh"],["image"]'``).
    """
    try:
        values = tomllib.loads(f"v = [{raw}]")["v"]
    except tomllib.TOMLDecodeError:
        values = [parse_override(f"v={part}")[1] for part in raw.split(",")]
    if not values or any(v == "" for v in values):
        raise SceneError(f"--grid {key}= needs at least one value, e.g. --grid {key}=1,2,3", key=key)
    return values


def parse_grid_arg(text: str) -> tuple[str, list]:
    """``"layer.thickness=0.003,0.006"`` -> ``("layer.thickness", [0.003, 0.006])``."""
    key, raw = split_assignment(text, "--grid", "KEY=V1,V2,...")
    return key, parse_values(raw, key)


def parse_seeds(spec: Any, *, file=None, key: str = "--seeds") -> list[int]:
    """Seeds from ``"1-8"``, ``"1,3,5"``, ``"1-4,9"``, an integer or a list of integers.

    Returns distinct integers >= 0 in the given order; at most :data:`MAX_POINTS`.
    """
    def fail(reason):
        return SceneError(f"{reason}; write seeds as 1-8, 1,3,5 or a list of integers", file=file, key=key)

    if isinstance(spec, bool):
        raise fail(f"got {spec!r}")
    if isinstance(spec, int):
        spec = [spec]
    seeds: list[int] = []
    if isinstance(spec, str):
        for part in spec.replace(" ", "").split(","):
            m = re.fullmatch(r"(\d+)(?:-(\d+))?", part)
            if not m:
                raise fail(f"cannot read {part!r}")
            lo, hi = int(m.group(1)), int(m.group(2) or m.group(1))
            if hi < lo:
                raise fail(f"range {part!r} runs backwards")
            if len(seeds) + hi - lo + 1 > MAX_POINTS:
                raise fail(f"more than {MAX_POINTS} seeds")
            seeds.extend(range(lo, hi + 1))
    elif isinstance(spec, list):
        if not all(isinstance(s, int) and not isinstance(s, bool) and s >= 0 for s in spec):
            raise fail(f"seeds must be integers >= 0, got {spec!r}")
        if len(spec) > MAX_POINTS:
            raise fail(f"more than {MAX_POINTS} seeds")
        seeds = list(spec)
    else:
        raise fail(f"got {spec!r}")
    if not seeds:
        raise fail("no seeds given")
    if len(set(seeds)) != len(seeds):
        raise fail(f"seeds repeat: {spec!r}")
    return seeds


def _flatten(table: dict, prefix: str = "") -> dict:
    """``{"layer": {"thickness": [...]}}`` -> ``{"layer.thickness": [...]}`` (unquoted dotted TOML keys)."""
    out = {}
    for k, v in table.items():
        full = f"{prefix}.{k}" if prefix else k
        if isinstance(v, dict):
            out.update(_flatten(v, full))
        else:
            out[full] = v
    return out


def file_sweep(scene_path: Path, table: dict) -> tuple[dict, list[int] | None]:
    """The ``[sweep]`` table of a scene file -> (grid, seeds); errors name ``sweep.*``."""
    for k in table:
        if k not in SWEEP_KEYS:
            raise SceneError(f"unknown key; valid keys: {', '.join(SWEEP_KEYS)}", file=scene_path, key=f"sweep.{k}")
    grid_table = table.get("grid", {})
    if not isinstance(grid_table, dict):
        raise SceneError('must be a table of KEY = [values], e.g. [sweep.grid] "layer.thickness" = [0.003, 0.006]',
                         file=scene_path, key="sweep.grid")
    grid = {}
    for k, values in _flatten(grid_table).items():
        if not isinstance(values, list) or not values:
            raise SceneError(f"must be a non-empty list of values, got {values!r}", file=scene_path,
                             key=f"sweep.grid.{k}")
        grid[k] = values
    seeds = parse_seeds(table["seeds"], file=scene_path, key="sweep.seeds") if "seeds" in table else None
    return grid, seeds


# -- the plan ------------------------------------------------------------------------------

def _safe(text: str) -> str:
    return re.sub(r"[^A-Za-z0-9._=+-]+", "-", text).strip("-") or "x"


def point_name(grid: dict, seed: int | None) -> str:
    """Folder name of a point: its grid values and seed, readable and file-system safe."""
    parts = [f"{k}={_safe(shown(v))}" for k, v in grid.items()]
    if seed is not None:
        parts.append(f"seed={seed}")
    name = "__".join(parts) or "base"
    if len(name) > MAX_NAME:
        digest = hashlib.sha1(name.encode()).hexdigest()[:10]
        name = f"{name[:MAX_NAME - 12]}--{digest}"
    return name


def plan_sweep(scene: str | Path, grid_args: list[str] | None = None, seeds: str | None = None,
               sets: list[str] | None = None) -> Plan:
    """Validate a sweep and list its points; nothing is run and nothing is written.

    scene : the scene file. grid_args : ``--grid`` texts (``KEY=V1,V2``).
    seeds : ``--seeds`` text or None (the file's ``[sweep] seeds``, else the scene's seed).
    sets : ``--set`` texts applied to every point.
    Raises :class:`vtcore.errors.SceneError` naming the file and key of the first problem.
    """
    path = Path(scene).resolve()
    sets = list(sets or [])
    base = load_scene(path, sets)  # the scene's own errors first (and its [sweep] table)
    grid, file_seeds = file_sweep(path, base.get("sweep") or {})
    cli = [parse_grid_arg(t) for t in grid_args or []]
    cli_keys = [k for k, _ in cli]
    for key in cli_keys:
        if cli_keys.count(key) > 1:
            raise SceneError("--grid names this key twice; give all its values in one --grid", key=key)
    grid.update(cli)  # a command-line key replaces the file's values for that key
    seed_list = parse_seeds(seeds) if seeds is not None else file_seeds
    for key, values in grid.items():
        if key == "scene.seed":
            raise SceneError("sweep seeds with --seeds (or [sweep] seeds), not as a grid key", key=key)
        if key.split(".")[0] == "sweep":
            raise SceneError("the [sweep] table cannot be swept", key=key)
        # 1 and 1.0 are the same run of a float key: compare numbers as floats
        same = [toml_literal(float(v) if isinstance(v, int) and not isinstance(v, bool) else v) for v in values]
        if len(set(same)) != len(same):
            raise SceneError(f"values repeat: {', '.join(toml_literal(v) for v in values)}", key=key)
    size = math.prod(len(v) for v in grid.values()) * (len(seed_list) if seed_list else 1)
    if size > MAX_POINTS:
        raise SceneError(f"the sweep has {size} points; at most {MAX_POINTS} are allowed: "
                         f"split it into several sweeps", key="--grid")

    # Each key alone first, so a bad key or value is named once, with the scene's own message.
    for key, values in grid.items():
        for v in values:
            text = f"{key}={toml_literal(v)}"
            _check_roundtrip(key, v, text)
            load_scene(path, sets + [text])

    keys = list(grid)
    points, names = [], {}
    for combo in itertools.product(*grid.values()):
        g = dict(zip(keys, combo))
        over = sets + [f"{k}={toml_literal(v)}" for k, v in g.items()]
        load_scene(path, over)  # combinations can fail a section's cross-field check
        for s in seed_list or [None]:
            name = point_name(g, s)
            if name in names:  # two values that differ only in characters a folder name cannot hold
                name = f"{name}--{hashlib.sha1(repr((g, s)).encode()).hexdigest()[:8]}"
            names[name] = True
            points.append(Point(name=name, grid=g, seed=s,
                                overrides=tuple(over + ([f"scene.seed={s}"] if s is not None else []))))
    return Plan(scene=path, keys=keys, seeds=seed_list, sets=sets, points=points)


def _check_roundtrip(key, value, text):
    if parse_override(text)[1] != value and not (isinstance(value, float) and math.isnan(value)):
        raise SceneError(f"the value {value!r} does not survive as --set text {text!r}", key=key)
