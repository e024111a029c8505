"""Design maps of a skin: where a touch goes unnoticed, how light a touch is felt, how precisely it is
located and told apart from a second one (issue 29; docs/evaluate.md).

Entry points: :func:`evaluate` (maps on a mesh: :class:`DesignMap`), :func:`evaluate_points` (maps at
given points), :class:`Settings`, :class:`Probe`, :func:`sensor_noise` (k sigma and gain from the
sensor profile), :func:`reference_points` (the same maps press by press), :func:`write_outputs`
(PLY, arrays, report) and :func:`compare` (several designs side by side).
"""

from .design import DesignMap, PointMaps, Settings, evaluate, evaluate_points, live_taxels, weighted_quantiles
from .noise import SensorNoise, sensor_noise
from .probe import PROBES, Probe, ResponseTable, response_table
from .reference import reference_points
from .samples import SurfaceSamples, cover_radius, sample_surface, vertex_samples

__all__ = ["evaluate", "evaluate_points", "DesignMap", "PointMaps", "Settings", "Probe", "PROBES", "ResponseTable",
           "response_table", "SensorNoise", "sensor_noise", "reference_points", "SurfaceSamples", "sample_surface",
           "vertex_samples", "cover_radius", "live_taxels", "weighted_quantiles"]
