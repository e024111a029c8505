"""``[layer]``: the soft layer over the skin and how its contact is simulated.

Thickness, material (or young_modulus/poisson), extent (radius of the layer),
base (bonded or frictionless), and the contact model, grid_spacing,
samples_per_taxel, proximity backend and geometry: :func:`build_layer` makes the
:class:`vtcore.contact.SoftLayer`, :func:`layer_options` the keyword arguments of
:func:`vtcore.contact.press`. The choices are the contact package's own option
sets, so a new model or back-end there is valid here without an edit.
"""

from __future__ import annotations

from ...contact.elastic import BASES, MODELS
from ...contact.materials import MATERIALS, SoftLayer
from ...contact.press import GEOMETRIES
from ...contact.proximity import BACKENDS
from ..registry import register_section
from ..schema import Field, Section

LAYER = Section({
    "profile": Field("str", default=None,
                     doc="sensor profile whose fitted layer ([response]: thickness, material, modulus, base) "
                         "this layer is, unless a key below says otherwise (\"cyskin\" or a .toml file)"),
    # at least 1 um (no elastomer layer is thinner): 5e-324 m gave NaN in the frames (found by --fuzz-long)
    "thickness": Field("float", default=None, ge=1e-6, unit="m", doc="soft layer thickness (default 3 mm, at least 1 um)"),
    "material": Field("str", default=None, choices=tuple(MATERIALS), doc="layer material (default Ecoflex 00-20)"),
    "young_modulus": Field("float", default=None, ge=1.0, le=1e12, unit="Pa",
                           doc="overrides the material's E (1 Pa..1 TPa; silicones 1e4-1e6, steel 2e11)"),
    "poisson": Field("float", default=None, ge=0, lt=0.5, doc="overrides the material's Poisson ratio"),
    "extent": Field("float", default=None, gt=0, unit="m", doc="radius of the layer (seed 001: 0.04)"),
    "base": Field("str", default=None, choices=BASES,
                  doc="the layer's interface with the end-effector: glued (the default), or a pad that slides"),
    "model": Field("str", default="finite_layer", choices=MODELS,
                   doc="contact model: finite_layer (linear), hyperelastic (the finite layer in a Seth-Hill "
                       "strain, for compressions past ~30 %), halfspace or local (see docs/contact.md)"),
    "grid_spacing": Field("float", default=1e-3, gt=0, le=0.01, unit="m",
                          doc="contact grid cell size (at most 1 cm: it is averaged over 4 mm taxel discs)"),
    "samples_per_taxel": Field("int", default=7, ge=1, doc="points averaged over each 4 mm taxel disc"),
    "backend": Field("str", default="auto", choices=("auto",) + BACKENDS, doc="proximity back-end"),
    "geometry": Field("str", default="plane", choices=GEOMETRIES,
                      doc="solve on the plane normal to the press (flat patches) or on the layout's unrolled "
                          "flat coordinates with the layer compressed along its normals (curved patches)"),
})

register_section("layer", Field("table", default=None, section=LAYER))


DEFAULTS = {"thickness": 3e-3, "material": "ecoflex_00_20", "base": "bonded"}


def layer_values(scene) -> dict:
    """The ``[layer]`` keys with the profile's fitted layer and the defaults filled in (explicit keys win)."""
    t = dict(scene["layer"] or LAYER.defaults())
    if t.get("profile"):
        from ...contact.profile import load_profile

        try:
            prof = load_profile(t["profile"])
        except ValueError as exc:
            raise scene.error("layer.profile", getattr(exc, "reason", str(exc))) from None
        r = prof.response
        if r is None:
            raise scene.error("layer.profile", f"profile {prof.name!r} ({prof.path}) has no [response]: no fitted "
                                               "layer to take")
        fitted = {"thickness": r.thickness, "material": r.material, "young_modulus": r.young_modulus,
                  "poisson": r.poisson, "base": r.base}
        for k, v in fitted.items():
            if t.get(k) is None:
                t[k] = v
    for k, v in DEFAULTS.items():
        if t.get(k) is None:
            t[k] = v
    return t


def build_layer(scene) -> SoftLayer:
    """The scene's SoftLayer (defaults when there is no ``[layer]`` table)."""
    t = layer_values(scene)
    try:
        return SoftLayer(thickness=t["thickness"], material=t["material"], young_modulus=t["young_modulus"],
                         poisson=t["poisson"], extent=t["extent"], base=t["base"])
    except ValueError as exc:
        raise scene.error(f"layer.{getattr(exc, 'key', '') or 'thickness'}", getattr(exc, "reason", str(exc)))


def layer_options(scene) -> dict:
    """Keyword arguments for vtcore.contact.press from ``[layer]``: model, grid, samples, backend."""
    from ...contact.grid import ContactGrid

    t = scene["layer"] or LAYER.defaults()
    return {"model": t["model"], "grid": ContactGrid(spacing=t["grid_spacing"]),
            "samples_per_taxel": t["samples_per_taxel"], "backend": None if t["backend"] == "auto" else t["backend"],
            "geometry": t["geometry"]}
