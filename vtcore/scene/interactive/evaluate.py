"""Design maps for a front end: evaluate a skin on the mesh it lies on, one value per mesh vertex."""

from __future__ import annotations

from dataclasses import dataclass, field

from ...errors import InputError
from ...layout import Layout
from .common import as_trimesh
from .contact import soft_layer


@dataclass
class SkinMap:
    """Design maps on a mesh's own vertices, ready to write as attributes.

    values : name -> (V,) per vertex (``threshold_n`` N, ``localisation_mm``, ``two_point_mm``,
    ``detect_rate``; ``blind``, ``evaluated``, ``covered`` bool). colours : map -> (V, 4) RGBA in [0, 1]
    (grey: not evaluated; red: no value). legends : map -> :class:`vtcore.evaluate.colours.Legend`.
    summary : the area-weighted metrics (:meth:`vtcore.evaluate.DesignMap.summary`). lines : the
    report the panel shows.
    """

    values: dict
    colours: dict
    legends: dict
    summary: dict
    lines: list = field(default_factory=list)


def evaluate_skin(layout: Layout, mesh_vertices, mesh_triangles, *, thickness: float,
                  material: str = "ecoflex_00_20", reference_force: float = 5.0, spacing: float = 0.002,
                  margin: float = 0.01, probe: str = "fingerpad", two_point: bool = True, draws: int = 32,
                  dead=(), counts_per_pa: float | None = None, seed: int = 0) -> SkinMap:
    """The design maps of ``layout`` on the mesh (vertices (V, 3) m and triangles (F, 3) in the skin's
    frame): every map on every vertex of that mesh, with colours and legends (docs/evaluate.md)."""
    from ...evaluate import Probe, Settings, evaluate, sensor_noise
    from ...evaluate.colours import QUANTITIES
    from ...evaluate.output import map_colours, vertex_maps

    if len(layout) == 0:
        raise InputError("the skin has no taxels", key="layout")
    mesh = as_trimesh(mesh_vertices, mesh_triangles)
    layer = soft_layer(thickness, material)
    st = Settings(probe=Probe(probe), reference_force=float(reference_force), two_point=bool(two_point),
                  draws=int(draws), dead=tuple(int(d) for d in dead), seed=int(seed))
    noise = sensor_noise(counts_per_pa=counts_per_pa)
    dm = evaluate(layout, mesh, layer, st, noise, spacing=spacing, margin=margin)
    vm = vertex_maps(dm, mesh.vertices, mesh.vertex_normals)
    colours, legends = {}, {}
    for key, q in QUANTITIES.items():
        if q.attribute in vm:
            # the threshold map's range ends at the blind limit: yellow means 'too hard to be a touch'
            colours[key], legends[key] = map_colours(vm, key, hi=st.limit if key == "threshold" else None)
    s = dm.summary()
    lines = [f"{s['samples']} points, {s['taxels_live']} live taxels, {st.probe.describe()} at "
             f"{st.reference_force:g} N",
             f"threshold median {s['threshold_covered_median_n']:.3g} N (p95 "
             f"{s['threshold_covered_p95_n']:.3g} N)",
             f"localisation median {s['localisation_covered_median_mm']:.3g} mm (p95 "
             f"{s['localisation_covered_p95_mm']:.3g} mm)"]
    # the numbers hinge on the sensor: say which one (a front end's gain is its own setting, the command's
    # the profile's fitted one)
    lines.insert(1, f"a taxel detects above {noise.k:g} x {noise.sigma:.0f} counts = {noise.threshold_pa:.3g} Pa "
                    f"(gain {noise.counts_per_pa:.3g} counts/Pa{'' if counts_per_pa is None else ', as set'})")
    if "two_point_covered_median_mm" in s:
        lines.append(f"two-point median {s['two_point_covered_median_mm']:.3g} mm")
    lines.append(f"blind: {s['blind_area_covered_cm2']:.3g} of {s['covered_area_cm2']:.3g} cm^2 covered, "
                 f"{s['blind_area_margin_cm2']:.3g} cm^2 of the margin")
    if s.get("saturated_covered_fraction", 0.0) > 0:
        lines.append(f"{st.reference_force:g} N drives taxels to the read-out's ceiling on "
                     f"{s['saturated_covered_fraction'] * 100:.0f} % of the skin (readings clipped)")
    return SkinMap(vm, colours, legends, s, lines)
