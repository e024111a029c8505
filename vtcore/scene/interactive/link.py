"""A fill on a robot's own link for a front end: on the link's exposed surface only, as ``vtcore layout
fill ROBOT --link NAME`` lays it (:func:`vtcore.robot.lay_on_link`), with the exposure to show.

:func:`vtcore.scene.interactive.lay_patch` calls :func:`fill_on_link` when the object filled is a link
of an imported robot (the add-on's *Fill* on a link object from *Import Robot*). Nothing here imports
``bpy``.
"""

from __future__ import annotations

import importlib.util
from dataclasses import dataclass, field, replace

import numpy as np


#: the Fill box's option (the add-on's ``fill_anywhere``, addon/props.py) that lays a fill on covered faces too
ANYWHERE_OPTION = "Anywhere on the link"


@dataclass
class LinkExposure:
    """What a fill on a link left out and the exposure to show on the link's mesh.

    reason : (F,) int8 :mod:`vtcore.robot.exposure` reason codes per face of the mesh filled (0
        exposed), or None (laid anywhere: nothing judged). legend : one line per colour
        (:func:`vtcore.robot.exposure.legend`). excluded : the report's lines: the faces left out
        and why, the modules the taxel check left out.
    """

    reason: np.ndarray | None = None
    legend: list = field(default_factory=list)
    excluded: list = field(default_factory=list)


def fill_on_link(mesh, at, direction, link: dict, *, module, region, radius, offset, **fill_options):
    """Fill ``region`` of ``mesh`` (trimesh, metres, the link's frame: the link object's own mesh)
    round ``at`` (3,) as :func:`vtcore.robot.lay_on_link` fills the link: only its exposed surface
    (not within 2 mm of or inside another link at the zero pose, reachable by an 8 mm probe) takes
    modules, and modules with a taxel off it are left out.

    link : {"robot": path of the URDF or MJCF, "link": name, "geometry": "visual" | "collision",
        "packages": {name: folder} or None, "anywhere": True to fill the whole region as before
        issue 33 (nothing judged), "probe_radius": metres or None (8 mm)}.
    fill_options : :func:`vtcore.layout.fill`'s (``max_faces``, ``existing``, ``progress``,
        ``max_strain``, ``crease_angle``, ``islands``).
    Returns ``(layout, report, LinkExposure)``: the new modules (link frame), the placement report
    (its notes say what was left out) and the exposure per face of ``mesh`` (a coarse mesh is split
    for the exposure, :func:`vtcore.robot.skin.exposure_mesh`; each face shows the reason of most of
    its area). InputError: the robot or link cannot be read, the link has no exposed surface in
    the region, no module fits.
    """
    from ...robot import lay_on_link, load_robot
    from ...robot.exposure import legend
    from ...robot.skin import ANYWHERE_HINT, NoExposedSurface, exposure_mesh, exposure_of, reasons_on

    robot = load_robot(link["robot"], link.get("packages") or None)
    name, geometry = link["link"], link.get("geometry") or "visual"
    robot.link(name)  # a link the file does not have: one line with the closest name
    args = dict(geometry=geometry, module=module, offset=offset, radius=radius, **fill_options)
    if link.get("anywhere") or importlib.util.find_spec("open3d") is None:
        layout, report = lay_on_link(robot, name, "fill", at, direction, mesh=mesh, exposure=False, region=region,
                                     **args)
        why = ("laid anywhere on the link: covered and unreachable faces were not left out" if link.get("anywhere")
               else "the exposed surface was not checked: it needs open3d (pip install open3d into Blender's Python)")
        return layout, report, LinkExposure(excluded=[why])
    fine, fine_region = exposure_mesh(mesh, region)
    exp, _ = exposure_of(robot, name, geometry, fine, True, link.get("probe_radius"))
    reason = reasons_on(mesh, fine, exp.reason)
    n = len(reason)  # the legend of the colours shown (a split face's minority reason shows on no face)
    shown = LinkExposure(reason, legend(replace(exp, reason=reason, area=np.asarray(mesh.area_faces, np.float64),
                                                sometimes=np.zeros(n, bool), covered_by=np.full(n, -1))))
    try:
        layout, report = lay_on_link(robot, name, "fill", at, direction, mesh=fine, exposure=exp, region=fine_region,
                                     probe_radius=exp.probe_radius, **args)
    except NoExposedSurface as exc:  # the way round it, as the Fill box names it (not the CLI's --anywhere)
        raise NoExposedSurface(exc.reason.replace(ANYWHERE_HINT, f"{ANYWHERE_OPTION!r} lays it there anyway"),
                               file=exc.file) from None
    info = layout.meta.get("exposure") or {}
    shown.excluded = [line for line in (info.get("excluded"), info.get("taxel_check")) if line]
    return layout, report, shown
