"""Task ``press``: press the scene's object onto the skin and read the skin.

Hold mode (no keyframes): the object moves along the press direction until the
total force is ``task.force`` (or, with ``task.target_response``, until the mean
response reaches it, seed 000's p-bar*), and ``task.readings`` readings are taken
at ``task.rate``. Trajectory mode (the object has ``keyframes``): the object
follows its keyframed poses (no force control), simulated at ``task.rate``,
each frame warm-started from the previous one.

Contact-stage effects (``soft_layer``, ``object_compliance``), sensor-stage
effects and transport-stage effects (``can``: the counts' CAN round trip, after the
sensor stage) run only when listed. Arrays: ``positions``, ``normals``, ``taxel_ids``,
``timestamps (T,)``, ``frames (T, N)`` counts, ``pressure (T, N)`` Pa before
the sensor effects, ``surface_pressure (T, N)``, ``force (T,)``,
``contact_area (T,)``, ``indentation (T,)`` and, with object compliance,
``displacement (T,)``; the last frame's grid: ``grid_x``, ``grid_y``,
``grid_pressure`` (and ``grid_stress`` with ``soft_layer``); the profile plot's cut through
the contact centre (:func:`profile_cut`): ``profile_s``, ``profile_surface_pressure``,
``profile_stress``, ``profile_disc_mean`` and the taxels it crosses, ``profile_taxel_*``.
"""

from __future__ import annotations

import warnings

import numpy as np

from ...contact import press, press_sequence, probe
from ...contact.finish import ResolutionWarning, resolution_warnings
from ...contact.materials import LargeDeformationWarning, compression_note
from ...plots import pyplot, skin_3d, taxel_map
from ...tolerances import EPS
from ..registry import CONTACT_EFFECTS, SENSOR_EFFECTS, TaskSpec, register_task
from ..runner import TaskResult
from ..budget import MAX_FORCE_N, check_frames
from ..schema import Field, Section
from ..sections.layer import build_layer, layer_options
from ..sections.objects import keyframe_poses, object_compliance, object_mesh, object_pose
from ..sections.layout import build_end_effector, build_layout

PARAMS = Section({
    "force": Field("float", default=10.0, gt=0, le=MAX_FORCE_N, unit="N", doc="target total normal force"),
    "target_response": Field("float", default=None, gt=0,
                             doc="target mean response p-bar* in counts (replaces force; seed 000: 4000)"),
    "object": Field("int", default=0, ge=0, doc="which [[objects]] entry to press"),
    "readings": Field("int", default=10, ge=1, doc="sensor readings taken while holding the force"),
    "rate": Field("float", default=20.0, gt=0, unit="Hz", doc="simulation / sensor sampling rate"),
    "direction": Field("vec", default=None, length=3, doc="press direction (default: -mean taxel normal)"),
    "profile_angle": Field("float", default=0.0, unit="deg",
                           doc="direction of the profile plot's cut through the contact centre, from the "
                               "contact grid's x axis (the end-effector's x on a flat patch) towards its y"),
})


def _field_figure(fld, layout, title, cut=None):
    """Surface pressure and, when spread, the stress at the taxels' depth, with the taxel discs."""
    plt = pyplot()
    panels = [("surface pressure", fld.pressure)] + ([("stress at the taxels' depth", fld.stress)]
                                                     if fld.stress is not None else [])
    fig, axes = plt.subplots(1, len(panels), figsize=(5.2 * len(panels), 4.4), squeeze=False)
    txy = fld.taxel_xy(layout) * 1e3
    ext = [fld.x[0] * 1e3, fld.x[-1] * 1e3, fld.y[0] * 1e3, fld.y[-1] * 1e3]
    vmax = max(float(fld.pressure.max()), EPS)
    for ax, (name, img) in zip(axes[0], panels):
        im = ax.imshow(img.T, origin="lower", extent=ext, cmap="magma", vmin=0, vmax=vmax)
        ax.scatter(txy[:, 0], txy[:, 1], s=16, facecolors="none", edgecolors="c", linewidths=0.6)
        if cut is not None and len(cut["s"]):  # the profile plot's cut
            rc = cut["centre"] - fld.origin
            c2 = np.array([rc @ fld.e1, rc @ fld.e2])
            d2 = np.array([cut["direction"] @ fld.e1, cut["direction"] @ fld.e2])
            ends = (c2 + np.outer(cut["s"][[0, -1]], d2)) * 1e3
            ax.plot(ends[:, 0], ends[:, 1], color="w", lw=0.7, ls="--")
        ax.set_title(name)
        ax.set_xlabel("x (mm)")
        ax.set_ylabel("y (mm)")
        fig.colorbar(im, ax=ax, label="Pa", shrink=0.85)
    fig.suptitle(title)
    return fig


def profile_cut(fld, layout, taxel_values, *, angle_deg=0.0, samples=7, radius=None):
    """A straight cut through the contact centre of ``fld`` and the taxels whose discs it crosses.

    The cut passes through the force-weighted centre of the surface pressure (the grid centre
    without contact) along the grid direction ``cos(a) e1 + sin(a) e2`` (``a = angle_deg``; e1 is
    the end-effector's x for a flat patch). Every curve is read from the same grid fields the
    taxels are read from: ``surface`` and ``stress`` (when spread) at the cut's points, and
    ``disc_mean``, the mean over a taxel disc centred on each cut point of the field the taxels
    read (stress when spread, else surface pressure) with the taxels' own disc samples, so a
    taxel centred on the cut reads exactly the ``disc_mean`` curve at its position.

    taxel_values : (N,) Pa, the taxels' readings of that field (PressResult.pressure or the
    soft_layer effect's output). Returns a dict of arrays: ``s (K,)`` m along the cut (0 at the
    centre), ``surface (K,)``, ``stress (K,)`` or None, ``disc_mean (K,)`` Pa; ``taxel_index (M,)``,
    ``taxel_s (M,)`` m, ``taxel_offset (M,)`` m (distance from the cut), ``taxel_value (M,)`` Pa
    (the taxels whose discs the cut crosses or, when fewer than two, those within half a pitch);
    ``centre (3,)`` m and ``direction (3,)`` unit, both in the end-effector frame (for a contact
    solved in the layout's flat domain, ``geometry = "unrolled"``: in the flat coordinates, z = 0).
    """
    from ...contact.grid import TAXEL_RADIUS, disc_offsets, sample_bilinear

    radius = TAXEL_RADIUS if radius is None else radius
    p = fld.pressure
    X, Y = np.meshgrid(fld.x, fld.y, indexing="ij")
    if p.sum() > 0:
        c = np.array([(X * p).sum(), (Y * p).sum()]) / p.sum()
    else:
        c = np.array([0.5 * (fld.x[0] + fld.x[-1]), 0.5 * (fld.y[0] + fld.y[-1])])
    a = np.deg2rad(angle_deg)
    t = np.array([np.cos(a), np.sin(a)])       # along the cut, grid coordinates
    o = np.array([-t[1], t[0]])                # across the cut
    ds = max(fld.spacing, 1e-6) / 4
    half = 0.5 * np.hypot(fld.x[-1] - fld.x[0], fld.y[-1] - fld.y[0])
    s = np.arange(-np.ceil(half / ds), np.ceil(half / ds) + 1) * ds
    pts = c + s[:, None] * t
    inside = ((pts[:, 0] >= fld.x[0]) & (pts[:, 0] <= fld.x[-1]) & (pts[:, 1] >= fld.y[0]) & (pts[:, 1] <= fld.y[-1]))
    s, pts = s[inside], pts[inside]
    read = fld.stress if fld.stress is not None else fld.pressure
    off = disc_offsets(samples, radius)
    disc = sample_bilinear(pts[:, None, :] + off[None, :, :], read, fld.x, fld.y).mean(axis=1)
    # taxels where taxel_means reads them
    txy = fld.taxel_xy(layout) - c
    ts, to = txy @ t, txy @ o
    idx = np.flatnonzero(np.abs(to) < radius)
    if len(idx) < 2 and len(txy) > 1:
        # the cut runs between two rows of taxels: show the rows within half a pitch of it
        from scipy.spatial import cKDTree

        pitch = float(np.median(cKDTree(txy).query(txy, k=2)[0][:, 1]))
        idx = np.flatnonzero(np.abs(to) < max(radius, 0.5 * pitch))
    idx = idx[np.argsort(ts[idx], kind="stable")]
    centre = fld.origin + c[0] * fld.e1 + c[1] * fld.e2
    return {"s": s, "surface": sample_bilinear(pts, fld.pressure, fld.x, fld.y),
            "stress": sample_bilinear(pts, fld.stress, fld.x, fld.y) if fld.stress is not None else None,
            "disc_mean": disc, "taxel_index": idx, "taxel_s": ts[idx], "taxel_offset": to[idx],
            "taxel_value": np.asarray(taxel_values, float)[idx], "centre": centre,
            "direction": t[0] * fld.e1 + t[1] * fld.e2, "domain": fld.domain}


def _profile_figure(cut, title):
    """The cut of :func:`profile_cut`: fields along it and the taxels whose discs it crosses."""
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(6.8, 3.8))
    s = cut["s"] * 1e3
    ax.plot(s, cut["surface"], color="C0", lw=1.2, label="surface pressure")
    if cut["stress"] is not None:
        ax.plot(s, cut["stress"], color="C1", lw=1.2, label="stress at the taxels' depth")
    ax.plot(s, cut["disc_mean"], color="C2", lw=1.2, ls="--", label="taxel-disc mean (what a taxel here reads)")
    if len(cut["taxel_index"]):
        sc = ax.scatter(cut["taxel_s"] * 1e3, cut["taxel_value"], c=np.abs(cut["taxel_offset"]) * 1e3,
                        cmap="Reds_r", vmin=0, vmax=4.0, s=26, edgecolors="k", linewidths=0.5, zorder=3,
                        label="taxels near the cut")
        fig.colorbar(sc, ax=ax, label="taxel centre off the cut (mm)", shrink=0.85)
    c, d = cut["centre"] * 1e3, cut["direction"]
    where = "flat (unrolled) coordinates" if cut.get("domain") == "flat" else "end-effector frame"
    ax.set_xlabel(f"along ({d[0]:.2f}, {d[1]:.2f}, {d[2]:.2f}) through the contact centre "
                  f"({c[0]:.1f}, {c[1]:.1f}, {c[2]:.1f}) mm, {where} (mm)", fontsize=8)
    ax.set_ylabel("Pa")
    ax.set_title(title, fontsize=9)
    ax.legend(loc="best", fontsize=7)
    return fig


def _edge_step(layout, values):
    """Largest neighbour-to-neighbour difference on the skin mesh, over the readings' range (from 0 or the
    most negative reading up to the largest): a fraction in [0, 1].

    skin_mesh meshes any layout (one taxel, a line, repeated positions), so an error
    from it is a real one and reaches the user instead of a silent NaN metric.
    """
    from ...layout import skin_mesh

    e = skin_mesh(layout).edges
    vmax = float(np.max(values)) if len(values) else 0.0
    if len(e) == 0 or vmax <= 0:
        return 0.0
    # over the range down to the most tensile reading (a frictionless base's taxels can read below 0):
    # the same as over the largest value where no reading is negative, and never above 1
    span = vmax - min(float(np.min(values)), 0.0)
    return float(np.abs(values[e[:, 0]] - values[e[:, 1]]).max() / span)


def halfmax_diameter(fld, values=None) -> float:
    """Equivalent diameter (m) of the grid area where ``values`` (default: the stress at depth,
    else the surface pressure) is at least half its maximum."""
    v = values if values is not None else (fld.stress if fld.stress is not None else fld.pressure)
    vmax = float(v.max()) if v.size else 0.0
    if vmax <= 0:
        return 0.0
    area = float((v >= 0.5 * vmax).sum()) * fld.spacing**2
    return 2.0 * np.sqrt(area / np.pi)


#: The object key that sets how finely an object kind's curved surface is tessellated.
_MESH_KEYS = {"sphere": "subdivisions", "cylinder": "sections", "halfcylinder": "sections", "mug": "sections",
              "fingerpad": "sections"}


def _resolution_notes(area, spacing, mesh, k, kind) -> list[str]:
    """Warn (and return report lines) where the grid does not resolve the contact or resolves the
    object's facets (:func:`vtcore.contact.finish.resolution_warnings`), naming the keys to change."""
    lines = resolution_warnings(area, spacing, mesh, grid_key="layer.grid_spacing",
                                mesh_key=f"objects[{k}].{_MESH_KEYS.get(kind, 'mesh')}")
    for line in lines:
        warnings.warn(line, ResolutionWarning, stacklevel=3)
    return [f"**Warning:** {line}." for line in lines]


def _simulate(scene, ctx, layout, layer, opts, mesh, k):
    """Press the scene's object ``k``: along its keyframes (trajectory mode) or once at the task's
    force or target response (hold mode). Returns (PressResults, timestamps (T,) s, mode)."""
    task, obj = scene["task"], scene["objects"][k]
    rate = task["rate"]
    kw = dict(opts, direction=task["direction"], spread=False)
    if obj["keyframes"]:
        t_end = obj["keyframes"][-1]["t"]
        with np.errstate(over="ignore"):
            n_frames = np.floor(t_end * rate + 1e-9) + 1
        check_frames(scene, n_frames, len(layout), "task.rate",
                     f"{n_frames:.3g} contact frames ({t_end:g} s of keyframes at {rate:g} Hz)")
        times = np.arange(int(n_frames)) / rate
        poses = keyframe_poses(scene, k, times, mesh)
        return press_sequence(layout, mesh, poses, layer, **kw), times, "trajectory"
    pose = object_pose(scene, k, mesh)
    if task["target_response"] is not None:
        gain = ctx.pipeline.get("gain")
        to_counts = gain.counts if gain is not None else (lambda p: np.asarray(p, float))
        spread_kw = dict(kw, spread=ctx.pipeline.has("soft_layer"))
        pr = probe(layout, mesh, pose, layer, target=task["target_response"], sensor=to_counts, **spread_kw)
        res = press(layout, mesh, pose, layer, force=pr.force, **kw)
    else:
        res = press(layout, mesh, pose, layer, force=task["force"], **kw)
    return [res], np.arange(task["readings"]) / rate, "hold"


def _read_skin(ctx, state, results, times, mode) -> dict:
    """The per-frame series after the contact stage's ``state``: the sensor stage, then the transport
    stage, then the sampling clock's pick. Returns ``pressure`` (T, N) Pa, ``surface_pressure`` (T, N)
    Pa, ``force`` (T,) N, ``contact_area`` (T,) m^2, ``indentation`` (T,) m, ``displacement`` (T,) m or
    None, ``per_last`` (N,) Pa (the last simulated frame, which the grid fields belong to),
    ``frames`` (T', N) and ``timestamps`` (T',) s."""
    per = np.asarray(state["pressure"], float)
    surf = np.array([r.surface_pressure for r in results])
    force = np.array([r.force for r in results])
    area = np.array([r.contact_area for r in results])
    indent = np.array([r.indentation for r in results])
    if mode == "hold":
        rep = lambda a: np.repeat(a[:1], len(times), axis=0)  # noqa: E731
        per, surf, force, area, indent = rep(per), rep(surf), rep(force), rep(area), rep(indent)
        disp = rep(state["displacement"]) if "displacement" in state else None
    else:
        disp = state.get("displacement")
    per_last = per[-1].copy()  # the last simulated frame, which the grid fields belong to
    sensed = ctx.pipeline.apply("sensor", {"frames": per.copy(), "timestamps": times}, ctx)
    frames, stamps = np.asarray(sensed["frames"], float), np.asarray(sensed["timestamps"], float)
    # transport stage (e.g. [effects.can]): the counts go over the wire and come back as a host
    # reads them; a transport effect maps frames (T, N) to frames (T, N)
    if ctx.pipeline.stage("transport"):
        sent = np.asarray(ctx.pipeline.apply("transport", frames, ctx), float)
        if sent.shape != frames.shape:
            raise ValueError(f"a transport effect changed the frames' shape {frames.shape} -> {sent.shape}")
        frames = sent
    if "sample_index" in sensed:  # the sampling clock picked some simulation frames
        idx = sensed["sample_index"]
        per, surf, force, area, indent = per[idx], surf[idx], force[idx], area[idx], indent[idx]
        disp = disp[idx] if disp is not None else None
    return {"pressure": per, "surface_pressure": surf, "force": force, "contact_area": area,
            "indentation": indent, "displacement": disp, "per_last": per_last, "frames": frames,
            "timestamps": stamps}


def _metrics(layout, layer, results, ser, mean) -> dict:
    """The press task's metrics from the series ``ser`` (:func:`_read_skin`) and the mean response (N,)."""
    per, force, area, indent, disp = (ser["pressure"], ser["force"], ser["contact_area"], ser["indentation"],
                                      ser["displacement"])
    fld = results[-1].field
    pmax = float(per.max()) if per.size else 0.0
    metrics = {
        "force_n": float(force[-1]) if len(force) else 0.0,
        "indentation_mm": float(indent[-1]) * 1e3 if len(indent) else 0.0,
        "contact_area_mm2": float(area[-1]) * 1e6 if len(area) else 0.0,
        "taxels": len(layout),
        "frames": int(len(ser["frames"])),
        "active_taxels": int((per[-1] > 1e-3 * max(pmax, EPS)).sum()) if len(per) else 0,
        "pressure_max_pa": pmax,
        "surface_pressure_max_pa": float(fld.pressure.max()),
        "response_max": float(mean.max()),
        "response_mean": float(mean.mean()),
        "response_edge_step": _edge_step(layout, per[-1]) if len(per) else 0.0,
        "stress_halfmax_diameter_mm": halfmax_diameter(fld) * 1e3,
        "solver_iterations": int(sum(r.iterations for r in results)),
        "solver_converged": bool(all(r.converged for r in results)),
        "bottomed_out": bool(any(r.bottomed_out for r in results)),
        "compression_max": float(max(r.max_compression for r in results) / layer.thickness),
    }
    if disp is not None:
        metrics["displacement_mm"] = float(disp[-1]) * 1e3
        if metrics["displacement_mm"] > 0:
            metrics["compliance_attribute"] = float(mean.mean() / disp[-1])  # seed 000 Eq. 1
    return metrics


def _arrays(layout, ser, fld, cut) -> dict:
    """The press task's arrays (see the module docstring) from the series, the last grid and the cut."""
    arrays = {
        "positions": layout.positions, "normals": layout.normals, "taxel_ids": layout.taxel_ids,
        "timestamps": ser["timestamps"], "frames": ser["frames"], "pressure": ser["pressure"],
        "surface_pressure": ser["surface_pressure"], "force": ser["force"],
        "contact_area": ser["contact_area"], "indentation": ser["indentation"],
        "grid_x": fld.x, "grid_y": fld.y, "grid_pressure": fld.pressure,
    }
    if fld.stress is not None:
        arrays["grid_stress"] = fld.stress
    arrays.update({"profile_s": cut["s"], "profile_surface_pressure": cut["surface"],
                   "profile_disc_mean": cut["disc_mean"], "profile_taxel_index": cut["taxel_index"],
                   "profile_taxel_s": cut["taxel_s"], "profile_taxel_offset": cut["taxel_offset"],
                   "profile_taxel_pressure": cut["taxel_value"], "profile_centre": cut["centre"],
                   "profile_direction": cut["direction"]})
    if cut["stress"] is not None:
        arrays["profile_stress"] = cut["stress"]
    if ser["displacement"] is not None:
        arrays["displacement"] = np.asarray(ser["displacement"], float)
    return arrays


def run(scene, ctx) -> TaskResult:
    if not scene["objects"]:
        raise scene.error("objects", "task 'press' needs at least one [[objects]] table")
    task = scene["task"]
    k = task["object"]
    if k >= len(scene["objects"]):
        raise scene.error("task.object", f"there are only {len(scene['objects'])} [[objects]] tables")
    layout = build_layout(scene)
    layer = build_layer(scene)
    opts = layer_options(scene)
    obj = scene["objects"][k]
    mesh = object_mesh(scene, k)
    comp_eff = ctx.pipeline.get("object_compliance")
    compliance = object_compliance(scene, k, mesh) if comp_eff is not None else None
    results, times, mode = _simulate(scene, ctx, layout, layer, opts, mesh, k)

    state = {"layout": layout, "layer": layer, "results": results, "mesh": mesh, "compliance": compliance,
             "pressure": np.array([r.surface_pressure for r in results]),
             "samples_per_taxel": opts["samples_per_taxel"]}
    state = ctx.pipeline.apply("contact", state, ctx)
    ser = _read_skin(ctx, state, results, times, mode)
    frames = ser["frames"]
    fld = results[-1].field
    mean = frames.mean(axis=0) if len(frames) else np.zeros(len(layout))
    unit = "counts" if ctx.pipeline.stage("sensor") else "Pa"
    metrics = _metrics(layout, layer, results, ser, mean)
    cut = profile_cut(fld, layout, ser["per_last"], angle_deg=task["profile_angle"],
                      samples=state.get("taxel_samples", opts["samples_per_taxel"]))
    title = f"{scene.name}: {obj['name']} through {layer.thickness * 1e3:g} mm ({opts['model']})"
    flat = layout.flat if layout.flat is not None else layout.positions[:, :2]
    figures = {}
    if scene["output"]["plots"]:  # the runner closes only the figures it saves
        figures = {
            "response": taxel_map(flat, mean, title=f"{scene.name}: mean response, {obj['name']}", label=unit),
            "skin_3d": skin_3d(layout.positions, mean, mesh=build_end_effector(scene),
                               title=f"{scene.name}: the skin on its end-effector", label=unit),
            "pressure_field": _field_figure(fld, layout, title, cut),
            "profile": _profile_figure(cut, title),
        }
    notes = [f"Contact model `{opts['model']}`, layer {layer.thickness * 1e3:g} mm of {layer.material} "
             f"(E = {layer.young_modulus / 1e3:.1f} kPa, nu = {layer.poisson}; {layer.source}). "
             f"Mode: {mode}, {len(frames)} frames."]
    notes += _resolution_notes(ser["contact_area"], opts["grid"].spacing, mesh, k, obj["kind"])
    big = compression_note(max(r.max_compression for r in results), layer.thickness, f"pressing {obj['name']}",
                           opts["model"])
    if big:
        notes.append(f"**Warning:** {big}.")
        warnings.warn(big, LargeDeformationWarning, stacklevel=2)
    return TaskResult(metrics=metrics, arrays=_arrays(layout, ser, fld, cut), figures=figures, sections=notes)


register_task(TaskSpec("press", run, PARAMS, sections=("layout", "objects"),
                       effects=CONTACT_EFFECTS + SENSOR_EFFECTS + ("can",),
                       doc="press an object at a target force (or mean response), or along keyframes"))
