"""``vtcore layout place|import|export|info``: design, convert and inspect skin layouts.

- ``vtcore layout place MESH --patch {triangle,hexagon,strip:N,fill} --at X Y Z [--direction DX DY DZ]
  [--module NAME] [--mirror] [--offset METRES] [--max-strain F] [--force] --out LAYOUT``; fill's region:
  ``[--radius M] [--facing DX DY DZ --within DEG] [--faces FILE] [--islands each|one] [--crease-angle DEG]``
- ``vtcore layout import FILE [--format icub|cyskin|csv|json|ply] --out LAYOUT``
- ``vtcore layout export LAYOUT --format icub|cyskin|csv|json|ply|mjcf|urdf --out FILE [--transform FILE_OR_16_NUMBERS]``
  MJCF: ``[--model ROBOT.xml --body BODY] [--footprint taxel|tile] [--pad|--no-pad] [--site-radius M]``;
  URDF: ``--parent LINK [--model ROBOT.urdf]``; both: ``[--prefix NAME_] [--package NAME=FOLDER]``; iCub, CySkin:
  ``[--estimate-normals]``; PLY: ``[--mesh]``. With ``--model`` it is ``vtcore robot export`` of this one layout
  (:func:`vtcore.robot.export_skinned`): the same inputs write the same file.
- ``vtcore layout reframe LAYOUT (--pose FILE_OR_16_NUMBERS [--parent NAME] | --into-parent) [--frame NAME] --out LAYOUT``
- ``vtcore layout info LAYOUT [--json]``

Layouts are written in the format their ``--out`` name says (``.json`` is our own JSON).
All lengths are metres.
"""

from __future__ import annotations

import argparse
import contextlib
import json
import sys
import warnings
from pathlib import Path

import numpy as np

from ..errors import InputError, for_users

#: metres: --subdivide below a micrometre is a unit error (refine coarsens to its face budget anyway); one
#: past a kilometre splits nothing on an accepted mesh, and its square overflows near 1e154
SUBDIVIDE_M = (1e-6, 1e3)
#: metres: the MJCF writer's --site-radius and --pad-thickness (a taxel is millimetres across)
MJCF_SIZE_M = (1e-6, 1.0)


def _patch_arg(value: str) -> str:
    from ..scene.budget import MAX_STRIP_MODULES

    if value in ("triangle", "hexagon", "fill"):
        return value
    if value.startswith("strip:") and value[6:].isdigit() and int(value[6:]) >= 1:
        if int(value[6:]) > MAX_STRIP_MODULES:  # a strip of 1e5 modules ran out of memory in the overlap check
            raise argparse.ArgumentTypeError(f"a strip of {int(value[6:])} modules is longer than the "
                                             f"{MAX_STRIP_MODULES} accepted; use fill for large areas")
        return value
    raise argparse.ArgumentTypeError(f"must be triangle, hexagon, fill or strip:N, got {value!r}")


def _check_place_numbers(args) -> None:
    """Refuse, before the mesh is read, numbers no placement can use (docs/inputs.md lists the ranges).

    ``--scale`` is checked with the mesh (:func:`vtcore.layout.meshinput.checked_mesh`); ``--offset``
    against the mesh's size once it is loaded (:func:`_check_offset`).
    """
    from ..inputs import to_float
    from ..layout.io import MAX_COORDINATE_M

    if args.at is not None:  # with --link it defaults to a point of the link's surface
        args.at = [to_float(v, lo=-MAX_COORDINATE_M, hi=MAX_COORDINATE_M, key="--at") for v in args.at]
    if args.direction is not None:
        d = [to_float(v, key="--direction") for v in args.direction]
        big = max(abs(v) for v in d)
        if big == 0:
            raise InputError("must not be the zero vector (the in-plane x direction of the patch)",
                             key="--direction")
        args.direction = [v / big for v in d]  # unit-free: 1e300 or 1e-300 lengths must not overflow a norm
    to_float(args.offset, key="--offset")
    if args.radius is not None:
        to_float(args.radius, gt=0.0, key="--radius")
    if args.probe_radius is not None:
        to_float(args.probe_radius, gt=0.0, hi=1.0, key="--probe-radius")
    if args.max_strain is not None:
        to_float(args.max_strain, gt=0.0, key="--max-strain")
    to_float(args.crease_angle, gt=0.0, hi=180.0, key="--crease-angle")
    to_float(args.within, gt=0.0, hi=180.0, key="--within")
    if args.patch != "fill" and (args.facing or args.faces or args.radius is not None):
        raise InputError("--facing, --faces and --radius choose the region of --patch fill", key="--patch")
    if args.subdivide is not None:
        to_float(args.subdivide, lo=SUBDIVIDE_M[0], hi=SUBDIVIDE_M[1], key="--subdivide")


def _check_offset(offset: float, mesh) -> None:
    """``--offset`` (metres along the normal) within +-the mesh's size: a skin further off than the
    part is large is a unit error, and past about 1e300 the placed positions overflow."""
    size = float(np.ptp(mesh.vertices, axis=0).max())
    if abs(offset) > size:
        raise InputError(f"must be within +-{size:.3g} m (the mesh's size), got {offset:g}", key="--offset")



def _region(args, mesh):
    """--facing/--within and --faces as one (F,) face mask of ``mesh`` (both: the faces in the file
    that face that way), or None (every face)."""
    from ..layout.regions import facing_region, read_face_indices

    region = None
    if args.faces:
        region = read_face_indices(args.faces, len(mesh.faces))
    if args.facing:
        cone = facing_region(mesh, args.facing, args.within)
        region = cone if region is None else region & cone
        if not region.any():
            raise InputError(f"no face of the mesh faces ({' '.join(f'{v:g}' for v in args.facing)}) within "
                             f"{args.within:g} deg" + (" among the faces of --faces" if args.faces else ""),
                             key="--facing")
    return region


def _print_warnings(caught):
    """The recorded warnings meant for users (vtcore's own, numerical ones; not a library's
    deprecations), one ``vtcore: warning:`` line each."""
    for w in for_users(caught):
        print(f"vtcore: warning: {w.message}", file=sys.stderr)


@contextlib.contextmanager
def _warnings_if_done():
    """The warnings of the block as ``vtcore: warning:`` lines once it has succeeded; if it fails,
    the command's output is its one error line (the warnings become the error's details)."""
    from ..errors import VtError

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            yield
        except VtError as exc:
            exc.details = [str(w.message) for w in for_users(caught)] + list(getattr(exc, "details", None) or [])
            raise
    _print_warnings(caught)


def _place_mesh(args):
    """The surface to place on: a mesh file, or with ``--link`` a robot link's geometry in its frame
    (then also the robot)."""
    from ..layout.meshinput import load_mesh

    if args.link is None:
        if args.geometry is not None or args.package or args.anywhere or args.probe_radius is not None:
            raise InputError("--geometry, --package, --anywhere and --probe-radius go with --link (MESH a robot "
                             "file)", key="--link")
        if args.at is None:
            raise InputError("--at is required (the surface point the patch is centred on)", key="--at")
        return load_mesh(args.mesh, args.scale, key=None, scale_key="--scale"), None
    from ..robot import link_mesh, load_robot
    from .robot import packages

    if args.scale != 1.0:
        raise InputError("a robot link is scaled by the robot file (its <mesh scale=\"0.001 0.001 0.001\"> for a "
                         "mesh in millimetres): a skin laid at another scale would not sit on the link the robot's "
                         "own file exports; give the scale in the robot file (--scale is for mesh files)",
                         key="--scale")
    robot = load_robot(args.mesh, packages(args.package))
    return link_mesh(robot, args.link, args.geometry or "visual"), robot


def cmd_place(args) -> int:
    from ..layout import fill, get_module, place, save
    from ..layout.report import DEFAULT_MAX_STRAIN, PLACE_MAX_STRAIN, check_trust
    from ..robot import lay_on_link

    _check_place_numbers(args)
    with _warnings_if_done():
        mesh, robot = _place_mesh(args)
    _check_offset(args.offset, mesh)
    if args.subdivide:
        from ..layout.repair import refine

        mesh = refine(mesh, args.subdivide)  # faces split on themselves: the surface does not move
    module = get_module(args.module, mirror=args.mirror)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            opts = {}
            if args.patch == "fill":
                opts = dict(region=_region(args, mesh), max_strain=args.max_strain or DEFAULT_MAX_STRAIN,
                            crease_angle=args.crease_angle, islands=args.islands)
            if robot is not None:  # born in the link's frame: exported back into the robot with no transform
                layout, report = lay_on_link(robot, args.link, args.patch, args.at, args.direction, mesh=mesh,
                                             geometry=args.geometry or "visual", module=module, offset=args.offset,
                                             method=args.method, radius=args.radius, exposure=not args.anywhere,
                                             probe_radius=args.probe_radius, force=args.force, **opts)
            elif args.patch == "fill":
                layout, report = fill(mesh, args.at, args.direction, module=module, radius=args.radius,
                                      offset=args.offset, **opts)
            else:
                layout, report = place(mesh, args.patch, args.at, args.direction, module=module,
                                       offset=args.offset, method=args.method)
            limit = args.max_strain or (DEFAULT_MAX_STRAIN if args.patch == "fill" else PLACE_MAX_STRAIN)
            kept = check_trust(report, max_strain=limit, force=args.force, what=args.patch)
        except InputError as exc:
            # the one error line says the main problem; the warnings and the per-island detail
            # follow it with --details
            exc.details = [str(w.message) for w in for_users(caught)] + list(getattr(exc, "details", None) or [])
            raise
    _print_warnings(caught)
    for line in kept:
        print(f"vtcore: warning: kept with --force: {line}", file=sys.stderr)
    if robot is None:
        layout.meta["mesh"] = str(args.mesh)
    save(layout, args.out, args.format)
    from ..layout.summary import report_lines

    where = f" on link {args.link!r} (its frame)" if robot is not None else ""
    print(f"{args.out}: {len(layout)} taxels in {layout.n_modules} modules{where}, {report.seconds:.2f} s "
          f"({report.method})")
    for line in report_lines(layout.meta.get("placement")):
        print(f"  {line}")
    if robot is not None:
        exp = layout.meta.get("exposure")
        if exp is None:
            print("  laid anywhere on the link (--anywhere): covered and unreachable faces were not left out")
        else:
            print(f"  {exp['excluded']}")
            if exp.get("taxel_check"):
                print(f"  {exp['taxel_check']}")
    return 0


def cmd_import(args) -> int:
    from ..layout import load, save

    with _warnings_if_done():
        layout = load(args.file, args.format, units=args.units)
        save(layout, args.out)
    print(f"{args.out}: {len(layout)} taxels in {layout.n_modules} modules (from {layout.meta.get('source_format')})")
    return 0


def _read_transform(value: list[str], key: str = "--transform") -> np.ndarray:
    if len(value) == 1:
        p = Path(value[0])
        if not p.is_file():
            raise InputError("transform file not found (give a file or 16 numbers)", file=p, key=key)
        text = p.read_text(encoding="utf-8")
        try:
            data = json.loads(text)
            nums = np.asarray(data.get("transform", data) if isinstance(data, dict) else data, float).ravel()
        except (ValueError, TypeError, AttributeError):
            try:
                nums = np.asarray(text.replace(",", " ").split(), float)
            except ValueError:
                raise InputError("transform file must hold 16 numbers (row-major 4x4) or JSON",
                                 file=p) from None
    else:
        try:
            nums = np.asarray(value, float)
        except ValueError:
            raise InputError(f"{key} needs 16 numbers, got {' '.join(value)}", key=key) from None
    if nums.size != 16:
        raise InputError(f"a transform has 16 numbers (row-major 4x4), got {nums.size}", key=key)
    return nums.reshape(4, 4)


def _export_options(args) -> dict:
    """The writer options the chosen format takes; an option given for another format is an error."""
    from ..inputs import to_float

    for k in ("site_radius", "pad_thickness"):
        if getattr(args, k) is not None:
            to_float(getattr(args, k), lo=MJCF_SIZE_M[0], hi=MJCF_SIZE_M[1], key="--" + k.replace("_", "-"))
    given = {k: getattr(args, k) for k in ("model", "body", "parent", "footprint", "pad", "site_radius",
                                           "pad_thickness", "prefix", "package") if getattr(args, k) is not None}
    given.update({k: True for k in ("estimate_normals", "mesh") if getattr(args, k)})  # store_true flags
    takes = {"mjcf": {"model", "body", "footprint", "pad", "site_radius", "pad_thickness", "prefix", "package"},
             "urdf": {"model", "parent", "prefix", "package"}, "icub": {"estimate_normals"},
             "cyskin": {"estimate_normals"}, "ply": {"mesh"}}.get(args.format, set())
    wrong = sorted(set(given) - takes)
    if wrong:
        flags = ", ".join("--" + k.replace("_", "-") for k in wrong)
        raise InputError(f"{flags}: not an option of --format {args.format}", key="--format")
    alone = sorted({"body", "package"} & set(given)) if "model" not in given else []
    if alone:  # they say where in the robot's own file: the fragment has none
        raise InputError("goes with --model ROBOT", key=f"--{alone[0]}")
    return given


def cmd_export(args) -> int:
    from ..layout import load, save

    options = _export_options(args)
    records = None
    with _warnings_if_done():
        layout = load(args.layout)
        transform = _read_transform(args.transform) if args.transform else None
        if options.get("model") is not None:  # the robot's own file: what robot export writes
            records = _export_into_robot(layout, args, transform, options)
        else:
            save(layout, args.out, args.format, transform=transform, **options)
    if records is not None:
        from .robot import print_export

        print_export(args.out, records)
        return 0
    print(f"{args.out}: {len(layout)} taxels as {args.format}")
    return 0


def _export_into_robot(layout, args, transform, options: dict) -> list[dict]:
    """``layout export --model ROBOT``: :func:`vtcore.robot.export_skinned`, the export ``robot export``
    runs, for this one layout: the link is ``--body`` (MJCF) or ``--parent`` (URDF), else the layout's
    parent or frame; ``--transform`` is the layout frame's pose in that link (:func:`~vtcore.layout.io.in_link`).
    Returns export_skinned's records."""
    from ..layout.io import in_link
    from ..robot import export_skinned
    from .robot import packages

    model, prefix = options.pop("model"), options.pop("prefix", None)
    link = options.pop("body", None) or options.pop("parent", None)  # MJCF's and URDF's name for it
    pkgs = packages(options.pop("package", None))
    if transform is not None:
        layout = in_link(layout, transform, Path(args.out).name)
    if link is not None:
        layout = layout.posed(layout.transform, link)
    return export_skinned(model, [layout], args.out, format=args.format, prefixes=[prefix], packages=pkgs, **options)


def cmd_reframe(args) -> int:
    """Say where the layout's frame is (``--pose``) or re-express the taxels in its parent."""
    from ..layout import load, save

    if (args.pose is None) == (not args.into_parent):
        raise InputError("give either --pose (where the layout's frame sits in its parent) or --into-parent "
                         "(re-express the taxels in the parent)", key="--pose")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        layout = load(args.layout)
    _print_warnings(caught)
    if args.into_parent:
        if args.parent is not None:
            raise InputError("--parent goes with --pose; --into-parent uses the layout's own parent", key="--parent")
        out = layout.in_parent()
        what = f"re-expressed in {out.frame!r}"
    else:
        out = layout.posed(_read_transform(args.pose, "--pose"), args.parent)
        what = f"frame {layout.frame!r} placed in {out.parent or 'its parent'!r}"
    if args.frame:
        out.frame = args.frame
    save(out, args.out)
    print(f"{args.out}: {len(out)} taxels, {what}")
    return 0


def _pairs_within(points: np.ndarray, radius: float, key: str) -> np.ndarray:
    """(P, 2) index pairs of ``points`` closer than ``radius``, counted (and held to the memory budget)
    before they are listed: a pitch as large as the layout would pair every taxel with every other."""
    from scipy.spatial import cKDTree

    from ..inputs import need_memory

    tree = cKDTree(points)
    pairs = (int(tree.count_neighbors(tree, radius)) - len(points)) // 2  # ordered, with each point itself
    need_memory(8.0 * 6 * pairs, key=key, what=f"{pairs} taxel pairs within {radius:.3g} m")
    return tree.query_pairs(radius, output_type="ndarray")


def layout_info(layout) -> dict:
    """Summary numbers of a layout (the ``layout info`` fields)."""
    from ..layout.report import OVERLAP_FRACTION, layout_strain
    from ..layout.mesh import nn_spacing
    from ..layout.summary import report_fields

    n = len(layout)
    sp = nn_spacing(layout.positions) if n > 1 else np.zeros(n)
    pitch_key = "meta.pitch_m" if layout.meta.get("pitch_m") else "positions"
    pitch = float(layout.meta.get("pitch_m") or (np.median(sp) if n > 1 else 0.0))
    placement = layout.meta.get("placement")
    fields = report_fields(placement if isinstance(placement, dict) else None)  # the numbers it can read
    strain_max, strain_mean = fields.get("strain_max"), fields.get("strain_mean")
    if strain_max is None and layout.flat is not None and n >= 2 and pitch > 0:
        pairs = _pairs_within(layout.flat, 1.25 * pitch, pitch_key)
        pairs = pairs[layout.module_ids[pairs[:, 0]] == layout.module_ids[pairs[:, 1]]] if len(pairs) else pairs
        with np.errstate(all="ignore"):  # coincident flat points: an undefined strain, dropped below
            s = layout_strain(layout, layout.flat, pairs) if len(pairs) else np.zeros(0)
        s = s[np.isfinite(s)]
        strain_max = float(np.abs(s).max()) if len(s) else 0.0
        strain_mean = float(np.abs(s).mean()) if len(s) else 0.0
    overlaps = 0
    if pitch > 0 and n >= 2:
        pairs = _pairs_within(layout.positions, OVERLAP_FRACTION * pitch, pitch_key)
        a, b = layout.module_ids[pairs[:, 0]], layout.module_ids[pairs[:, 1]]
        cross = a != b  # module pairs with taxels too close (as report.find_overlaps, on the counted pairs)
        overlaps = len(np.unique(np.sort(np.column_stack([a[cross], b[cross]]), axis=1), axis=0)) if cross.any() else 0
    lo, hi = (layout.positions.min(axis=0), layout.positions.max(axis=0)) if n else (np.zeros(3), np.zeros(3))
    return {
        "taxels": int(n), "modules": int(layout.n_modules),
        "spacing_min_mm": float(sp.min() * 1e3) if n > 1 else None,
        "spacing_median_mm": float(np.median(sp) * 1e3) if n > 1 else None,
        "strain_max": strain_max, "strain_mean": strain_mean,
        "overlaps": overlaps,
        "off_boundary": fields.get("off_boundary", 0),
        "coverage": fields.get("coverage"),
        "bbox_min_m": lo.tolist(), "bbox_max_m": hi.tolist(),
        "frame": layout.frame, "module_type": layout.meta.get("module_type"),
        "roles": {str(r): int(c) for r, c in zip(*np.unique(layout.roles.astype(str), return_counts=True))},
        "mirror": layout.meta.get("module_mirror"),
        "placement": fields,
    }


def cmd_info(args) -> int:
    from ..layout import load
    from ..layout.summary import report_lines

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        layout = load(args.layout, args.format)
    info = layout_info(layout)
    if args.json:
        info["warnings"] = [str(w.message) for w in for_users(caught)]
        print(json.dumps(info, indent=1))
        return 0
    _print_warnings(caught)
    f = lambda v, fmt: "n/a" if v is None else format(v, fmt)  # noqa: E731
    print(f"{args.layout}")
    print(f"  taxels {info['taxels']}, modules {info['modules']} ({info['module_type'] or 'unknown type'}), "
          f"roles {info['roles']}")
    print(f"  neighbour spacing: min {f(info['spacing_min_mm'], '.2f')} mm, "
          f"median {f(info['spacing_median_mm'], '.2f')} mm")
    print(f"  strain: max {f(info['strain_max'], '.4f')}, mean {f(info['strain_mean'], '.4f')}; "
          f"overlaps {info['overlaps']}; off boundary {info['off_boundary']}; "
          f"coverage {f(info['coverage'], '.3f')}")
    lines = report_lines(layout.meta.get("placement"))
    if lines:
        method = info["placement"].get("method")
        print(f"  placement report{f' ({method})' if method else ''}: " + "; ".join(lines))
    lo, hi = np.array(info["bbox_min_m"]) * 1e3, np.array(info["bbox_max_m"]) * 1e3
    print(f"  bounding box (mm): [{lo[0]:.1f}, {lo[1]:.1f}, {lo[2]:.1f}] .. [{hi[0]:.1f}, {hi[1]:.1f}, {hi[2]:.1f}]"
          f" in frame {info['frame']!r}")
    return 0


def register(sub) -> None:
    """Add ``vtcore layout`` and its actions (place, import, export, reframe, info) to ``sub``."""
    from ..layout.io import FORMATS, READ_FORMATS
    from ..layout.modules import MODULES

    p = sub.add_parser("layout", help="place, import, export and inspect skin layouts")
    lsub = p.add_subparsers(dest="layout_command", metavar="ACTION")
    _add_place(lsub, FORMATS, MODULES)
    _add_import(lsub, READ_FORMATS)
    _add_export(lsub, FORMATS)
    _add_reframe(lsub)
    _add_info(lsub, READ_FORMATS)

    def _help(args, parser=p):
        parser.print_help(sys.stderr)
        return 2

    p.set_defaults(func=_help)


def _add_place(lsub, formats, modules) -> None:
    """``vtcore layout place``: a patch or a fill conformed to a mesh or a robot link."""
    pl = lsub.add_parser("place", help="conform a patch of modules to a mesh")
    pl.add_argument("mesh", metavar="MESH", help="end-effector mesh (STL, OBJ, PLY, ...), or with --link a robot "
                                                 "(URDF or MJCF)")
    _add_link_options(pl)
    pl.add_argument("--patch", type=_patch_arg, default="hexagon", help="triangle, hexagon, strip:N or fill")
    pl.add_argument("--at", type=float, nargs=3, metavar=("X", "Y", "Z"),
                    help="surface point the patch is centred on (metres; with --link in the link frame, default "
                         "a flat point of the link's exposed surface near its middle)")
    pl.add_argument("--direction", type=float, nargs=3, metavar=("DX", "DY", "DZ"),
                    help="in-plane direction of the patch's x axis")
    pl.add_argument("--module", default="cyskin10", choices=sorted(modules), help="module type")
    pl.add_argument("--mirror", action="store_true",
                    help="mirror-image modules (skinGui's mirror column: x negated in the module frame)")
    pl.add_argument("--offset", type=float, default=0.0, metavar="METRES", help="distance along the normal")
    pl.add_argument("--method", default="logmap", choices=("logmap", "project"), help="placement method")
    _add_fill_options(pl)
    pl.add_argument("--force", action="store_true",
                    help="keep a placement with taxels off the surface, over-strained modules or --at far off "
                         "the surface (refused by default, exit 2)")
    pl.add_argument("--details", action="store_true",
                    help="with an error: every warning after it, and why no module fits, island by island")
    pl.add_argument("--scale", type=float, default=1.0, help="mesh unit to metres (0.001 for a mesh in mm)")
    pl.add_argument("--subdivide", type=float, metavar="METRES",
                    help="first split mesh edges longer than this (coarse CAD or collision meshes)")
    pl.add_argument("--format", choices=formats, help="output format (default: from --out)")
    pl.add_argument("--out", required=True, metavar="LAYOUT", help="layout file to write")
    pl.set_defaults(func=cmd_place)


def _add_link_options(pl) -> None:
    """``place --link`` and the options that go with it (a robot file as MESH)."""
    pl.add_argument("--link", help="lay the skin on this link of the robot MESH: its geometry as the model places "
                                   "it, the layout born in the link's frame")
    pl.add_argument("--geometry", choices=("visual", "collision"), help="with --link: which geometry (default visual)")
    pl.add_argument("--package", action="append", metavar="NAME=FOLDER",
                    help="with --link: where a package:// package of the URDF is")
    pl.add_argument("--anywhere", action="store_true",
                    help="with --link: lay modules on the whole link, also where another link covers it (within "
                         "2 mm of or inside it at the zero pose) or no fingertip reaches (default: only on the "
                         "exposed surface)")
    pl.add_argument("--probe-radius", type=float, metavar="METRES",
                    help="with --link: the fingertip sphere that must reach a face for it to count as exposed "
                         "(default 0.008)")


def _add_fill_options(pl) -> None:
    """``place --patch fill``'s region and limits (--max-strain serves place too)."""
    pl.add_argument("--radius", type=float, help="fill: geodesic radius of the region round --at (metres)")
    pl.add_argument("--facing", type=float, nargs=3, metavar=("DX", "DY", "DZ"),
                    help="fill: the region is the faces whose normal is within --within degrees of this direction")
    pl.add_argument("--within", type=float, default=45.0, metavar="DEG", help="fill: the cone of --facing (default 45)")
    pl.add_argument("--faces", metavar="FILE",
                    help="fill: the region is the faces listed in FILE (0-based indices of the mesh as read; "
                         "spaces, commas or lines, # comments, or a JSON list)")
    pl.add_argument("--islands", choices=("each", "one"), default="each",
                    help="fill: give each island of the region its own lattice (default), or one lattice to "
                         "islands within two pitches of each other")
    pl.add_argument("--max-strain", type=float, metavar="FRACTION",
                    help="largest stretch of a module edge: fill leaves out modules straining more (default 0.05), "
                         "place refuses a patch straining more (default 0.10: a hexagon on a 40 mm sphere strains "
                         "7 %%); a flexible PCB bends freely, stretched edges put taxels where the layout does not say")
    pl.add_argument("--crease-angle", type=float, default=40.0, metavar="DEG",
                    help="fill: no module crosses an edge where the faces turn more than this (a design crease; "
                         "default 40); raise it when a coarse mesh's facets are not creases of the part")


def _add_import(lsub, read_formats) -> None:
    """``vtcore layout import``."""
    im = lsub.add_parser("import", help="read a layout file and write it as our JSON (or --out's format)")
    im.add_argument("file", metavar="FILE")
    im.add_argument("--format", choices=read_formats, help="input format (default: from name and content)")
    im.add_argument("--units", choices=("m", "mm"), help="declare the file's length unit")
    im.add_argument("--out", required=True, metavar="LAYOUT")
    im.set_defaults(func=cmd_import)


def _add_export(lsub, formats) -> None:
    """``vtcore layout export``: another format or frame, into a robot model."""
    ex = lsub.add_parser("export", help="write a layout in another format or frame")
    ex.add_argument("layout", metavar="LAYOUT")
    ex.add_argument("--format", required=True, choices=formats)
    ex.add_argument("--out", required=True, metavar="FILE")
    ex.add_argument("--transform", nargs="+", metavar="FILE_OR_16_NUMBERS",
                    help="4x4 rigid transform T (row-major; a file or 16 numbers): the pose of the layout's frame "
                         "in the frame the file is written in (urdf, mjcf --model: in the link), taxels written "
                         "as T p")
    ex.add_argument("--model", metavar="ROBOT", help="mjcf/urdf: the robot file to add the skin to (the export "
                                                     "vtcore robot export writes)")
    ex.add_argument("--package", action="append", metavar="NAME=FOLDER",
                    help="mjcf/urdf with --model: where a package:// package of the robot is")
    ex.add_argument("--body", help="mjcf with --model: the robot body the skin is on (default: the layout's "
                                   "parent, else its frame)")
    ex.add_argument("--parent", help="urdf: the link the taxel links hang from (default: the layout's parent, "
                                     "else its frame)")
    ex.add_argument("--prefix", help="urdf, mjcf with --model: start of the taxel frame / site names "
                                     "(default LINK_vtskin_)")
    ex.add_argument("--footprint", choices=("taxel", "tile"),
                    help="mjcf: sites of the taxel's size (default) or pads and sites tiling the skin")
    ex.add_argument("--pad", action=argparse.BooleanOptionalAction, default=None,
                    help="mjcf: give the skin its own contact pads (default: on in a fragment; with --model "
                         "on where robot export rebuilds the link's contact surface)")
    ex.add_argument("--site-radius", type=float, metavar="METRES", help="mjcf: taxel site radius")
    ex.add_argument("--pad-thickness", type=float, metavar="METRES", help="mjcf: pad thickness (default 1 mm)")
    ex.add_argument("--estimate-normals", action="store_true",
                    help="icub/cyskin: write the estimated normals where the source had zeros (default: zeros, as read)")
    ex.add_argument("--mesh", action="store_true",
                    help="ply: a standard 'face' element for mesh viewers (default: 'skin_face', so point-cloud "
                         "loaders keep one vertex per taxel)")
    ex.set_defaults(func=cmd_export)


def _add_reframe(lsub) -> None:
    """``vtcore layout reframe``."""
    rf = lsub.add_parser("reframe", help="place the layout's frame in its parent (--pose) or re-express the "
                                         "taxels in that parent (--into-parent)")
    rf.add_argument("layout", metavar="LAYOUT")
    rf.add_argument("--pose", nargs="+", metavar="FILE_OR_16_NUMBERS",
                    help="4x4 rigid transform (row-major): the pose of the layout's frame in its parent "
                         "(p_parent = R p + t); the positions stay as they are")
    rf.add_argument("--parent", help="with --pose: the parent frame's name (e.g. the robot link)")
    rf.add_argument("--into-parent", action="store_true",
                    help="re-express the positions in the parent (R p + t); the transform becomes identity")
    rf.add_argument("--frame", help="new name of the layout's frame")
    rf.add_argument("--out", required=True, metavar="LAYOUT")
    rf.set_defaults(func=cmd_reframe)


def _add_info(lsub, read_formats) -> None:
    """``vtcore layout info``."""
    inf = lsub.add_parser("info", help="counts, spacing, strain, overlaps, coverage, bounding box")
    inf.add_argument("layout", metavar="LAYOUT")
    inf.add_argument("--format", choices=read_formats)
    inf.add_argument("--json", action="store_true", help="print a JSON object")
    inf.set_defaults(func=cmd_info)
