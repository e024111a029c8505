"""Contact effects: the soft layer's spreading of stress."""

from __future__ import annotations

from ...contact import spread_through_layer
from ..registry import EffectSpec, register_effect
from ..schema import Section


class SoftLayer:
    """Spreads the surface pressure to the taxels at the layer's depth."""

    def __init__(self, p, ctx):
        pass

    def apply(self, state, ctx):
        state["pressure"] = spread_through_layer(state["positions"], state["pressure"],
                                                 state["thickness"], state["taxel_area"])
        return state


register_effect(EffectSpec("soft_layer", "contact", 10, SoftLayer, Section({}),
                           doc="Boussinesq spreading of stress through the layer"))
