"""Named tolerances: the small numbers vtcore divides by or compares with, named for what they mean.

One place, so that one meaning has one value everywhere and a reader can see why
it is that size. Unit conversions (``1e-3``: millimetres to metres) are not
tolerances and stay where they are; a tolerance that only one function uses, with
a meaning of its own, stays a named constant of its module.
"""

from __future__ import annotations

#: Floor of a divisor that is a norm, an area, a weight sum or a scale
#: (``x / max(n, TINY)``): it guards 0/0 only; any nonzero float64 magnitude met in
#: practice is hundreds of orders above it, so it never changes a result.
TINY = 1e-300

#: Zero for a quantity of order one (a norm of a unit-scale vector, a slope, a
#: relative difference): below it the value counts as zero. Float64 rounding of
#: such quantities is ~1e-16, so it leaves four orders of room.
EPS = 1e-12

#: Metres: points, steps or lengths below this are the same point / no motion
#: (a nanometre: far below any taxel pitch or mesh feature, far above float64
#: rounding of coordinates of a metre-sized scene, ~1e-16 m).
LENGTH_TOL = 1e-9

#: A normal vector (meant to be unit length) shorter than this is missing: a file
#: gave zeros, or nobody estimated it. Readers estimate it; writers that need an
#: axis refuse it.
ZERO_NORMAL = 1e-9
