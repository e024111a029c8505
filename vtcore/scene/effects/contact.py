"""Contact effects: the soft layer's spreading of stress, and the object's own compliance.

``soft_layer``: the stress that reaches the taxels at the layer's base, spread
from the surface pressure with the Boussinesq kernel (width ~1.13 h). Without
it the taxels read the surface pressure above them.

``object_compliance``: the object's local stiffness (N/m, from its
``[[objects]]`` table: ``stiffness``, ``stiffness_edge``, ``stiffness_file``) in
series with the layer, so the end-effector travels further on soft regions
(seed 000, Eq. 1). ``default_stiffness`` applies to objects that give none.

State (a dict) passed by the press task: ``layout``, ``layer``, ``results``
(list of PressResult, one per frame), ``pressure (T, N)`` Pa; the effects add to
it.
"""

from __future__ import annotations

import numpy as np

from ...contact.elastic import SPREADINGS
from ...contact.grid import spread_field, taxel_means
from ..budget import STIFFNESS_N_M
from ..registry import EffectSpec, register_effect
from ..schema import Field, Section


class SoftLayerSpreading:
    """Spreads each frame's surface pressure to the taxels at depth h."""

    def __init__(self, p, ctx):
        self.samples = p["samples_per_taxel"]
        self.kernel = p["kernel"]

    def apply(self, state, ctx):
        layout, layer = state["layout"], state["layer"]
        rows = []
        s = self.samples or state.get("samples_per_taxel", 7)
        state["taxel_samples"] = s  # so plots read the grid fields exactly as the taxels were read
        for r in state["results"]:
            r.field.stress = spread_field(r.field, layer, self.kernel)
            rows.append(taxel_means(layout, r.field, r.field.stress, s))
        state["pressure"] = np.asarray(rows).reshape(np.shape(state["pressure"]))
        return state


class ObjectCompliance:
    """Adds the object's deflection F / k(contact point) to the end-effector displacement."""

    def __init__(self, p, ctx):
        self.default = p["default_stiffness"]

    def stiffness(self, compliance, mesh, result):
        """k (N/m) at the contact of ``result``; ``compliance`` as for vtcore.contact.press."""
        from ...contact.finish import object_stiffness

        spec = compliance if compliance is not None else self.default
        return object_stiffness(spec, mesh, result.pose, result.contact_point)

    def apply(self, state, ctx):
        comp, mesh = state.get("compliance"), state["mesh"]
        defl = []
        for r in state["results"]:
            if r.force > 0 and np.all(np.isfinite(r.contact_point)):
                defl.append(r.force / self.stiffness(comp, mesh, r))
            else:
                defl.append(0.0)
        state["object_deflection"] = np.asarray(defl)
        state["displacement"] = np.asarray([r.indentation for r in state["results"]]) + state["object_deflection"]
        return state


register_effect(EffectSpec("soft_layer", "contact", 10, SoftLayerSpreading, Section({
    "samples_per_taxel": Field("int", default=0, ge=0,
                               doc="points averaged over each taxel disc (0: the [layer] setting)"),
    "kernel": Field("str", default="layer", choices=SPREADINGS,
                    doc="exact base stress of the layer, or the Boussinesq half-space stress at depth h")}),
    doc="Boussinesq spreading of stress through the layer to the taxels"))
register_effect(EffectSpec("object_compliance", "contact", 20, ObjectCompliance, Section({
    "default_stiffness": Field("float", default=5000.0, ge=STIFFNESS_N_M[0], le=STIFFNESS_N_M[1], unit="N/m",
                               doc="stiffness of objects whose table gives none")}),
    doc="object's local stiffness in series with the layer"))


def spread_options(pipeline) -> dict:
    """``press()`` keywords of the listed ``soft_layer`` effect: spread the stress through the layer only
    when the scene lists ``[effects.soft_layer]``, with its kernel (and its samples per taxel, if set).
    Tasks that press through vtcore.contact.press pass these instead of press's own default (spread)."""
    fx = pipeline.get("soft_layer")
    if fx is None:
        return {"spread": False}
    kw = {"spread": True, "spreading": fx.kernel}
    if fx.samples:
        kw["samples_per_taxel"] = fx.samples
    return kw
