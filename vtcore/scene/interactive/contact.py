"""Contact for a front end: press an indenter on the skin for one frame or a trajectory."""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from ...contact.objects import SIZE_RANGE_M
from ...errors import InputError
from ...layout import Layout
from .common import as_trimesh


@dataclass
class Contact:
    """One simulated contact as the add-on shows it.

    pressure : (N,) Pa at the taxels. response : (N,) counts (gain, then 16-bit clip).
    edge_response : (N,) Eq. 6 of seed 002 on the response. edge : (N,) bool.
    force : N. indentation : m. contact_area : m^2. compression : the largest compression of the
    layer as a share of its thickness. warning : a sentence when it exceeds 30 % (outside linear
    elasticity), else "".
    """

    pressure: np.ndarray
    response: np.ndarray
    edge_response: np.ndarray
    edge: np.ndarray
    force: float
    indentation: float
    contact_area: float
    compression: float = 0.0
    warning: str = ""


def soft_layer(thickness: float, material: str = "ecoflex_00_20"):
    """A :class:`vtcore.contact.SoftLayer`; a zero thickness is refused here (the
    designer forgot to set the layer), although vtcore models a bare skin."""
    from ...contact import SoftLayer

    if not np.isfinite(thickness) or thickness <= 0:
        raise InputError(f"must be > 0 m, got {thickness}", key="thickness")
    return SoftLayer(thickness=float(thickness), material=material)


#: the sensor every front end simulates by default: the shipped CySkin profile, as the command line does
SENSOR_PROFILE = "cyskin"


def sensor_response(pressure, counts_per_pa: float | None = None, profile: str = SENSOR_PROFILE):
    """Counts (same shape) of taxel pressures (Pa): the sensor profile's fitted transfer (its gain and
    saturation), or the linear gain ``counts_per_pa`` where one is given (an explicit override), then
    the 16-bit clip."""
    from ...contact import sensor

    return sensor.saturate(sensor_model(counts_per_pa, profile).counts(pressure))


@lru_cache(maxsize=16)
def sensor_model(counts_per_pa: float | None = None, profile: str = SENSOR_PROFILE):
    """The :class:`vtcore.evaluate.SensorNoise` of ``profile`` (gain overridden by ``counts_per_pa``),
    read once: live touch asks for it every frame."""
    from ...evaluate import sensor_noise

    return sensor_noise(counts_per_pa=counts_per_pa, profile=profile)


def sensor_summary(counts_per_pa: float | None = None, profile: str = SENSOR_PROFILE) -> str:
    """One line naming the sensor a front end simulates: the profile and its gain (counts/Pa), or the
    override; and the detection threshold (Pa) it gives."""
    n = sensor_model(counts_per_pa, profile)
    src = "override" if counts_per_pa is not None else f"profile {profile!r}"
    return f"gain {n.counts_per_pa:.3g} counts/Pa ({src}); detects above {n.threshold_pa:.3g} Pa"


class SkinEdges:
    """Eq. 6 (edge response) and Eq. 7 (edge flags) of seed 002 on one skin mesh, built once.

    layout : the skin; triangles : (F, 3) its skin mesh. ``edges(response (N,) or (T, N), edge_fraction)``
    returns ``(edge_response, edge)``: a frame's edges are the taxels above ``edge_fraction`` of its
    strongest edge response (a frame without contact has none).
    """

    def __init__(self, layout: Layout, triangles):
        from ...filters import EdgeFilter
        from ...layout import mesh_from_triangles

        tri = np.asarray(triangles, np.int64).reshape(-1, 3)
        self.filter = EdgeFilter(mesh_from_triangles(layout.positions, layout.normals, tri)) if len(tri) else None

    def edges(self, response, edge_fraction: float):
        from ...filters import relative_threshold, threshold

        if self.filter is None:
            return np.zeros_like(response, dtype=np.float64), np.zeros(np.shape(response), bool)
        er = self.filter(response)
        # A frame without contact has no edge: the floor keeps rounding residue out.
        eps = relative_threshold(er, edge_fraction, floor=1e-9)
        return er, threshold(er, eps)


def _edges(layout, triangles, response, edge_fraction):
    return SkinEdges(layout, triangles).edges(response, edge_fraction)


def simulate(layout: Layout, triangles, indenter_vertices, indenter_triangles, pose, *, thickness: float,
             material: str = "ecoflex_00_20", force: float | None = 5.0, counts_per_pa: float | None = None,
             edge_fraction: float = 0.3, geometry: str = "plane", model: str = "finite_layer") -> Contact:
    """Press an indenter onto the skin at a target force and read taxels and edges.

    layout : the skin (skin frame, metres); triangles : (F, 3) its skin mesh.
    indenter_vertices (V, 3) metres and indenter_triangles (G, 3): the indenter
    in its own frame; pose : (4, 4) its pose in the skin frame before pressing
    (it moves towards the skin until ``force`` newtons; ``force=None`` uses the
    pose as it is). thickness : m; material : a vtcore.contact.MATERIALS key.
    counts_per_pa : sensor gain override, counts/Pa (None: the CySkin profile's fitted transfer, as the
    command line's). edge_fraction : edge threshold as a fraction of
    the frame's largest edge response (Eq. 7 with a relative epsilon). geometry : "plane"
    or "unrolled" (solved on the layout's flat coordinates: curved patches; see
    :func:`vtcore.contact.press`). model : the layer's contact model (vtcore.contact.MODELS).
    """
    from ...contact import press

    if len(layout) == 0:
        raise InputError("the skin has no taxels", key="layout")
    layer = soft_layer(thickness, material)
    mesh = as_trimesh(indenter_vertices, indenter_triangles, SIZE_RANGE_M)
    res = press(layout, mesh, np.asarray(pose, float), layer, force=force if force else None, geometry=geometry,
                model=model)
    response = sensor_response(res.pressure, counts_per_pa)
    er, edge = _edges(layout, triangles, response, edge_fraction)
    from ...contact.materials import compression_note

    return Contact(res.pressure, response, er, edge, float(res.force), float(res.indentation),
                   float(res.contact_area), float(res.max_compression / layer.thickness),
                   compression_note(res.max_compression, layer.thickness) or "")


def bake(layout: Layout, triangles, indenter_vertices, indenter_triangles, poses, *, thickness: float,
         material: str = "ecoflex_00_20", forces=None, counts_per_pa: float | None = None,
         edge_fraction: float = 0.3, callback=None, geometry: str = "plane") -> dict:
    """Simulate a trajectory: one press per pose, warm-started from the previous frame.

    poses : (T, 4, 4) indenter poses in the skin frame. forces : None (each pose
    as it is: the animation decides the indentation) or (T,) newtons (target
    force per frame, 0 for no contact). callback(i, T) is called after each frame.
    geometry : as for :func:`simulate`.
    Returns ``pressure``, ``response``, ``edge_response`` (T, N) float, ``edge``
    (T, N) bool, ``force`` (T,) newtons, ``compression`` (T,) (largest compression / thickness) and
    ``warning`` (a sentence when a frame compresses the layer by more than 30 %, else "").
    """
    from ...contact import press
    from ...errors import UnreachableTargetError

    poses = np.asarray(poses, dtype=np.float64).reshape(-1, 4, 4)
    t, n = len(poses), len(layout)
    if n == 0:
        raise InputError("the skin has no taxels", key="layout")
    layer = soft_layer(thickness, material)
    mesh = as_trimesh(indenter_vertices, indenter_triangles, SIZE_RANGE_M)
    f = None if forces is None else np.broadcast_to(np.asarray(forces, float), (t,))
    pressure = np.zeros((t, n))
    force = np.zeros(t)
    compression = np.zeros(t)
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
            compression[i] = res.max_compression / layer.thickness
        if callback is not None:
            callback(i, t)
    response = sensor_response(pressure, counts_per_pa)
    er, edge = _edges(layout, triangles, response, edge_fraction)
    from ...contact.materials import compression_note

    worst = int(np.argmax(compression)) if t else 0
    note = compression_note(compression[worst] * layer.thickness, layer.thickness, f"frame {worst}") if t else None
    return {"pressure": pressure, "response": response, "edge_response": er, "edge": edge, "force": force,
            "compression": compression, "warning": note or ""}


def edges(layout: Layout, triangles, response, edge_fraction: float = 0.3):
    """Eq. 6 edge response and Eq. 7 edge flags of a (N,) or (T, N) response."""
    return _edges(layout, triangles, np.asarray(response, dtype=np.float64), edge_fraction)


# ---------------------------------------------------------------------------


def indenter_mesh(kind: str = "fingerpad", **dims):
    """An indenter to press with, as arrays for the add-on: ``(vertices (V, 3) m, triangles (F, 3))``.

    kind : a :data:`vtcore.contact.objects.DEFAULTS` kind ("fingerpad": radius, length tip to tip,
    bend_radius; "sphere", "cube", ...). Built as it rests on a table, pressed face up (+z); the
    add-on turns it over towards the skin.
    """
    from ...contact.objects import make_object

    m = make_object(kind, **dims)
    return np.asarray(m.vertices, np.float64), np.asarray(m.faces, np.int64)
