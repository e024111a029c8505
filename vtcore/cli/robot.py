"""``vtcore robot info|export``: a robot's links and their geometry; the robot with its skins in it.

- ``vtcore robot info ROBOT [--package NAME=FOLDER ...] [--json]``
- ``vtcore robot export ROBOT LAYOUT [LAYOUT ...] --out FILE [--format urdf|mjcf] [--prefix NAME_ ...]
  [--footprint taxel|tile] [--pad|--no-pad] [--site-radius M] [--pad-thickness M] [--package NAME=FOLDER]``

- ``vtcore robot skin ROBOT --out DIR [--links PATTERN] [--geometry visual|collision] [--workers N]
  [--scheduler ADDRESS] [--module NAME] [--package NAME=FOLDER]``: every link filled, in parallel

Laying skin on one link: ``vtcore layout place ROBOT --link NAME [--geometry visual|collision]``.
"""

from __future__ import annotations

import json
import sys
import warnings
from pathlib import Path

from ..errors import InputError, for_users


def packages(values) -> dict:
    """``NAME=FOLDER`` pairs (``--package``) as a dict."""
    out = {}
    for v in values or []:
        name, sep, folder = v.partition("=")
        if not sep or not name or not folder:
            raise InputError(f"give NAME=FOLDER, got {v!r}", key="--package")
        if not Path(folder).is_dir():
            raise InputError(f"{name}={folder}: the folder {folder} does not exist", key="--package")
        out[name] = folder
    return out


def _warnings(caught):
    for w in for_users(caught):
        print(f"vtcore: warning: {w.message}", file=sys.stderr)


def exposure_rows(robot, geometry: str, probe_radius: float | None) -> dict:
    """link -> ``{"exposed_m2", "area_m2", "modules", "covered_by", "unreachable_m2", "covered_m2"}`` at
    the zero pose (the exposed surface does not depend on the sampled poses: they only say which
    covered faces stay covered), for every link with ``geometry``."""
    from ..layout.modules import get_module
    from ..robot.exposure import PROBE_RADIUS, modules_room, robot_exposure

    module = get_module("cyskin10")
    out = {}
    for name, e in robot_exposure(robot, geometry, poses=0, probe_radius=probe_radius or PROBE_RADIUS).items():
        s = e.summary()
        out[name] = {"exposed_m2": s["exposed_m2"], "area_m2": s["area_m2"], "covered_m2": s["covered_m2"],
                     "unreachable_m2": s["unreachable_m2"], "covered_by": s["covered_by"],
                     "modules": modules_room(e, module), "module": module.name}
    return out


def cmd_info(args) -> int:
    from ..robot import describe, load_robot

    robot = load_robot(args.robot, packages(args.package))
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        rows = describe(robot)
        exposure = {} if args.no_exposure else exposure_rows(robot, args.geometry, args.probe_radius)
    joints = [{"name": j.name, "type": j.type, "parent": j.parent, "child": j.child, "lower": j.lower,
               "upper": j.upper} for j in robot.joints]
    if args.json:
        print(json.dumps({"robot": robot.name, "format": robot.format, "root": robot.root, "links": rows,
                          "joints": joints, "exposure": exposure, "exposure_geometry": args.geometry,
                          "warnings": [str(w.message) for w in for_users(caught)]}, indent=1))
        return 0
    _warnings(caught)
    print(f"{args.robot}: robot {robot.name!r} ({robot.format}), {len(robot.links)} links, "
          f"{len(robot.moving_joints)} moving joints, root {robot.root!r}")
    for k, r in enumerate(rows):
        if r["kind"] is None:
            print(f"  {r['link']}: no geometry")
            continue
        scale = "" if r["scale"] == [1.0, 1.0, 1.0] else f" scale {' '.join(f'{v:g}' for v in r['scale'])}"
        what = r["error"] or f"{r['faces']} faces, {1e3 * r['size_m']:.0f} mm across"
        print(f"  {r['link']}: {r['kind']} {r['source']}{scale}: {what}")
        e = exposure.get(r["link"])
        if e is not None and (k + 1 == len(rows) or rows[k + 1]["link"] != r["link"]):
            by = f"; covered by {', '.join(e['covered_by'])}" if e["covered_by"] else ""
            print(f"    exposed ({args.geometry}): {1e4 * e['exposed_m2']:.1f} of {1e4 * e['area_m2']:.1f} cm2, room "
                  f"for about {e['modules']} {e['module']} modules{by}")
    return 0


def cmd_export(args) -> int:
    from ..layout import load
    from ..robot import export_skinned

    opts = {k: getattr(args, k) for k in ("footprint", "pad", "site_radius", "pad_thickness")
            if getattr(args, k) is not None}
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        layouts = [load(p) for p in args.layouts]
        if args.prefix and len(args.prefix) != len(layouts):
            raise InputError(f"{len(args.prefix)} --prefix for {len(layouts)} layouts: give one per layout, "
                             "in the same order", key="--prefix")
        records = export_skinned(args.robot, layouts, args.out, format=args.format, prefixes=args.prefix,
                                 packages=packages(args.package), **opts)
    _warnings(caught)
    print_export(args.out, records)
    return 0


def print_export(out, records) -> None:
    """The lines ``robot export`` (and ``layout export --model``) print: per skin its taxels and link, and
    the taxels the export's contact check found unable to read (MuJoCo's rays)."""
    for r in records:
        print(f"{out}: {r['taxels']} taxels on {r['link']!r} ({r['names'][0]} .. {r['names'][-1]})")
        bad = r.get("unreadable") or []
        if bad:  # the export's contact check (MuJoCo's rays at the zero pose): these taxels cannot sense
            why = r["unreadable_why"]
            shown = "; ".join(f"{n}: {why[n]}" for n in bad[:8]) + (f"; ... ({len(bad)} in all)" if len(bad) > 8 else "")
            print(f"  {len(bad)} of {r['taxels']} taxels on {r['link']!r} cannot read: {shown}")
        some = r.get("covered_at_some_poses") or {}
        if some:
            first = next(iter(some))
            print(f"  {len(some)} more read at the zero pose but not at some joint configurations ({first}: "
                  f"{some[first]})")


def cmd_skin(args) -> int:
    from ..robot.skin_robot import skin_robot

    opts = {k: getattr(args, k) for k in ("max_strain", "crease_angle") if getattr(args, k) is not None}
    rep = skin_robot(args.robot, args.out, links=args.links, geometry=args.geometry, workers=args.workers,
                     scheduler=args.scheduler, packages=packages(args.package), module=args.module, **opts)
    for r in rep["links"]:
        what = f"{r['modules']} modules" if r["status"] == "ok" else f"{r['status']}: {r.get('reason')}"
        secs = f" ({r['seconds']:.1f} s)" if r.get("seconds") is not None else ""
        print(f"  {r['link']}: {what}{secs}")
    for f in rep["robot_files"]:
        print(f"{f.get('file') or f['format'] + ' not written: ' + f['error']}")
    c = rep["counts"]
    print(f"{args.out}: {rep['modules']} modules on {c['ok']} links, {c['refused']} refused, {c['failed']} failed, "
          f"{c['skipped']} skipped, in {rep['seconds']:.1f} s (report.md)")
    return 0


def register(sub) -> None:
    p = sub.add_parser("robot", help="a robot's links and geometry; export a robot with its skins")
    rsub = p.add_subparsers(dest="robot_command", metavar="ACTION")

    inf = rsub.add_parser("info", help="links with their meshes, size and units; joints")
    inf.add_argument("robot", metavar="ROBOT", help="URDF or MJCF file")
    inf.add_argument("--package", action="append", metavar="NAME=FOLDER", help="where a package:// package is")
    inf.add_argument("--json", action="store_true", help="print a JSON object")
    inf.add_argument("--geometry", choices=("visual", "collision"), default="visual",
                     help="whose exposed surface to measure (default visual)")
    inf.add_argument("--probe-radius", type=float, metavar="METRES",
                     help="the fingertip sphere that must reach a face for it to count as exposed (default 0.008)")
    inf.add_argument("--no-exposure", action="store_true",
                     help="skip the exposed surface (each link's meshes against the others': seconds on a humanoid)")
    inf.set_defaults(func=cmd_info)

    ex = rsub.add_parser("export", help="the robot's file with the skins' taxel frames (URDF) or touch sensors "
                                        "(MJCF) in their links")
    ex.add_argument("robot", metavar="ROBOT", help="URDF or MJCF file")
    ex.add_argument("layouts", metavar="LAYOUT", nargs="+", help="layouts in link frames (vtcore layout place "
                                                                 "ROBOT --link, or reframe --parent LINK)")
    ex.add_argument("--out", required=True, metavar="FILE")
    ex.add_argument("--format", choices=("urdf", "mjcf"), help="default: from --out (.urdf, .xml)")
    ex.add_argument("--prefix", action="append", metavar="NAME_",
                    help="start of the taxel names, one per layout (default LINK_vtskin_)")
    ex.add_argument("--package", action="append", metavar="NAME=FOLDER", help="where a package:// package is")
    ex.add_argument("--footprint", choices=("taxel", "tile"), help="mjcf: taxel-size sites or tiling pads")
    ex.add_argument("--pad", action="store_true", default=None, help="mjcf: contact pads under the sites")
    ex.add_argument("--site-radius", type=float, metavar="METRES", help="mjcf: taxel site radius")
    ex.add_argument("--pad-thickness", type=float, metavar="METRES", help="mjcf: pad thickness (default 1 mm)")
    ex.set_defaults(func=cmd_export)

    sk = rsub.add_parser("skin", help="fill every link that can carry a module, in parallel over links; write "
                                      "the layouts, the skinned robot (URDF, MJCF) and a report")
    sk.add_argument("robot", metavar="ROBOT", help="URDF or MJCF file")
    sk.add_argument("--out", required=True, metavar="DIR")
    sk.add_argument("--links", metavar="PATTERN", help="links to fill: fnmatch patterns, comma-separated "
                                                       "(default every link with geometry)")
    sk.add_argument("--geometry", choices=("visual", "collision"), default="visual")
    sk.add_argument("--workers", type=int, metavar="N", help="worker processes (default: cores)")
    sk.add_argument("--scheduler", metavar="ADDRESS", help="run on the workers of this dask scheduler "
                                                           "(tcp://host:port) instead")
    sk.add_argument("--module", default="cyskin10", help="module type (default cyskin10)")
    sk.add_argument("--max-strain", type=float, metavar="FRACTION", help="largest stretch of a module edge")
    sk.add_argument("--crease-angle", type=float, metavar="DEG", help="no module crosses a sharper edge")
    sk.add_argument("--package", action="append", metavar="NAME=FOLDER", help="where a package:// package is")
    sk.set_defaults(func=cmd_skin)

    def _help(args, parser=p):
        parser.print_help(sys.stderr)
        return 2

    p.set_defaults(func=_help)
