"""``vtcore evaluate LAYOUT [LAYOUT ...] [--mesh MESH] [--scene SCENE.toml] [--set KEY=V[,V2...]] --out DIR``.

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


def _base_scene(args, out: Path, name: str | None = None, layout=None) -> Path:
    """Write ``out/evaluate.toml``: the evaluate task on the mesh and the first layout (``layout``,
    already read), with the ``[layer]`` (and, for an evaluate scene, ``[task]`` and ``[effects]``;
    by default ``[effects.soft_layer]``) of ``--scene``; a
    robot layout's link surface beside it (:func:`link_surface`). name : the scene's name (default:
    ``out``'s)."""
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
        if layout is not None:
            lies_on(layout, args.mesh, args.scale)
        keep["end_effector"] = {"shape": "mesh", "mesh": str(Path(args.mesh).resolve()), "scale": args.scale}
    elif "end_effector" not in keep and layout is not None and layout.meta.get("robot"):
        # relative to the scene beside it: both are written in a staging folder and moved in together
        keep["end_effector"] = {"shape": "mesh", "mesh": link_surface(layout, args, out).name, "scale": 1.0}
    if args.layouts:
        keep["layout"] = {"file": args.layouts[0]}
    if "end_effector" not in keep:
        raise InputError("give the robot's mesh (--mesh MESH) or a --scene with an [end_effector] (a layout laid "
                         "on a robot link with vtcore layout place ROBOT --link NAME needs neither)", key="--mesh")
    lines = ["# written by vtcore evaluate: the base scene of every design in this folder",
             "[scene]", f"name = {toml_literal(name or out.name or 'evaluate')}", 'task = "evaluate"',
             f"seed = {int(tables.get('scene', {}).get('seed', 0))}"]
    for name, table in keep.items():
        lines += ["", f"[{name}]"] + [f"{k} = {toml_literal(v)}" for k, v in table.items()]
    # The effects an evaluate scene of --scene lists; by default the soft layer's spreading, which
    # the maps of the add-on and the shipped evaluate scenes simulate (the effect contract computes
    # no effect a scene does not list, so without it the taxels would read the surface pressure).
    effects = tables.get("effects") if "task" in keep and isinstance(tables.get("effects"), dict) \
        else {"soft_layer": {}}
    for name, table in effects.items():
        lines += ["", f"[effects.{name}]"] + [f"{k} = {toml_literal(v)}" for k, v in (table or {}).items()]
    path = out / "evaluate.toml"
    from .._io import atomic_write

    with atomic_write(path, "w", encoding="utf-8") as fh:
        fh.write("\n".join(lines) + "\n")
    return path


#: metres and degrees: a layout farther than this from the --mesh it is evaluated on does not lie on it
LIES_ON_MM, LIES_ON_DEG = 0.5, 30.0


def lies_on(layout, mesh_path, scale: float = 1.0) -> None:
    """Refuse (InputError, one line naming the distance) a ``--mesh`` the layout's taxels do not lie on:
    the largest taxel distance to the mesh over :data:`LIES_ON_MM` or the largest angle between a taxel's
    normal and its face's over :data:`LIES_ON_DEG` (a collision-box skin evaluated on the visual STL)."""
    import numpy as np

    from ..errors import InputError
    from ..layout.meshinput import load_mesh
    from ..layout.surface import closest_points

    mesh = load_mesh(mesh_path, scale=scale)
    t = layout.transform
    p, n = layout.positions @ t[:3, :3].T + t[:3, 3], layout.normals @ t[:3, :3].T
    _, face, dist = closest_points(mesh, p)
    cos = np.einsum("ij,ij->i", n / np.linalg.norm(n, axis=1, keepdims=True), mesh.face_normals[face])
    deg = float(np.degrees(np.arccos(np.clip(cos, -1, 1))).max())
    mm = 1e3 * float(dist.max())
    if mm > LIES_ON_MM or deg > LIES_ON_DEG:
        where = (f" (it was laid on link {layout.meta['link']!r}'s {layout.meta.get('geometry', 'visual')} geometry of "
                 f"{layout.meta['robot']}: leave out --mesh)") if layout.meta.get("robot") else ""
        raise InputError(f"the layout does not lie on this mesh: taxels up to {mm:.1f} mm and {deg:.0f} degrees off "
                         f"(at most {LIES_ON_MM} mm and {LIES_ON_DEG:.0f} degrees){where}", file=mesh_path,
                         key="--mesh")


def evaluation_surface(robot, link: str, geometry: str):
    """The surface of ``link`` a robot layout is evaluated on: the link's exposed faces
    (:func:`vtcore.robot.exposure.exposed_faces`, as ``layout place ROBOT --link`` fills them: not
    covered by another link at the zero pose, reachable by a fingertip), in the link's frame. A
    design map over a face no object can touch would report detection where nothing presses; a
    link with no exposed face is the same one-line refusal as ``layout place`` gives."""
    import numpy as np

    from ..robot import link_mesh
    from ..robot.exposure import exposed_faces
    from ..errors import InputError
    from ..robot.skin import exposure_mesh

    mesh, _ = exposure_mesh(link_mesh(robot, link, geometry))
    exposure = exposed_faces(robot, link, geometry, mesh=mesh)
    if not exposure.mask.any():
        raise InputError(f"link {link!r} ({geometry} geometry) has no exposed surface to map: "
                         f"{exposure.excluded_text().split(': ', 1)[1]}; give the surface with --mesh",
                         file=robot.path, key="--link")
    if exposure.mask.all():
        return mesh
    return mesh.submesh([np.flatnonzero(exposure.mask)], append=True)


def link_surface(layout, args, out: Path) -> Path:
    """Write the surface of the robot link the layout records (``meta["robot"]``, ``["link"]``,
    ``["geometry"]``; package:// paths through ``--package`` as ``layout place`` resolves them) to
    ``out/<link>_<geometry>.stl`` in the link's frame, metres; returns its path."""
    from ..errors import InputError
    from ..robot import load_robot
    from .robot import packages

    robot_file = Path(layout.meta["robot"])
    if not robot_file.is_file():
        raise InputError(f"the layout was laid on the robot {robot_file}, which is not there: give the link's "
                         "mesh with --mesh", file=args.layouts[0], key="robot")
    robot = load_robot(robot_file, packages(args.package))
    link = layout.meta.get("link") or layout.parent or layout.frame
    geometry = layout.meta.get("geometry") or "visual"
    mesh = evaluation_surface(robot, link, geometry)
    path = out / f"{link}_{geometry}.stl"
    from .._io import atomic_write

    with atomic_write(path, "wb") as fh:
        mesh.export(fh, file_type="stl")
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


def _said_of_the_input(exc, out: Path):
    """``exc`` without the base scene the command generated in ``out`` as its file (the user never
    wrote it: a --set typo is the --set's), else unchanged."""
    from ..errors import InputError

    scene = str((out / "evaluate.toml").resolve())
    text = str(exc)
    if scene not in text:
        return exc
    return InputError(text.replace(f"{scene}: ", "").replace(scene, "the --set values"))


def _stage_inputs(args, stage: Path, grid: list[str], name: str) -> tuple[list[str], Path]:
    """Copy the layouts (several) and write the base scene into ``stage``, after reading every layout
    (a refused layout is one error before anything is written); (the grid, the staged scene)."""
    import warnings

    from ..layout import load

    with warnings.catch_warnings():  # each design's run reports the layout's warnings in its result
        warnings.simplefilter("ignore")
        first = [load(f) for f in args.layouts][:1]
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
    return grid, _base_scene(args, stage, name, first[0] if first else None)


def _remove_inputs(out: Path, made: bool, names: list[str]) -> None:
    """Remove the entries :func:`_stage_inputs` put into ``out`` (``names``: the base scene, copied
    layouts, a robot link's surface), and ``out`` when this command made it and nothing else is there."""
    import contextlib

    for name in names:
        if (out / name).is_dir():
            shutil.rmtree(out / name, ignore_errors=True)
        else:
            (out / name).unlink(missing_ok=True)
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
        try:
            grid, base = _stage_inputs(args, stage, grid, out.resolve().name)
            plan_sweep(base, grid, args.seeds, sets)  # every design validated before anything lands
        except ValueError as exc:  # named as what the user typed, not the generated scene
            raise _said_of_the_input(exc, stage) from None
        staged = sorted(f.name for f in stage.iterdir())
    scene = out / base.name
    plan = plan_sweep(scene, grid, args.seeds, sets)
    if len(plan.points) == 1 and not plan.keys:
        try:
            res = run_scene(load_scene(scene, plan.points[0].overrides), out)
        except BaseException:  # the one design refused (or stopped): take back what this command put in
            _remove_inputs(out, made, staged)
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
    p.add_argument("--mesh", help="the robot link's mesh (STL, OBJ, PLY, ...) the layout lies on (default for a "
                                  "layout laid on a robot link: that link's geometry, from the robot file it records)")
    p.add_argument("--package", action="append", metavar="NAME=FOLDER",
                   help="where a package:// package of the layout's robot is (as vtcore layout place --package)")
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
