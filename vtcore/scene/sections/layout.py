"""``[end_effector]`` and ``[layout]``: the rigid body and the skin on it.

Conventions (metres): every built-in end-effector has its skin surface through
the origin with outward normal +z there, so objects pressed along -z meet the
skin. ``sphere``: centre ``(0, 0, -radius)``; ``cylinder``: axis along y through
``(0, 0, -radius)``, ``length`` long; ``plane``: a box ``size`` wide with its top at
z = 0; ``disc``: a cylinder of ``radius`` with its top at z = 0; ``mesh``: a mesh
file (``scale`` converts its unit to metres). ``seed001_disc``,
``seed002_planar`` and ``seed002_curved`` are the end-effectors of the seed
papers and come with their own skin (``[layout] patch = "auto"``).

``[layout]`` either loads a calibrated layout ``file`` or places a ``patch``
(triangle, hexagon, strip:N, fill) of ``module`` on the end-effector at ``at``
(default: the origin, the top of the skin surface) with its x axis along
``direction``, ``offset`` metres out along the normal; ``mirror = true`` lays
mirror-image modules (skinGui's ``mirror`` column). On the analytic primitives
with the default ``at`` the exponential map is exact (azimuthal equidistant on
the sphere, unrolling on the cylinder); elsewhere the mesh log map is used.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from ...errors import InputError
from ...layout import Layout, make_patch, wrap_on_sphere
from ...layout.meshinput import SURFACE_SIZE_M, load_mesh
from ...layout.modules import MODULES, PITCH
from ..budget import MAX_STRIP_MODULES
from ..registry import register_section
from ..schema import Field, Section

if TYPE_CHECKING:  # for annotations only: trimesh is imported where a mesh is built
    import trimesh

SHAPES = ("sphere", "plane", "cylinder", "disc", "mesh", "seed001_disc", "seed002_planar", "seed002_curved")
SEEDS = ("seed001_disc", "seed002_planar", "seed002_curved")


def _check_ee(t: dict) -> list:
    if t["shape"] == "mesh" and not t["mesh"]:
        return [("mesh", "shape 'mesh' needs mesh = \"FILE\" (STL, OBJ, PLY, ...)")]
    if t["shape"] != "mesh" and t["mesh"]:
        return [("mesh", f"a mesh file is only used with shape = \"mesh\", not {t['shape']!r}")]
    return []


def _patch_ok(v: str) -> str | None:
    if v in ("auto", "triangle", "hexagon", "fill"):
        return None
    if v.startswith("strip:") and v[6:].isdigit() and int(v[6:]) >= 1:
        if int(v[6:]) > MAX_STRIP_MODULES:
            return (f"a strip of {int(v[6:])} modules is longer than the {MAX_STRIP_MODULES} modules accepted "
                    "(vtcore.scene.budget.MAX_STRIP_MODULES); use fill for large areas")
        return None
    return f"must be auto, triangle, hexagon, fill or strip:N (N >= 1), got {v!r}"


END_EFFECTOR = Section({
    "shape": Field("str", default="sphere", choices=SHAPES, doc="end-effector body"),
    # primitives span what a skin is laid on (SURFACE_SIZE_M, as a mesh file): a plane 1e308 m wide hung
    # in trimesh's subdivision, its edges' lengths overflowing to infinity
    "radius": Field("float", default=0.05, ge=SURFACE_SIZE_M[0], le=SURFACE_SIZE_M[1], unit="m",
                    doc="radius of a sphere, cylinder or disc"),
    "length": Field("float", default=0.12, ge=SURFACE_SIZE_M[0], le=SURFACE_SIZE_M[1], unit="m",
                    doc="length of a cylinder (along y)"),
    "size": Field("vec", default=[0.1, 0.1], length=2, unit="m", doc="x and y size of a plane",
                  item=Field("float", ge=SURFACE_SIZE_M[0], le=SURFACE_SIZE_M[1])),
    "thickness": Field("float", default=0.01, gt=0, le=SURFACE_SIZE_M[1], unit="m", doc="thickness of a plane or disc"),
    "mesh": Field("path", default=None, doc="mesh file for shape = \"mesh\""),
    "scale": Field("float", default=1.0, gt=0, doc="factor from the mesh file's unit to metres (0.001 for mm)"),
    "resolution": Field("float", default=0.004, gt=0, unit="m", doc="largest edge of a primitive's mesh"),
}, check=_check_ee)


def _check_layout(t: dict) -> list:
    if t["file"] and t["patch"] not in ("auto",):
        return [("patch", "give either file = ... or patch = ..., not both")]
    return []


LAYOUT = Section({
    "patch": Field("str", default="auto", check=_patch_ok,
                   doc="auto (the seed end-effector's own skin, else hexagon), triangle, hexagon, strip:N, fill"),
    "module": Field("str", default="cyskin10", choices=lambda: tuple(sorted(MODULES)), doc="module type"),
    "mirror": Field("bool", default=False,
                    doc="mirror-image modules (skinGui's mirror column: x negated in the module frame)"),
    "pitch": Field("float", default=PITCH, ge=1e-4, le=1.0, unit="m",
                   doc="taxel pitch (scales the patch; 0.1 mm .. 1 m)"),
    "center": Field("bool", default=False, doc="hexagon: add the centre taxel (61 instead of 60)"),
    "at": Field("vec", default=None, length=3, unit="m", doc="surface point the patch is centred on"),
    "direction": Field("vec", default=None, length=3, doc="in-plane direction of the patch's x axis"),
    "offset": Field("float", default=0.0, unit="m", doc="distance along the normal above the surface"),
    "method": Field("str", default="logmap", choices=("logmap", "project"), doc="placement method"),
    "radius": Field("float", default=None, gt=0, unit="m", doc="fill: geodesic radius of the region"),
    "file": Field("path", default=None, doc="calibrated layout file to load instead of placing a patch"),
    "format": Field("str", default=None, choices=("json", "icub", "cyskin", "csv", "ply"),
                    doc="format of the layout file (default: from its name and content)"),
    "units": Field("str", default=None, choices=("m", "mm"), doc="length unit of the layout file"),
}, check=_check_layout)

register_section("end_effector", Field("table", default=None, section=END_EFFECTOR))
register_section("layout", Field("table", default=None, section=LAYOUT))

def _tables(scene):
    return scene["end_effector"] or END_EFFECTOR.defaults(), scene["layout"] or LAYOUT.defaults()


def _primitive(ee: dict):
    import trimesh

    shape, r, res = ee["shape"], ee["radius"], ee["resolution"]
    if shape == "sphere":
        # icosphere edge ~ 1.1 R / 2^s: pick the subdivision that reaches the resolution (capped)
        s = int(np.clip(np.ceil(np.log2(max(1.1 * r / res, 1.0))), 2, 6))
        m = trimesh.creation.icosphere(subdivisions=s, radius=r)
        m.apply_translation([0.0, 0.0, -r])
        return m
    if shape == "cylinder":
        sections = int(np.clip(np.ceil(2 * np.pi * r / res), 16, 512))
        m = trimesh.creation.cylinder(radius=r, height=ee["length"], sections=sections)
        m.apply_transform(trimesh.transformations.rotation_matrix(np.pi / 2, [1, 0, 0]))  # axis z -> y
        m.apply_translation([0.0, 0.0, -r])
        return m.subdivide_to_size(max(res, ee["length"] / 200))
    if shape == "disc":
        sections = int(np.clip(np.ceil(2 * np.pi * r / res), 16, 512))
        m = trimesh.creation.cylinder(radius=r, height=ee["thickness"], sections=sections)
        m.apply_translation([0.0, 0.0, -ee["thickness"] / 2])
        return m
    if shape == "plane":
        sx, sy = ee["size"]
        m = trimesh.creation.box(extents=[sx, sy, ee["thickness"]])
        m.apply_translation([0.0, 0.0, -ee["thickness"] / 2])
        return m.subdivide_to_size(max(res, max(sx, sy) / 100))
    raise AssertionError(shape)


def build_end_effector(scene) -> "trimesh.Trimesh":
    """The end-effector of ``scene`` as a closed mesh in metres (see the module docstring)."""
    ee, _ = _tables(scene)
    shape = ee["shape"]
    if shape in SEEDS:
        from ... import layout as L

        return getattr(L, shape)()[0]
    if shape == "mesh":
        try:
            return load_mesh(ee["mesh"], ee["scale"], key=None, scale_key="end_effector.scale")
        except InputError as exc:
            raise scene.error("end_effector.mesh", str(exc)) from None
    return _primitive(ee)


def _scaled_patch(lay: dict):
    p = make_patch(lay["patch"], lay["module"], center=lay["center"], mirror=lay["mirror"])
    mod = MODULES[lay["module"]]
    s = lay["pitch"] / mod.pitch
    if s != 1.0:
        p.flat = p.flat * s
        p.poses[:, 1:] *= s
    return p


def build_layout(scene) -> Layout:
    """The layout of ``scene``: a loaded file, a seed end-effector's own skin, or a patch
    placed on the end-effector. The scene's counts are checked against the memory budget
    (:mod:`vtcore.scene.budget`) as soon as the number of taxels is known."""
    from ..budget import check_run_sizes

    layout = _build_layout(scene)
    check_run_sizes(scene, len(layout))
    return layout


def _build_layout(scene) -> Layout:
    from ... import layout as L

    ee, lay = _tables(scene)
    if lay["file"]:
        return L.load(lay["file"], lay["format"], units=lay["units"])
    shape = ee["shape"]
    if lay["patch"] == "auto" and shape in SEEDS:
        return getattr(L, shape)()[1]
    kind = "hexagon" if lay["patch"] == "auto" else lay["patch"]
    lay = dict(lay, patch=kind)
    analytic = lay["at"] is None and lay["method"] == "logmap" and lay["direction"] is None \
        and shape in ("sphere", "plane", "disc", "cylinder") and kind != "fill"
    if analytic:
        p = _scaled_patch(lay)
        if shape == "sphere":
            pos, nrm = wrap_on_sphere(p.flat, ee["radius"])
        elif shape == "cylinder":
            # unrolling: x wraps round the axis (along y), y runs along it
            th = p.flat[:, 0] / ee["radius"]
            r = ee["radius"]
            pos = np.column_stack([r * np.sin(th), p.flat[:, 1], r * np.cos(th) - r])
            nrm = np.column_stack([np.sin(th), np.zeros_like(th), np.cos(th)])
        else:
            pos = np.column_stack([p.flat, np.zeros(len(p))])
            nrm = np.tile([0.0, 0.0, 1.0], (len(p), 1))
        from ...layout.conform import OVERLAP_FRACTION, find_overlaps, layout_strain

        out = p.to_layout(pos, nrm, {"placement_method": "analytic", "end_effector": shape})
        strain = layout_strain(out, p.flat, p.module_edges)
        overlaps = find_overlaps(pos, p.module_ids, OVERLAP_FRACTION * p.module.pitch * lay["pitch"] / PITCH)
        out.positions = pos + lay["offset"] * nrm
        out.meta["placement"] = {"method": "analytic", "strain_max": float(np.abs(strain).max()) if len(strain) else 0.0,
                                 "strain_mean": float(np.abs(strain).mean()) if len(strain) else 0.0,
                                 "overlaps": len(overlaps), "overlap_pairs": [list(o) for o in overlaps],
                                 "off_boundary": [], "coverage": None}
        if overlaps:
            import warnings

            from ...layout import LayoutWarning

            warnings.warn(f"layout: the {kind} patch overlaps itself on the {shape} ({len(overlaps)} module pairs)",
                          LayoutWarning, stacklevel=2)
        return out
    mesh = build_end_effector(scene)
    at = lay["at"] if lay["at"] is not None else [0.0, 0.0, 0.0]
    if kind == "fill":
        layout, _ = L.fill(mesh, at, lay["direction"], module=L.get_module(lay["module"], mirror=lay["mirror"]),
                           radius=lay["radius"],
                           offset=lay["offset"])
        return layout
    layout, _ = L.place(mesh, _scaled_patch(lay), at, lay["direction"], offset=lay["offset"],
                        method=lay["method"])
    return layout
