"""Contact simulation: proximity of objects to the skin, the soft layer, force control."""

from .press import boussinesq_kernel, median_taxel_area, press_sphere, spread_through_layer

__all__ = ["press_sphere", "spread_through_layer", "boussinesq_kernel", "median_taxel_area"]
