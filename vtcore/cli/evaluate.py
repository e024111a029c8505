"""``vtcore evaluate LAYOUT [LAYOUT ...] --mesh MESH [--scene SCENE.toml] [--set KEY=V[,V2...]] --out DIR``.

Design maps of one skin, or several designs side by side: every layout given, times every grid of
``--set KEY=V1,V2`` values (layer thickness, module type, ...). Each design is one run of the
``evaluate`` scene task, so a design's folder is exactly what ``vtcore run DIR/evaluate.toml --set
...`` writes; several designs run in this process (they share the probe's response table), or
through ``vtcore sweep``'s dask.distributed cluster with ``--workers`` / ``--scheduler`` (and by
default beyond :data:`IN_PROCESS_DESIGNS` designs). DIR/comparison.md, .csv and .png put them side by side.
"""

from __future__ import annotations

import shutil
import sys
import tomllib
from pathlib import Path

#: more designs than this run on a dask cluster unless --in-process is given
IN_PROCESS_DESIGNS = 8


def _base_scene(args, out: Path, name: str | None = None) -> Path:
    """Write ``out/evaluate.toml``: the evaluate task on the mesh and the first layout, with the
    ``[layer]`` (and, for an evaluate scene, ``[task]``) of ``--scene``. name : the scene's name
    (default: ``out``'s)."""
    from ..errors import InputError
    from ..sweep.spec import toml_literal

    tables: dict = {}
    if args.scene:
        try:
            tables = tomllib.loads(Path(args.scene).read_text(encoding="utf-8"))
        except (OSError, tomllib.TOMLDecodeError) as exc:
            raise InputError(f"cannot read the scene: {exc}", file=str(args.scene)) from None
    keep = {"layer": tables.get("layer", {})}
    if tables.get("scene", {}).get("task") == "evaluate":
        keep["task"] = tables.get("task", {})
    for t in ("end_effector", "layout"):
        if t in tables and args.scene and not (args.mesh if t == "end_effector" else args.layouts):
            keep[t] = tables[t]
    if args.mesh:
        keep["end_effector"] = {"shape": "mesh", "mesh": str(Path(args.mesh).resolve()), "scale": args.scale}
    if args.layouts:
        keep["layout"] = {"file": args.layouts[0]}
    if "end_effector" not in keep:
        raise InputError("give the robot's mesh (--mesh MESH) or a --scene with an [end_effector]", key="--mesh")
    lines = ["# written by vtcore evaluate: the base scene of every design in this folder",
             "[scene]", f"name = {toml_literal(name or out.name or 'evaluate')}", 'task = "evaluate"',
             f"seed = {int(tables.get('scene', {}).get('seed', 0))}"]
    for name, table in keep.items():
        lines += ["", f"[{name}]"] + [f"{k} = {toml_literal(v)}" for k, v in table.items()]
    path = out / "evaluate.toml"
    from .._io import atomic_write

    with atomic_write(path, "w", encoding="utf-8") as fh:
        fh.write("\n".join(lines) + "\n")
    return path


def _grid(args) -> tuple[list[str], list[str]]:
    """(--grid texts, --set texts): a --set value with a comma outside brackets is a grid."""
    grid, sets = list(args.grid), []
    for text in args.set:
        value = text.split("=", 1)[1] if "=" in text else ""
        depth, comma = 0, False
        for ch in value:
            depth += ch in "[{"
            depth -= ch in "]}"
            comma |= ch == "," and depth == 0
        (grid if comma else sets).append(text)
    return grid, sets


def _stage_inputs(args, stage: Path, grid: list[str], name: str) -> tuple[list[str], Path]:
    """Copy the layouts (several) and write the base scene into ``stage``, after reading every layout
    (a refused layout is one error before anything is written); (the grid, the staged scene)."""
    import warnings

    from ..layout import load

    with warnings.catch_warnings():  # each design's run reports the layout's warnings in its result
        warnings.simplefilter("ignore")
        for f in args.layouts:
            load(f)
    if len(args.layouts) > 1:
        # the layouts travel with the results: the folder names and the scene stay short and valid;
        # paths relative to the scene, which is beside them in the staging folder as in the output
        (stage / "layouts").mkdir()
        rel = []
        for i, f in enumerate(args.layouts):
            dst = stage / "layouts" / f"{i + 1}_{Path(f).name}"
            shutil.copyfile(f, dst)
            rel.append(str(dst.relative_to(stage)))
        grid = [f"layout.file={','.join(rel)}"] + grid
        args.layouts = [rel[0]]
    elif args.layouts:
        args.layouts = [str(Path(args.layouts[0]).resolve())]
    return grid, _base_scene(args, stage, name)


def _remove_inputs(out: Path, made: bool) -> None:
    """Remove the base scene and copied layouts :func:`_stage_inputs` put into ``out`` (and ``out``,
    when this command made it and nothing else is there)."""
    import contextlib

    (out / "evaluate.toml").unlink(missing_ok=True)
    shutil.rmtree(out / "layouts", ignore_errors=True)
    if made:
        with contextlib.suppress(OSError):
            out.rmdir()


def cmd_evaluate(args) -> int:
    from .._io import staged_into
    from .._progress import progress
    from ..inputs import check_output_dir
    from ..evaluate.compare import write_comparison
    from ..scene import load_scene, run_scene
    from ..sweep import plan_sweep, run_sweep

    out = check_output_dir(args.out)
    made = not out.exists()
    grid, sets = _grid(args)
    # The base scene and the copied layouts are staged, and land only once every design has been
    # validated and every layout read: a refused input leaves no half-made output folder.
    with staged_into(out, prefix=".vtcore-evaluate-") as stage:
        grid, base = _stage_inputs(args, stage, grid, out.resolve().name)
        plan_sweep(base, grid, args.seeds, sets)  # every design validated before anything lands
    scene = out / base.name
    plan = plan_sweep(scene, grid, args.seeds, sets)
    if len(plan.points) == 1 and not plan.keys:
        try:
            res = run_scene(load_scene(scene, plan.points[0].overrides), out)
        except BaseException:  # the one design refused (or stopped): take back what this command put in
            _remove_inputs(out, made)
            raise
        m = res["metrics"]
        print(f"evaluate: {m['samples']} points, threshold median {m['threshold_covered_median_n']:.3g} N, "
              f"localisation median {m['localisation_covered_median_mm']:.3g} mm, blind "
              f"{m['blind_area_covered_cm2']:.3g} of {m['covered_area_cm2']:.3g} cm^2 covered -> {out}/report.md")
        return 0
    use_dask = args.workers is not None or args.scheduler is not None or (
        len(plan.points) > IN_PROCESS_DESIGNS and not args.in_process)
    print(f"evaluate: {len(plan.points)} designs "
          f"{'on dask.distributed (vtcore sweep)' if use_dask else 'in this process'} -> {out}/", file=sys.stderr)
    if use_dask:
        rows = run_sweep(plan, out, workers=args.workers, scheduler=args.scheduler,
                         command=" ".join(["vtcore", "evaluate", *sys.argv[2:]]))
        failed = [r for r in rows if r["status"] != "ok"]
    else:
        failed = []
        for p in progress(plan.points, desc="designs", unit="design"):
            try:
                run_scene(load_scene(scene, p.overrides), out / p.name)
            except ValueError as exc:  # one design's bad input: the others still run
                failed.append({"name": p.name, "error": str(exc)})
                print(f"evaluate: {p.name}: {exc}", file=sys.stderr)
    rows = write_comparison(out, [(p.name, out / p.name) for p in plan.points],
                            notes=[f"Base scene `{scene.name}`; grid: "
                                   + (", ".join(plan.keys) or "none") + "."])
    print(f"{len(rows)} designs ({len(failed)} failed) -> {out}/comparison.md")
    return 0 if not failed else 1


def register(sub) -> None:
    p = sub.add_parser("evaluate", help="design maps of a skin: blind spots, detection threshold, localisation "
                                        "and two-point discrimination; several designs side by side")
    p.add_argument("layouts", nargs="*", metavar="LAYOUT",
                   help="layout file(s) (any format vtcore layout reads); several: compared side by side")
    p.add_argument("--mesh", help="the robot link's mesh (STL, OBJ, PLY, ...) the layout lies on")
    p.add_argument("--scale", type=float, default=1.0, help="factor from the mesh file's unit to metres (0.001: mm)")
    p.add_argument("--scene", help="a scene whose [layer] (and, for an evaluate scene, [task]) to use")
    p.add_argument("--set", action="append", default=[], metavar="KEY=VALUE[,VALUE...]",
                   help="a scene value (task.reference_force=5, layer.thickness=0.003); several values "
                        "separated by commas make a grid of designs (repeatable)")
    p.add_argument("--grid", action="append", default=[], metavar="KEY=V1,V2,...", help="as --set with a list")
    p.add_argument("--seeds", metavar="SEEDS", help="seeds of every design (noise draws, random subsets): 1-5")
    p.add_argument("--out", required=True, help="output folder")
    where = p.add_mutually_exclusive_group()
    where.add_argument("--workers", type=int, metavar="N", help="run the designs on a local dask cluster of N")
    where.add_argument("--scheduler", metavar="tcp://HOST:PORT", help="run the designs on a running dask scheduler")
    where.add_argument("--in-process", action="store_true", help="run every design in this process")
    p.set_defaults(func=cmd_evaluate)
