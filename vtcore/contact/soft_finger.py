"""A soft indenter: a fingertip whose pad deforms too, pressed on the soft layer.

A real press is made by a finger: soft pulp a few millimetres thick over the distal phalanx (a
rigid, bone-like core), curved, about as soft as the skin's silicone. Two deformable bodies touch,
and both take part of the approach. For two linear elastic bodies with a frictionless contact the
relative surface approach at a point is the sum of the two bodies' displacements (Johnson,
*Contact Mechanics*, 1985, section 4.2: the gap ``h(x) + u1(x) + u2(x) - d``), each the
convolution of the same contact pressure with its own surface compliance kernel. So a soft
indenter is solved exactly as a rigid one, with the kernel ``K_layer + K_pad``: the skin layer's
(bonded to the end-effector) plus the pad's, a layer of the pad's modulus and of thickness
``core_depth`` bonded to its rigid core. Two half-spaces give Hertz's combined modulus
``1/E* = 1/E1* + 1/E2*`` (tested); a pad as soft as the layer spreads the same force over a larger
footprint with a lower peak (tested). Its pressure stays dome-shaped: a plateau under a soft pad
would need the pad's large deformation, which the linear kernels do not hold.

What it neglects, stated: the pad's surface is treated as flat at the scale of its compliance
kernel (its curvature enters through the geometry only, as in Hertz), and the bottoming-out check
of :func:`vtcore.contact.press` counts the whole approach (the pad's share too) against the skin
layer's thickness, so it refuses a force early rather than late.

Use: ``press(layout, make_object("fingerpad", radius=...), pose, soft_indenter(layer, pad), ...)``,
or the calibration's indenter kind ``"softfinger"`` (:mod:`vtcore.calibrate.simulate`).
"""

from __future__ import annotations

from dataclasses import dataclass, fields

from ..errors import InputError
from .materials import SoftLayer

#: the soft finger's parameters and their defaults (starting values, not measurements: the
#: calibration fits them): the pad's Young's modulus, Pa (fingertip pulp at small strain is of the
#: order of the skin silicone's, tens of kPa), the depth of soft tissue over the distal phalanx, m
#: (a few millimetres at the pad's centre) and its Poisson's ratio (nearly incompressible tissue)
FINGER_DEFAULTS = {"pad_modulus": 50e3, "core_depth": 0.004, "pad_poisson": 0.49}


@dataclass
class SoftIndenterLayer(SoftLayer):
    """The skin's soft layer pressed by a soft indenter: the layer's fields (:class:`SoftLayer`) and
    ``pad``, the indenter's own soft layer over its rigid core (a :class:`SoftLayer`: its
    thickness is the core depth, m; its modulus and Poisson's ratio the pad's). The compliance
    operator (:func:`vtcore.contact.elastic.compliance_operator`) sums the two kernels."""

    pad: SoftLayer | None = None

    def __post_init__(self):
        super().__post_init__()
        if not isinstance(self.pad, SoftLayer) or isinstance(self.pad, SoftIndenterLayer):
            raise InputError("must be a SoftLayer (the indenter's pad over its rigid core)", key="pad")
        if not self.pad.thickness > 0:
            raise InputError(f"must be > 0 m (the soft tissue over the rigid core), got {self.pad.thickness}",
                             key="core_depth")


def finger_pad(pad_modulus: float, core_depth: float, pad_poisson: float = 0.49) -> SoftLayer:
    """The soft pad of a finger: a layer of ``pad_modulus`` Pa, ``core_depth`` m over the rigid core."""
    for key, v in (("pad_modulus", pad_modulus), ("core_depth", core_depth)):
        try:
            ok = float(v) > 0 and float(v) < float("inf")
        except (TypeError, ValueError):
            ok = False
        if isinstance(v, bool) or not ok:
            raise InputError(f"must be a number > 0, got {v!r}", key=key)
    return SoftLayer(thickness=float(core_depth), young_modulus=float(pad_modulus), poisson=float(pad_poisson))


def soft_indenter(layer: SoftLayer, pad: SoftLayer) -> SoftIndenterLayer:
    """``layer`` pressed by an indenter with the soft ``pad`` (see :func:`finger_pad`)."""
    if not isinstance(layer, SoftLayer):
        raise InputError("layer must be a vtcore.contact.SoftLayer", key="layer")
    own = {f.name: getattr(layer, f.name) for f in fields(SoftLayer) if f.init}
    return SoftIndenterLayer(**own, pad=pad)
