"""Conform flat patches to curved surfaces, the way a flexible PCB wraps them.

Placement maps the flat patch domain onto a triangle mesh around a point ``at``
with the patch's x axis along an in-plane ``direction``:

- ``method="logmap"`` (default): the inverse of the surface's logarithmic map
  at ``at`` (the exponential map), computed with the vector heat method
  (Sharp, Soliman, Crane 2019) as implemented by potpourri3d
  (geometry-central). Geodesic distance and direction from ``at`` are kept
  exactly; what strain remains is what the surface's Gaussian curvature forces
  (none on developable surfaces such as cylinders and planes). The mesh is
  cropped to the part within reach of the patch first, so a small patch on a
  large mesh only factors a small system.
- ``method="project"``: the baseline: lay the flat patch in the tangent plane at
  ``at`` and move every taxel to its closest point on the surface. Cheap, but
  distances shrink as the surface curves away (the benchmark shows how much).

Every taxel lands on the surface (on a mesh face) with the interpolated surface
normal, then moves ``offset`` metres along it. Taxels whose flat position maps
outside an open boundary of the mesh are reported (``off_boundary``) and kept at
their closest surface point, never silently dropped.

The :class:`PlacementReport` gives per patch: the strain of module edges against
the flat layout (edge length on the surface, measured as the arc through both
taxels with their normals, over the flat length, minus one: bending is free for a
flexible PCB, stretching is not), module overlaps (taxels of different modules
closer than ``overlap_fraction`` of the pitch), off-boundary taxels, and the
coverage of the chosen region (area of the region under module outlines over the
region's area).

Where each part lives (this module only gathers the public names):

- :mod:`.repair`: mesh repair (merge, degenerate and duplicate faces, non-manifold edges,
  bowties, subdivision of coarse faces, simplification);
- :mod:`.surface`: closest points, the exact snap of ``at``, surface normals;
- :mod:`.logmap`: :class:`LogMap` (the log map and its inverse, ``exp``);
- :mod:`.placement`: :func:`place`; :mod:`.tiling`: :func:`fill`;
- :mod:`.report`: :class:`PlacementReport`, strain, overlaps, coverage;
- :mod:`vtcore.geometry`: triangle and frame helpers shared with contact, filters and augment.
"""

from __future__ import annotations

from ..geometry import closest_point_on_triangles
from .tiling import fill
from .logmap import LogMap
from .placement import place
from .repair import clean_mesh
from .report import (OVERLAP_FRACTION, PlacementReport, arc_lengths, find_overlaps, find_overlaps_between,
                     layout_strain, points_in_outlines)

__all__ = ["LogMap", "PlacementReport", "place", "fill", "clean_mesh", "closest_point_on_triangles",
           "arc_lengths", "layout_strain", "find_overlaps", "find_overlaps_between", "points_in_outlines",
           "OVERLAP_FRACTION"]
