"""Glue for interactive front ends (the Blender add-on): one call per user action.

Each function takes plain numpy arrays (SI units, one frame), composes the
``vtcore`` packages and returns plain arrays, so the add-on only gathers input,
calls ONE function here and writes the result. Nothing here imports ``bpy``;
everything is testable without Blender. No algorithm lives here: these are
thin compositions of ``vtcore.layout``, ``vtcore.contact``, ``vtcore.filters``
and ``vtcore.augment``.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .._progress import Job, keep_going  # noqa: F401  (Job: the add-on runs a long fill in one)
from ..contact.objects import SIZE_RANGE_M
from ..errors import InputError
from ..layout import Layout, skin_mesh
from ..layout.meshinput import SURFACE_SIZE_M, checked_mesh


@dataclass
class SceneOutput:
    """What the add-on shows of a scene run.

    layout : the scene's skin layout (positions in the end-effector frame, metres).
    triangles : (F, 3) int, the skin mesh over the taxels.
    pressure : (N,) pascals at the taxels, mean over the readings.
    response : (N,) sensor counts (mean over readings) after the listed sensor
        effects, or the pressure when the scene lists none.
    result : the run's ``result.json`` object.
    out : the output folder.
    """

    layout: Layout
    triangles: np.ndarray
    pressure: np.ndarray
    response: np.ndarray
    result: dict = field(default_factory=dict)
    out: Path | None = None
    replay: object = None  # a vtcore.can.timeline.Replay for a ``replay`` scene
    output: dict = field(default_factory=dict)  # the scene's [output] (render settings)


def run_scene_file(path, out, overrides=None, fps: float | None = None) -> SceneOutput:
    """Run the scene file ``path`` into folder ``out`` and return what to display.

    For a ``replay`` scene, ``replay`` holds the recording prepared for playback on the
    timeline at ``fps`` (None: the scene's ``[output] fps``). Raises the scene's
    ``SceneError`` (naming file and key) on a bad scene and ``InputError`` when the run
    produced no per-taxel arrays.
    """
    from .loader import load_scene
    from .runner import run_scene
    from .sections.layout import build_layout

    path = Path(path)
    if not path.is_file():
        raise InputError("is not a readable scene file", file=path)
    scene = load_scene(path, overrides)
    out = Path(out)
    result = run_scene(scene, out)
    npz = out / "arrays.npz"
    if not npz.is_file():
        raise InputError("the run wrote no arrays.npz (is [output] arrays = false?)", file=path)
    with np.load(npz) as z:
        arrays = {k: z[k] for k in z.files}
    if "positions" not in arrays:
        raise InputError(f"task {scene.task!r} writes no taxel positions to show", file=path)
    layout = build_layout(scene)
    if len(layout) != len(arrays["positions"]):
        # The task laid its own taxels: show those, without module information.
        n = len(arrays["positions"])
        layout = Layout(arrays["positions"], arrays.get("normals", np.tile([0.0, 0.0, 1.0], (n, 1))),
                        arrays.get("taxel_ids", np.arange(n)), np.zeros(n, np.int64))
    n = len(layout)
    pressure = _mean_frames(arrays.get("pressure"), n)
    response = _mean_frames(arrays.get("frames"), n)
    if response is None:
        response = pressure
    if pressure is None:
        pressure = response if response is not None else np.zeros(n)
        response = pressure
    tri = skin_triangles(layout)
    replay = None
    if scene.task == "replay":
        from ..can.timeline import load_recording

        p = scene["task"]
        replay = load_recording(p["log"], layout, tri, kind=p["codec"], boards=p["boards"] or None,
                                fps=fps or scene["output"]["fps"], baseline_rows=p["baseline_rows"],
                                edge_fraction=p["edge_fraction"], min_response=p["min_response"],
                                period=p["period"] or None, window=p["window"])
    return SceneOutput(layout, tri, pressure, response, result, out, replay, dict(scene["output"]))


def _mean_frames(a, n):
    if a is None:
        return None
    a = np.asarray(a, dtype=np.float64)
    if a.ndim == 2 and a.shape[1] == n:
        return a.mean(axis=0)
    if a.ndim == 1 and a.shape[0] == n:
        return a
    return None


# ---------------------------------------------------------------------------
# Skin layout


def _trimesh(vertices, triangles, size_range=SURFACE_SIZE_M):
    """The add-on's mesh (vertices (V, 3) metres, triangles (F, 3)) under the checks every mesh entering
    vtcore takes (:func:`vtcore.layout.meshinput.checked_mesh`); indenters pass the objects' size range."""
    if len(np.asarray(triangles).reshape(-1)) == 0:
        raise InputError("has no faces: a skin can only be laid on (and pressed by) a surface", key="mesh")
    return checked_mesh(vertices, triangles, size_range=size_range, key="mesh", scale_key="the object's scale",
                        process=False)


def merge(base: Layout | None, extra: Layout) -> Layout:
    """Taxels of ``base`` followed by those of ``extra``, whose modules are numbered after
    base's (from 0 without a base): :meth:`Layout.concat`.

    Without a base, ``extra`` keeps its flat coordinates. With one, the result has none:
    ``extra`` was unrolled about its own anchor and ``base`` about another, so their flat
    coordinates are in different charts and together would overlap.
    """
    if base is None or len(base) == 0:
        return extra.renumber(0)
    out = Layout.concat([base, extra])
    out.flat = None
    return out


def selection_anchor(face_centres, face_areas, selected) -> np.ndarray:
    """Where a patch or a fill over selected faces is anchored: (3,) metres.

    face_centres : (F, 3) metres, any frame (the result is in the same one);
    face_areas : (F,) m^2; selected : (F,) bool mask or indices of the selected faces.
    The anchor is the selected face centre nearest the area-weighted mean of the selected
    centres: the mean itself lies inside the body when the selection is curved (the top and
    a flank) and snaps to a face outside the selection, where a fill finds no room.
    """
    c = np.asarray(face_centres, dtype=np.float64).reshape(-1, 3)
    w = np.asarray(face_areas, dtype=np.float64).reshape(-1)
    if len(w) != len(c):
        raise InputError(f"{len(w)} face areas for {len(c)} face centres", key="face_areas")
    sel = np.asarray(selected)
    if sel.dtype == bool:
        if len(sel) != len(c):
            raise InputError(f"a mask of {len(sel)} faces for {len(c)} faces", key="selected")
        sel = np.flatnonzero(sel)
    sel = sel.astype(np.int64).reshape(-1)
    if len(sel) and (sel.min() < 0 or sel.max() >= len(c)):
        raise InputError(f"face indices must be in 0..{len(c) - 1}", key="selected")
    if len(sel) == 0:
        raise InputError("select at least one face", key="selected")
    c, w = c[sel], w[sel] + 1e-30  # zero-area faces still count when all are zero
    mean = (c * w[:, None]).sum(0) / w.sum()
    return c[np.argmin(((c - mean) ** 2).sum(1))]


@dataclass
class LayoutEdit:
    """A layout after an edit, with what to show.

    layout : all taxels (skin frame, metres). triangles : (F, 3) skin mesh.
    report : dict of the placement report (strain_max, strain_mean, overlaps,
    coverage, notes) of the edit, or {}.
    """

    layout: Layout
    triangles: np.ndarray
    report: dict


def skin_triangles(layout: Layout) -> np.ndarray:
    """(F, 3) int64 skin mesh triangles of ``layout`` to show; none for fewer than three taxels
    or a layout the skin mesh refuses (its InputError), so the add-on shows the taxels alone."""
    if len(layout) < 3:
        return np.zeros((0, 3), np.int64)
    try:
        return np.asarray(skin_mesh(layout).triangles, np.int64)
    except ValueError:
        return np.zeros((0, 3), np.int64)


def _edit(layout: Layout, report: dict) -> LayoutEdit:
    return LayoutEdit(layout, skin_triangles(layout), report)


def lay_patch(vertices, triangles, at, *, existing: Layout | None = None, patch: str = "hexagon",
              module: str = "cyskin10", direction=None, offset: float = 0.0, method: str = "logmap",
              fill_region=None, max_faces: int | None = 20_000, progress=None) -> LayoutEdit:
    """Conform a patch (or fill a face region with modules) onto a mesh, added to ``existing``.

    vertices : (V, 3) metres and triangles : (F, 3) of the end-effector surface, in
    the skin frame. at : (3,) metres, the point the patch is centred on (snapped to
    the surface). patch : "hexagon", "triangle" or "strip:N"; module : module type.
    direction : (3,) in-plane x axis or None. offset : metres along the normal.
    fill_region : (F,) bool face mask: tile that region with whole modules instead.
    max_faces : the log map is solved on a copy simplified to about this many faces
        (vtcore.layout.place's speed/accuracy knob; None: the full mesh). A fill sizes its copy
        by the module pitch instead (``fill(max_faces="auto")``) unless this is None.
    progress : None or ``progress(fraction) -> bool`` (0..1); returning False stops a fill,
        which raises :class:`vtcore.errors.Cancelled` (nothing is returned or changed).
        It is told 0 when the fill starts, the fill's own fractions as its growth proceeds
        (after each chart, so a stop takes effect at the next one) and 1 when it ends.
    Returns the merged layout, its skin mesh and the placement report.
    """
    from ..layout import fill, place

    mesh = _trimesh(vertices, triangles)
    at = np.asarray(at, dtype=np.float64).reshape(3)
    if fill_region is not None:
        region = np.asarray(fill_region, dtype=bool).reshape(-1)
        if len(region) != len(mesh.faces) or not region.any():
            raise InputError("select at least one face of the end-effector to fill", key="region")
        keep_going(progress, 0.0, "the fill")
        new, rep = fill(mesh, at, direction, module=module, region=region, offset=offset,
                        max_faces=None if max_faces is None else "auto", existing=existing, progress=progress)
        keep_going(progress, 1.0, "the fill")
    else:
        new, rep = place(mesh, patch, at, direction, module=module, offset=offset, method=method,
                         max_faces=max_faces, existing=existing)
    if len(new) == 0:
        raise InputError("no module fits there", key="at")
    report = rep.as_dict()
    if existing is not None and len(existing) and report["existing_overlap_pairs"]:
        # name the new modules by their ids in the merged skin (merge renumbers them)
        ids = np.unique(new.module_ids)
        first = int(existing.module_ids.max()) + 1
        report["existing_overlap_pairs"] = [[a, first + int(np.searchsorted(ids, b))]
                                            for a, b in report["existing_overlap_pairs"]]
    return _edit(merge(existing, new), report)


def remove_modules(layout: Layout, modules) -> LayoutEdit:
    """``layout`` without the taxels of ``modules`` (module ids)."""
    modules = np.unique(np.asarray(modules, dtype=np.int64).reshape(-1))
    if len(modules) == 0:
        raise InputError("select a taxel of the module to remove", key="modules")
    keep = ~np.isin(layout.module_ids, modules)
    if keep.all():
        raise InputError(f"no module {modules.tolist()} in this skin", key="modules")
    return _edit(layout.subset(keep), {})


def move_module(layout: Layout, module: int, vertices, triangles, at, direction=None,
                offset: float = 0.0) -> LayoutEdit:
    """Move one module of ``layout`` to ``at`` on the mesh (re-conformed there).

    Keeps the module's id and its taxel ids; the other modules are untouched.
    """
    from ..layout import place

    mask = layout.module_ids == int(module)
    if not mask.any():
        raise InputError(f"no module {module} in this skin", key="module")
    mesh = _trimesh(vertices, triangles)
    mod_type = str(layout.meta.get("module", "cyskin10"))
    new, rep = place(mesh, "triangle", np.asarray(at, float).reshape(3), direction,
                     module=mod_type if mod_type in _module_names() else "cyskin10", offset=offset)
    old = layout.subset(mask)
    if len(new) != len(old):
        raise InputError(f"module {module} has {len(old)} taxels, a placed module {len(new)}", key="module")
    new.module_ids[:] = int(module)
    new.taxel_ids = old.taxel_ids.copy()
    new.can_ids = old.can_ids  # the same board, wired to the same bus
    # Flat coordinates are dropped: the module was unrolled about its new place, the rest
    # about the old anchor.
    moved = Layout.concat([layout.subset(~mask), new], renumber=False)
    moved.flat = None
    return _edit(moved, rep.as_dict())


def _module_names():
    from ..layout import MODULES

    return MODULES


# ---------------------------------------------------------------------------
# Contact


@dataclass
class Contact:
    """One simulated contact as the add-on shows it.

    pressure : (N,) Pa at the taxels. response : (N,) counts (gain, then 16-bit clip).
    edge_response : (N,) Eq. 6 of seed 002 on the response. edge : (N,) bool.
    force : N. indentation : m. contact_area : m^2.
    """

    pressure: np.ndarray
    response: np.ndarray
    edge_response: np.ndarray
    edge: np.ndarray
    force: float
    indentation: float
    contact_area: float


def soft_layer(thickness: float, material: str = "ecoflex_00_20"):
    """A :class:`vtcore.contact.SoftLayer`; a zero thickness is refused here (the
    designer forgot to set the layer), although vtcore models a bare skin."""
    from ..contact import SoftLayer

    if not np.isfinite(thickness) or thickness <= 0:
        raise InputError(f"must be > 0 m, got {thickness}", key="thickness")
    return SoftLayer(thickness=float(thickness), material=material)


def _response(pressure, counts_per_pa):
    from ..contact import sensor

    return sensor.saturate(sensor.gain(pressure, counts_per_pa))


def _edges(layout, triangles, response, edge_fraction):
    from ..filters import edge_filter, relative_threshold, threshold
    from ..layout import mesh_from_triangles

    tri = np.asarray(triangles, np.int64).reshape(-1, 3)
    if len(tri) == 0:
        z = np.zeros_like(response, dtype=np.float64)
        return z, np.zeros(response.shape, bool)
    mesh = mesh_from_triangles(layout.positions, layout.normals, tri)
    er = edge_filter(mesh, response)
    # A frame without contact has no edge: the floor keeps rounding residue out.
    eps = relative_threshold(er, edge_fraction, floor=1e-9)
    return er, threshold(er, eps)


def simulate(layout: Layout, triangles, indenter_vertices, indenter_triangles, pose, *, thickness: float,
             material: str = "ecoflex_00_20", force: float | None = 5.0, counts_per_pa: float = 0.1,
             edge_fraction: float = 0.3, geometry: str = "plane") -> Contact:
    """Press an indenter onto the skin at a target force and read taxels and edges.

    layout : the skin (skin frame, metres); triangles : (F, 3) its skin mesh.
    indenter_vertices (V, 3) metres and indenter_triangles (G, 3): the indenter
    in its own frame; pose : (4, 4) its pose in the skin frame before pressing
    (it moves towards the skin until ``force`` newtons; ``force=None`` uses the
    pose as it is). thickness : m; material : a vtcore.contact.MATERIALS key.
    counts_per_pa : sensor gain. edge_fraction : edge threshold as a fraction of
    the frame's largest edge response (Eq. 7 with a relative epsilon). geometry : "plane"
    or "unrolled" (solved on the layout's flat coordinates: curved patches; see
    :func:`vtcore.contact.press`).
    """
    from ..contact import press

    if len(layout) == 0:
        raise InputError("the skin has no taxels", key="layout")
    layer = soft_layer(thickness, material)
    mesh = _trimesh(indenter_vertices, indenter_triangles, SIZE_RANGE_M)
    res = press(layout, mesh, np.asarray(pose, float), layer, force=force if force else None, geometry=geometry)
    response = _response(res.pressure, counts_per_pa)
    er, edge = _edges(layout, triangles, response, edge_fraction)
    return Contact(res.pressure, response, er, edge, float(res.force), float(res.indentation),
                   float(res.contact_area))


def bake(layout: Layout, triangles, indenter_vertices, indenter_triangles, poses, *, thickness: float,
         material: str = "ecoflex_00_20", forces=None, counts_per_pa: float = 0.1,
         edge_fraction: float = 0.3, callback=None, geometry: str = "plane") -> dict:
    """Simulate a trajectory: one press per pose, warm-started from the previous frame.

    poses : (T, 4, 4) indenter poses in the skin frame. forces : None (each pose
    as it is: the animation decides the indentation) or (T,) newtons (target
    force per frame, 0 for no contact). callback(i, T) is called after each frame.
    geometry : as for :func:`simulate`.
    Returns ``pressure``, ``response``, ``edge_response`` (T, N) float, ``edge``
    (T, N) bool and ``force`` (T,) newtons.
    """
    from ..contact import press
    from ..errors import UnreachableTargetError

    poses = np.asarray(poses, dtype=np.float64).reshape(-1, 4, 4)
    t, n = len(poses), len(layout)
    if n == 0:
        raise InputError("the skin has no taxels", key="layout")
    layer = soft_layer(thickness, material)
    mesh = _trimesh(indenter_vertices, indenter_triangles, SIZE_RANGE_M)
    f = None if forces is None else np.broadcast_to(np.asarray(forces, float), (t,))
    pressure = np.zeros((t, n))
    force = np.zeros(t)
    prev = None
    for i in range(t):  # frames depend on each other through the warm start
        target = None if f is None else float(f[i])
        if target is not None and target <= 0:
            prev = None  # no contact asked for this frame
        else:
            try:
                res = press(layout, mesh, poses[i], layer, force=target, warm_start=prev, geometry=geometry)
            except UnreachableTargetError as exc:
                raise InputError(f"frame {i}: {exc}", key="force") from exc
            pressure[i], force[i], prev = res.pressure, res.force, res
        if callback is not None:
            callback(i, t)
    response = _response(pressure, counts_per_pa)
    er, edge = _edges(layout, triangles, response, edge_fraction)
    return {"pressure": pressure, "response": response, "edge_response": er, "edge": edge, "force": force}


def edges(layout: Layout, triangles, response, edge_fraction: float = 0.3):
    """Eq. 6 edge response and Eq. 7 edge flags of a (N,) or (T, N) response."""
    return _edges(layout, triangles, np.asarray(response, dtype=np.float64), edge_fraction)


# ---------------------------------------------------------------------------
# Augmented point clouds


def augment(cloud_points, probe_points, probe_values, *, method: str = "smooth", beta: float = -300.0,
            c_min: float | None = None, c_max: float | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Propagate tactile values from probes to a visual point cloud (seed 000).

    cloud_points : (M, 3) metres. probe_points : (n, 3) metres; probe_values : (n,).
    method : "cluster" (Eq. 2) or "smooth" (Eqs. 3-4, ``beta`` per metre, <= 0).
    Returns ``values (M,)`` and ``colours (M, 3)`` float in [0, 1] (viridis_r
    between c_min and c_max, default the probes' range).
    """
    from ..augment import ClusterPropagation, SmoothPropagation, colour_map

    pts = np.asarray(cloud_points, dtype=np.float64).reshape(-1, 3)
    probes = np.asarray(probe_points, dtype=np.float64).reshape(-1, 3)
    vals = np.asarray(probe_values, dtype=np.float64).reshape(-1)
    if len(pts) == 0:
        raise InputError("the point cloud has no points", key="cloud")
    if len(probes) == 0 or len(vals) != len(probes):
        raise InputError("need at least one probe with a value", key="probes")
    if method == "cluster":
        model = ClusterPropagation()
    elif method == "smooth":
        model = SmoothPropagation(beta=beta)
    else:
        raise InputError(f"unknown method {method!r}; use 'cluster' or 'smooth'", key="method")
    values = model.fit(probes, vals).predict(pts)
    lo = float(np.nanmin(vals)) if c_min is None else c_min
    hi = float(np.nanmax(vals)) if c_max is None else c_max
    if hi <= lo:
        hi = lo + 1.0  # one probe value: every point gets the same (lowest) colour
    rgb = colour_map(values, lo, hi).astype(np.float64) / 255.0
    return values, rgb


def probes_from_file(path) -> tuple[np.ndarray, np.ndarray]:
    """Probe points (n, 3) metres and compliance values (n,) from a recorded probe file."""
    from ..augment import load_probes

    path = Path(path)
    if not path.is_file():
        raise InputError("is not a readable probe file", file=path)
    tpc = load_probes(path)
    vals = np.asarray(tpc.values, float)
    return np.asarray(tpc.points, float), vals[:, 0] if vals.ndim == 2 else vals


# ---------------------------------------------------------------------------
# Export


def export_layout(layout: Layout, triangles, path, format: str | None = None, transform=None) -> Path:
    """Write ``layout`` (with its skin mesh faces) to ``path`` in a layout format.

    transform : optional (4, 4) rigid transform from the skin frame to the
    frame the file should use (another object's frame).
    """
    from ..layout import save

    tri = np.asarray(triangles, np.int64).reshape(-1, 3)
    out = layout.subset(slice(None))
    if len(tri):
        out.meta["faces"] = tri
    if len(out) == 0:
        raise InputError("the skin has no taxels", key="layout")
    path = Path(path)
    save(out, path, format, transform=transform)
    return path
