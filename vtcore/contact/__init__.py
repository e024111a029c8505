"""Contact simulation: proximity of objects to the skin, the soft layer, the sensor, force control.

Entry points: :class:`SoftLayer` (+ :data:`MATERIALS`), :func:`make_object`,
:func:`placement_pose`, :func:`press` -> :class:`PressResult`,
:func:`press_sequence` (trajectories, warm-started), :func:`probe` (mean response
to a target, seed 000), the proximity back-ends (:func:`lower_envelope`,
:func:`signed_distance`) and the sensor functions in :mod:`vtcore.contact.sensor`.
"""

from . import sensor
from .elastic import MODELS, boussinesq_kernel, layer_factor, solve_pk
from .analytic import footprint_pressure
from .force import ProbeResult, probe, solve_monotone
from .materials import MATERIALS, SoftLayer
from .objects import make_object, placement_pose
from .finish import PressResult
from .grid import ContactField, ContactGrid, spread_field, taxel_means
from .press import press, press_sequence
from .proximity import lower_envelope, prepare_mesh, signed_distance

__all__ = [
    "SoftLayer", "MATERIALS", "footprint_pressure", "make_object", "placement_pose", "press", "press_sequence", "PressResult",
    "ContactGrid", "ContactField", "probe", "ProbeResult", "solve_monotone", "MODELS", "layer_factor",
    "solve_pk", "lower_envelope", "signed_distance", "prepare_mesh", "spread_field", "taxel_means", "sensor",
    "boussinesq_kernel",
]
