"""Indenter profiles of the layer-model reference cases: a sphere, a flat punch, a cube's edge, a finger pad.

Each is a rigid profile ``f(x)`` (m): the height of the indenter's surface above its lowest
point at lateral distance ``x`` (m) from its axis, with its slope ``f'(x)``, for two geometries:
``"axisymmetric"`` (x is the radius; sphere, punch) or ``"plane"`` (plane strain, x across a long
body; cube edge, finger pad). The finite-element reference (:mod:`vtcore.contact.fem_reference`)
and the fast layer models (:mod:`vtcore.contact.hyperelastic`) press the same profiles, so the
comparison in docs/contact.md is between models, not between shapes.

Edges are rounded (``edge_radius``): a perfectly sharp edge has a singular pressure in both models
and no peak to compare; a cast or machined edge is rounded to a fraction of a millimetre anyway.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import InputError

#: slope (rise over run) at which a profile's rounded edge turns into a straight side (72 degrees)
SIDE_SLOPE = 3.0
KINDS = ("sphere", "punch", "cube_edge", "finger")


@dataclass(frozen=True)
class Indenter:
    """A rigid indenter profile.

    kind : one of :data:`KINDS`. radius : m, the sphere's or the finger pad's radius, or the
    punch's (cube's) half-width. edge_radius : m, the rounding of a punch's or cube's edge.
    geometry : "axisymmetric" (sphere, punch) or "plane" (cube edge, finger pad: plane strain).
    """

    kind: str
    radius: float
    edge_radius: float = 0.0

    def __post_init__(self):
        if self.kind not in KINDS:
            raise InputError(f"indenter kind must be one of {', '.join(KINDS)}, got {self.kind!r}", key="kind")
        if not self.radius > 0:
            raise InputError(f"must be > 0 m, got {self.radius}", key="radius")
        if self.kind in ("punch", "cube_edge") and not 0 < self.edge_radius < self.radius:
            raise InputError(f"must be in (0, radius), got {self.edge_radius}", key="edge_radius")

    @property
    def geometry(self) -> str:
        return "axisymmetric" if self.kind in ("sphere", "punch") else "plane"

    def profile(self, x):
        """(f, f') at lateral distances ``x`` (any shape, m): height above the tip (m) and slope.

        Round bodies: a circle of ``radius``. Punch and cube: flat to ``radius - edge_radius``, then a
        circle of ``edge_radius``. Where the circle's slope reaches :data:`SIDE_SLOPE` the side goes on
        straight at that slope (a side flaring at 72 degrees rather than a vertical wall): the layer
        bulging beside a deep press meets it in both models alike, and the slope stays finite.
        """
        xa = np.asarray(x, dtype=float)
        a = np.abs(xa)
        r, s = (self.radius, a) if self.kind in ("sphere", "finger") else \
            (self.edge_radius, a - (self.radius - self.edge_radius))
        s_t = r * SIDE_SLOPE / np.sqrt(1 + SIDE_SLOPE**2)   # where the circle's slope is SIDE_SLOPE
        f_t = r - np.sqrt(r * r - s_t * s_t)
        on = (s > 0) & (s < s_t)
        root = np.sqrt(np.where(on, r * r - s * s, 1.0))
        f = np.where(s <= 0, 0.0, np.where(on, r - root, f_t + SIDE_SLOPE * (s - s_t)))
        fp = np.where(s <= 0, 0.0, np.where(on, s / root, SIDE_SLOPE))
        return f, fp * np.sign(xa)

    def gap(self, X, Y):
        """Gap (m) of the indenter over a grid ``X, Y`` (m) centred on its axis.

        Axisymmetric kinds use the radius ``hypot(X, Y)``; plane kinds vary along X only (the caller
        bounds the body's length along Y).
        """
        x = np.hypot(X, Y) if self.geometry == "axisymmetric" else np.asarray(X, float)
        return self.profile(x)[0]


#: The reference cases of docs/contact.md ('Large compression'): seed 001's 30 mm sphere, a 10 mm
#: punch, a 30 mm cube's edge in plane strain, and the shipped profile's finger pad (radius 7 mm)
CASES = {
    "sphere": Indenter("sphere", 0.015),
    "punch": Indenter("punch", 0.005, 0.001),
    "cube_edge": Indenter("cube_edge", 0.015, 0.001),
    "finger": Indenter("finger", 0.007),
}
