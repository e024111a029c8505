"""``[layer]`` and ``[[objects]]``: the soft layer and what touches the skin."""

from __future__ import annotations

from ..registry import register_section
from ..schema import Field, Section

LAYER = Section({
    "thickness": Field("float", default=3e-3, ge=0, unit="m", doc="soft layer thickness"),
    "young_modulus": Field("float", default=55e3, gt=0, unit="Pa",
                           doc="Ecoflex 00-20, ~55 kPa (Smooth-On 100% modulus)"),
    "poisson": Field("float", default=0.49, ge=0, lt=0.5, doc="Poisson's ratio"),
})

OBJECT = Section({
    "name": Field("str", default="object"),
    "shape": Field("str", default="sphere", choices=("sphere",)),
    "radius": Field("float", default=0.03, gt=0, unit="m"),
    "position": Field("vec", default=[0.0, 0.0], length=2, unit="m",
                      doc="where the object's axis crosses the skin plane"),
})

register_section("layer", Field("table", default=None, section=LAYER))
register_section("objects", Field("tables", default=[], section=OBJECT))
