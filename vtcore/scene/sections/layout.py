"""``[end_effector]`` and ``[layout]``: the rigid body and the skin on it."""

from __future__ import annotations

import numpy as np

from ...layout import Layout, hexagon_flat, wrap_on_sphere
from ..registry import register_section
from ..schema import Field, Section

END_EFFECTOR = Section({
    "shape": Field("str", default="sphere", choices=("sphere", "plane"),
                   doc="primitive end-effector surface"),
    "radius": Field("float", default=0.05, gt=0, unit="m", doc="radius of curvature of a sphere"),
})

LAYOUT = Section({
    "patch": Field("str", default="hexagon", choices=("hexagon",), doc="patch type"),
    "pitch": Field("float", default=7.5e-3, gt=0, unit="m", doc="taxel pitch"),
})

register_section("end_effector", Field("table", default=None, section=END_EFFECTOR))
register_section("layout", Field("table", default=None, section=LAYOUT))


def build_layout(scene) -> Layout:
    """The layout of ``scene``: its patch wrapped onto its end-effector."""
    ee, lay = scene["end_effector"], scene["layout"]
    flat, modules = hexagon_flat(lay["pitch"])
    radius = ee["radius"] if ee["shape"] == "sphere" else np.inf
    pos, nrm = wrap_on_sphere(flat, radius)
    ids = (modules + 1) * 16 + np.tile(np.arange(1, 11), 6)[: len(modules)]
    return Layout(pos, nrm, ids, modules, flat=flat, meta={"patch": lay["patch"]})
