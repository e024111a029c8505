"""Task ``evaluate``: design maps of the scene's skin on its end-effector (docs/evaluate.md).

Builds the end-effector mesh, the layout and the layer from the scene's tables, and computes
:func:`vtcore.evaluate.evaluate`: detection threshold, localisation error and two-point
discrimination over the covered surface and a margin, and the blind spots. Writes ``maps.ply``
(the end-effector mesh with per-vertex values and the threshold map's colours), the per-sample
arrays, histograms and a 3-D picture of the maps, and the summary table in ``report.md``.

``task.taxels`` keeps a random subset of that many taxels (the others read nothing; drawn from the
scene's seed): seed 001's spatial-resolution study (Fig. 10) as a sweep over it
(``scenes/evaluate_resolution.toml``).
"""

from __future__ import annotations

import numpy as np

from ..budget import MAX_FORCE_N
from ..registry import TaskSpec, register_task
from ..runner import TaskResult
from ..schema import Field, Section

PARAMS = Section({
    "reference_force": Field("float", default=5.0, gt=0, le=MAX_FORCE_N, unit="N",
                             doc="force of the localisation and two-point maps (a firm finger press)"),
    "force_max": Field("float", default=20.0, gt=0, le=MAX_FORCE_N, unit="N",
                       doc="largest force tabulated: the threshold shown where nothing is detected"),
    "blind_limit": Field("float", default=None, gt=0, unit="N",
                         doc="a point is blind where its threshold exceeds this (default: reference_force)"),
    "spacing": Field("float", default=0.002, gt=0, le=1.0, unit="m", doc="distance between evaluated points"),
    "margin": Field("float", default=0.01, ge=0, le=1.0, unit="m", doc="surface evaluated beyond the covered part"),
    "draws": Field("int", default=32, ge=1, le=4096, doc="noise draws of the localisation map"),
    "two_point": Field("bool", default=True, doc="compute the two-point discrimination map"),
    "two_point_spacing": Field("float", default=None, gt=0, le=1.0, unit="m",
                               doc="distance between its points (default: 2 x spacing)"),
    "two_point_step": Field("float", default=0.001, gt=0, unit="m", doc="separations tested, step"),
    "max_separation": Field("float", default=0.05, gt=0, le=1.0, unit="m", doc="largest separation tested"),
    "directions": Field("int", default=4, ge=1, le=36, doc="two-point directions over half a turn"),
    "probe": Field("str", default="fingerpad", choices=("fingerpad", "sphere"), doc="the standard probe"),
    "probe_radius": Field("float", default=None, gt=0, unit="m", doc="probe radius (default: the probe's own)"),
    "probe_length": Field("float", default=None, gt=0, unit="m", doc="finger pad length, tip to tip"),
    "probe_yaw": Field("float", default=0.0, unit="deg", doc="probe turn about the normal from probe_axis"),
    "probe_axis": Field("vec", default=None, length=3,
                        doc="direction the probe's long axis follows on the surface (default: the surface's "
                            "flattest direction, along a link)"),
    "dead": Field("list", default=[], item=Field("int"), doc="taxel ids that read nothing"),
    "taxels": Field("int", default=None, ge=1, doc="keep a random subset of this many taxels (Fig. 10)"),
    "sensor_profile": Field("str", default="cyskin", doc="sensor profile (name or file) for noise and k"),
    "noise_sigma": Field("float", default=None, ge=0, doc="noise sigma in counts (default: the profile's)"),
    "k": Field("float", default=None, gt=0, doc="detection threshold in noise deviations (default: profile's)"),
    "counts_per_pa": Field("float", default=None, gt=0, doc="sensor gain (default: the profile's fit, else 0.1)"),
    "table_spacing": Field("float", default=None, gt=0, le=1.0, unit="m",
                           doc="cell of the probe's response table (default: thickness / 6, 0.2-1 mm)"),
    "table_forces": Field("int", default=9, ge=2, le=64, doc="forces tabulated from 0.02 N to force_max"),
    "colour_by": Field("str", default="threshold", choices=("threshold", "localisation", "two_point"),
                       doc="the map whose colours maps.ply carries"),
})


def settings_of(scene, layout, rng, spread=None):
    """(Settings, SensorNoise, dead ids) from the scene's ``[task]`` and ``[layer]`` tables; ``spread``:
    the listed soft_layer effect (its kernel spreads the stress to the taxels) or None (surface pressure)."""
    from ...evaluate import Probe, Settings, sensor_noise

    t = scene["task"]
    dims = {k: t[f"probe_{k}"] for k in ("radius", "length") if t[f"probe_{k}"] is not None}
    if t["probe"] == "sphere" and "length" in dims:
        raise scene.error("task.probe_length", "a sphere has no length; give probe_radius")
    try:
        probe = Probe(t["probe"], dims, float(np.deg2rad(t["probe_yaw"])))
        probe.mesh()
    except ValueError as exc:
        raise scene.error(f"task.probe_{getattr(exc, 'key', '') or 'radius'}".replace("probe_probe.", "probe_"),
                          str(exc)) from None
    dead = [int(i) for i in t["dead"]]
    if t["taxels"] is not None:
        if t["taxels"] > len(layout):
            raise scene.error("task.taxels", f"the layout has only {len(layout)} taxels")
        keep = rng.choice(len(layout), size=t["taxels"], replace=False)
        dead += [int(i) for i in np.delete(layout.taxel_ids, keep)]
    layer = scene["layer"] or {}
    try:
        noise = sensor_noise(t["noise_sigma"], t["k"], t["counts_per_pa"], t["sensor_profile"] or None)
    except ValueError as exc:
        raise scene.error("task.sensor_profile", str(exc)) from None
    st = Settings(probe=probe, reference_force=t["reference_force"], force_max=max(t["force_max"],
                  t["reference_force"]), blind_limit=t["blind_limit"], draws=t["draws"], seed=int(scene.seed),
                  two_point=t["two_point"], two_point_spacing=t["two_point_spacing"],
                  two_point_step=t["two_point_step"], max_separation=t["max_separation"],
                  two_point_directions=t["directions"], model=layer.get("model", "finite_layer"),
                  spreading=spread.kernel if spread is not None else None,
                  dead=tuple(sorted(set(dead))), table_spacing=t["table_spacing"], table_forces=t["table_forces"],
                  probe_axis=None if t["probe_axis"] is None else _direction(t["probe_axis"]))
    return st, noise


def _direction(v) -> tuple:
    """A direction of any finite length, scaled by its largest component (1e308 overflowed when squared)."""
    v = np.asarray(v, float)
    big = float(np.abs(v).max(initial=0.0))
    return tuple(v / big) if big > 0 else tuple(v)


def display_mesh(mesh, spacing: float, near=None, reach: float = 0.0):
    """The mesh the maps are shown on: ``mesh`` with every edge longer than ``spacing`` split where the maps
    have values (faces within ``reach`` of a point of ``near`` (P, 3)): a CAD export's long slivers or a
    collision hull's few faces would show one value per face otherwise. Its vertices start with the mesh's
    own, in order; the faces elsewhere are the mesh's own."""
    import trimesh
    from scipy.spatial import cKDTree

    from ...layout.repair import face_submesh, refine

    V, F = np.asarray(mesh.vertices, float), np.asarray(mesh.faces, np.int64)
    tri = V[F]
    centre = tri.mean(axis=1)
    rad = np.linalg.norm(tri - centre[:, None], axis=2).max(axis=1)
    if near is None or not len(near):
        region = np.ones(len(F), bool)
    else:
        d, _ = cKDTree(np.asarray(near, float)).query(centre)
        region = d - rad <= reach
    sel = np.flatnonzero(region)
    if not len(sel):
        return mesh
    sub = face_submesh(mesh, sel)
    fine = refine(sub, spacing, max_faces=max(300_000, 2 * len(sel)))
    used = np.flatnonzero(np.bincount(F[sel].ravel(), minlength=len(V)))
    n_sub = len(sub.vertices)
    remap = np.concatenate([used, len(V) + np.arange(len(fine.vertices) - n_sub)])
    verts = np.vstack([V, np.asarray(fine.vertices)[n_sub:]])
    faces = np.vstack([F[~region], remap[np.asarray(fine.faces)]])
    return trimesh.Trimesh(verts, faces, process=False, validate=False)


def run(scene, ctx) -> TaskResult:
    from ...evaluate import evaluate
    from ...evaluate.output import (blind_rows, histograms, map_colours, map_figure, sample_values, summary_rows,
                                    vertex_maps, write_ply)
    from ..._bench import markdown_table
    from ..sections.layer import build_layer
    from ..sections.layout import build_end_effector, build_layout

    t = scene["task"]
    mesh = build_end_effector(scene)
    layout = build_layout(scene)
    layer = build_layer(scene)
    st, noise = settings_of(scene, layout, ctx.child_rng("taxels"), ctx.pipeline.get("soft_layer"))
    try:
        dm = evaluate(layout, mesh, layer, st, noise, spacing=t["spacing"], margin=t["margin"])
    except ValueError as exc:
        key = getattr(exc, "key", None) or "spacing"
        raise scene.error(f"task.{key}" if "." not in key else key, getattr(exc, "reason", str(exc))) from None
    shown = display_mesh(mesh, 1.5 * t["spacing"], dm.samples.positions, 2 * t["spacing"])
    vm = vertex_maps(dm, shown.vertices, shown.vertex_normals)
    rgba, legend = map_colours(vm, t["colour_by"], hi=st.limit if t["colour_by"] == "threshold" else None)
    write_ply(ctx.out / "maps.ply", shown.vertices, shown.faces, vm, rgba,
              comments=[f"colours: {' / '.join(legend.lines())}",
                        f"the end-effector mesh, edges longer than {1.5 * t['spacing'] * 1e3:g} mm split "
                        f"(its first {len(mesh.vertices)} vertices are the mesh's own)"])
    metrics = dm.summary()
    arrays = {"positions": layout.positions, "normals": layout.normals, "taxel_ids": layout.taxel_ids,
              "live": ~np.isin(layout.taxel_ids, st.dead), "sample_positions": dm.samples.positions,
              "sample_normals": dm.samples.normals, "sample_areas": dm.samples.areas,
              "sample_distance": dm.samples.distance,
              **{f"sample_{k}": np.asarray(v) for k, v in sample_values(dm).items()},
              "table_forces": dm.table.forces, "table_x": dm.table.x, "table_y": dm.table.y,
              "table_values": dm.table.values}
    sections = [
        "## Design maps", "",
        f"Probe: {st.probe.describe()}; reference force {st.reference_force:g} N; blind where the threshold "
        f"exceeds {st.limit:g} N. Sensor: {noise.source}. Detection: a taxel reading more than "
        f"k sigma = {noise.threshold_counts:.4g} counts ({noise.threshold_pa:.4g} Pa at the taxel). "
        f"{dm.taxels_live} live taxels of {len(layout)}; {len(dm.samples)} points every "
        f"{dm.samples.spacing * 1e3:g} mm, covered = within {dm.samples.cover * 1e3:.3g} mm of a taxel, "
        f"margin {dm.samples.margin * 1e3:g} mm beyond it. Estimator: the reading-weighted centroid of the "
        f"taxels above k sigma, expected over {st.draws} noise draws. Method and its limits: docs/evaluate.md.",
        "", markdown_table(summary_rows(dm)), "", *saturation_note(dm), "Blind spots:", "",
        markdown_table(blind_rows(dm)), "",
        f"`maps.ply`: the end-effector mesh (edges split to the spacing) with per-vertex `threshold_n`, `localisation_mm`, `two_point_mm`, "
        f"`detect_rate`, `blind`, `evaluated`, `covered`, coloured by {legend.title.lower()} "
        f"({'; '.join(legend.lines()[1:])}).", ""]
    figures = {}
    if scene["output"]["plots"]:  # the runner closes only the figures it saves: never built and left open
        live = layout.positions[~np.isin(layout.taxel_ids, st.dead)]
        figures = {"histograms": histograms(dm), "maps": map_figure(dm, live)}
    return TaskResult(metrics, arrays, figures, sections, files=["maps.ply"])


def saturation_note(dm) -> list[str]:
    """A paragraph when the reference force drives taxels to the read-out's ceiling somewhere (else none)."""
    share = dm.summary().get("saturated_covered_fraction", 0.0)
    if not share:
        return []
    return [f"At the reference force {dm.settings.reference_force:g} N some taxel reads the read-out's ceiling "
            f"({dm.noise.max_counts:.0f} counts) on {share * 100:.0f} % of the covered surface: the sensor clips "
            "there, and so do these maps (localisation and two-point read flat-topped blobs). A lighter reference "
            "force, a thicker layer or a lower gain keeps the readings in range.", ""]


def sweep_summary(scene, rows, grid_keys) -> str:
    """The designs side by side: the covered surface's medians and 95th percentiles and the blind area."""
    from ..._bench import markdown_table

    cols = [("threshold_covered_median_n", "threshold median (N)"), ("threshold_covered_p95_n", "p95 (N)"),
            ("localisation_covered_median_mm", "localisation median (mm)"),
            ("localisation_covered_p95_mm", "p95 (mm)"), ("two_point_covered_median_mm", "two-point median (mm)"),
            ("two_point_covered_p95_mm", "p95 (mm)"), ("blind_area_covered_cm2", "blind, covered (cm^2)"),
            ("covered_area_cm2", "covered (cm^2)"), ("taxels_live", "taxels")]
    table = []
    for r in rows:
        if r.get("status") != "ok":
            continue
        row = {k: r["grid"].get(k) for k in grid_keys}
        row["seed"] = r.get("seed")
        row.update({label: r["metrics"].get(key) for key, label in cols})
        table.append(row)
    if not table:
        return ""
    return "\n".join(["### Designs side by side (covered surface)", "", markdown_table(table), ""])


register_task(TaskSpec("evaluate", run, PARAMS, sections=(), effects=("soft_layer",), doc="design maps: detection, localisation, "
                       "two-point discrimination and blind spots of a skin (issue 29)", sweep_summary=sweep_summary))
