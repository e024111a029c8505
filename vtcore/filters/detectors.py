"""Three ways to find the edges of a contact on a skin, behind one interface.

Each detector is built once per skin and maps a frame of taxel pressures
``(N,)`` to :class:`~vtcore.filters.extract.EdgeFeatures` in the end-effector
frame, which the contour controller turns into a motion (Eq. 9):

- :class:`MeshEdgeDetector`: seed 002's method, Eq. 6 on the skin mesh, Eq. 7,
  connected components of edge taxels, Eq. 8, moments.
- :class:`ImageEdgeDetector`: the tactile-image baseline (flatten, 1 mm grid,
  Canny, back-projection), then the same Eq. 8 and moments.
- :class:`SubtaxelEdgeDetector`: beyond the paper, Eq. 6 on a Loop-subdivided
  skin mesh with the pressures interpolated on it, response-weighted moments,
  so the edge can lie between taxels.
"""

from __future__ import annotations

import numpy as np

from ..errors import InputError
from ..tolerances import TINY
from .extract import EdgeFeatures, features, mesh_components
from .image import TactileImage, canny_edges
from .local import EdgeFilter, relative_threshold
from .subdivide import loop_subdivision

#: Rounding floor of the relative threshold, as a fraction of ``max(p)^2 * max(1/D)``:
#: the two-product form of Eq. 6 leaves ~1e-16 of that on a uniform frame.
_FLOOR = 1e-9


def _check_frame(values, n):
    v = np.asarray(values, dtype=np.float64)
    if v.shape != (n,):
        raise InputError(f"expected one frame of shape ({n},), got {v.shape}", key="pressure")
    if not np.all(np.isfinite(v)):
        raise InputError("contains NaN or inf", key="pressure")
    return v


def _scaled_response(filt, v, peak, fraction, gmax, epsilon=None):
    """Eq. 6 response (N,) of ``v`` (N,) and its Eq. 7 threshold, computed on ``v`` scaled by a power
    of two near ``1 / peak`` and scaled back: exact (a power of two changes no mantissa) where the
    frame is representable squared, and where it is not (a uniform frame of 1e160: peak^2
    overflows) the mask is still right and the response is infinite, not an OverflowError."""
    k = int(np.frexp(peak)[1]) if peak > 0 and np.isfinite(peak) else 0
    r = filt(np.ldexp(v, -k))
    eps = (float(relative_threshold(r, fraction, _FLOOR * gmax)) if epsilon is None
           else float(np.ldexp(float(epsilon), -2 * k)))
    mask = r > eps
    with np.errstate(over="ignore"):
        return np.ldexp(r, 2 * k), mask, float(np.ldexp(eps, 2 * k))


class MeshEdgeDetector:
    """Seed 002's edge extraction on the skin mesh.

    mesh : SkinMesh. fraction : Eq. 7 threshold as a fraction of the frame's
    strongest Eq. 6 response (used when ``epsilon`` is None). epsilon : absolute
    Eq. 7 threshold (pressure^2 / m). normal : the z axis of Eq. 8.
    min_pressure : frames whose peak is below this (same unit as the input) have no edges.
    """

    name = "mesh"

    def __init__(self, mesh, fraction: float = 0.15, epsilon: float | None = None,
                 normal=(0.0, 0.0, 1.0), min_pressure: float = 0.0):
        self.mesh = mesh
        self.filter = EdgeFilter(mesh)
        self.n = self.filter.n
        self.fraction, self.epsilon = float(fraction), epsilon
        self.normal = np.asarray(normal, dtype=np.float64)
        self.min_pressure = float(min_pressure)
        self._gmax = float(self.filter.g.max()) if self.filter.g.size else 0.0

    def edges(self, values):
        """Eq. 6 response (N,) and Eq. 7 mask (N,) of one frame."""
        v = _check_frame(values, self.filter.n)
        peak = float(np.max(np.abs(v))) if v.size else 0.0
        if peak <= self.min_pressure or peak == 0.0:
            return self.filter(v), np.zeros(v.shape, dtype=bool)
        r, mask, _ = _scaled_response(self.filter, v, peak, self.fraction, self._gmax, self.epsilon)
        return r, mask

    def detect(self, values) -> EdgeFeatures:
        r, mask = self.edges(values)
        lab = mesh_components(self.mesh.adjacency, mask)
        idx = np.flatnonzero(mask)
        return features(self.mesh.positions[idx], lab[idx], None, self.normal,
                        extra={"mask": mask, "response": r})


class ImageEdgeDetector:
    """Tactile-image baseline: flatten, resample (``resolution`` m), Canny, back-project.

    positions, triangles : the skin mesh. flat : (N, 2) layout coordinates or None.
    sigma : Canny smoothing, pixels. low, high : hysteresis thresholds as
    fractions of the strongest gradient. Components: 8-connected edge pixels.
    """

    name = "image"

    def __init__(self, positions, triangles, flat=None, resolution: float = 1e-3, sigma: float = 1.5,
                 low: float = 0.1, high: float = 0.2, normal=(0.0, 0.0, 1.0),
                 min_pressure: float = 0.0):
        self.tactile = TactileImage(positions, triangles, flat, resolution)
        self.n = len(np.asarray(positions).reshape(-1, 3))
        self.sigma, self.low, self.high = float(sigma), float(low), float(high)
        self.normal = np.asarray(normal, dtype=np.float64)
        self.min_pressure = float(min_pressure)

    def edge_pixels(self, values):
        v = _check_frame(values, self.n)
        img = self.tactile.image(v)
        if float(np.max(np.abs(v))) <= self.min_pressure:
            return img, np.zeros(img.shape, dtype=bool)
        return img, canny_edges(img, self.tactile.inside, self.sigma, self.low, self.high)

    def detect(self, values) -> EdgeFeatures:
        from skimage.measure import label

        img, e = self.edge_pixels(values)
        lab = label(e, connectivity=2)
        sel = lab.ravel() > 0
        pts = self.tactile.pixel_points[sel]
        return features(pts, lab.ravel()[sel] - 1, None, self.normal,
                        extra={"image": img, "edge_pixels": e})


class SubtaxelEdgeDetector:
    """Eq. 6 on a Loop-subdivided skin mesh: the edge located between taxels.

    mesh : SkinMesh (its ``triangles``). levels : Loop subdivision steps (each
    halves the spacing). fraction : threshold as a fraction of the strongest
    fine-mesh response. interpolate : ``"log"`` (default) subdivides
    ``log(p + floor)`` and maps back with ``exp``; ``"linear"`` subdivides ``p``.
    log_floor : ``floor`` as a fraction of the frame's peak.

    Why log: under a thin edge pressed through an elastic layer the pressure
    falls off roughly like a Gaussian, whose logarithm is quadratic; subdividing
    the logarithm reproduces such a bump between two taxel rows almost exactly
    (the mesh version of three-point Gaussian sub-pixel peak interpolation),
    while subdividing ``p`` itself pulls every estimate towards the nearest
    taxel row. With a 6.5 mm row spacing and a ~2 mm wide line contact, the
    linear version's estimate of a 1 mm offset is ~2 mm (the contour follower
    then zig-zags), the log version's ~1 mm. Edge points are weighted by how far their response
    exceeds the threshold, so the centroid and moments move continuously as the
    contact moves, instead of jumping from taxel to taxel.
    """

    name = "subtaxel"

    def __init__(self, mesh, levels: int = 2, fraction: float = 0.1, normal=(0.0, 0.0, 1.0),
                 min_pressure: float = 0.0, centroid: str = "curve", interpolate: str = "log",
                 log_floor: float = 1e-3):
        from ..layout import mesh_from_triangles

        if int(levels) < 0:
            raise InputError(f"must be >= 0, got {levels}", key="levels")
        self.n = len(mesh.positions)
        self.S, tri = loop_subdivision(self.n, mesh.triangles, levels)
        pos = self.S @ np.asarray(mesh.positions, dtype=np.float64)
        nrm = self.S @ np.asarray(mesh.normals, dtype=np.float64)
        nrm /= np.maximum(np.linalg.norm(nrm, axis=1, keepdims=True), TINY)
        self.fine = mesh_from_triangles(pos, nrm, tri)
        self.filter = EdgeFilter(self.fine)
        self.fraction = float(fraction)
        self.normal = np.asarray(normal, dtype=np.float64)
        self.min_pressure = float(min_pressure)
        self.centroid = centroid
        if interpolate not in ("log", "linear"):
            raise InputError(f"must be 'log' or 'linear', got {interpolate!r}", key="interpolate")
        if not log_floor > 0:
            raise InputError(f"must be > 0, got {log_floor}", key="log_floor")
        self.interpolate, self.log_floor = interpolate, float(log_floor)
        self._gmax = float(self.filter.g.max()) if self.filter.g.size else 0.0

    def interpolated(self, values) -> np.ndarray:
        """Pressures (N,) -> values on the fine mesh (N_fine,)."""
        v = _check_frame(values, self.n)
        if self.interpolate == "linear":
            return self.S @ v
        peak = float(np.max(v)) if v.size else 0.0
        if peak <= 0.0:
            return np.zeros(self.S.shape[0])
        floor = self.log_floor * peak
        return np.exp(self.S @ np.log(np.maximum(v, 0.0) + floor)) - floor

    def edges(self, values):
        v = _check_frame(values, self.n)
        fine = self.interpolated(v)
        peak = float(np.max(np.abs(v))) if v.size else 0.0
        if peak <= self.min_pressure or peak == 0.0:
            r = self.filter(fine)
            return fine, r, np.zeros(r.shape, dtype=bool), 0.0
        r, mask, eps = _scaled_response(self.filter, fine, peak, self.fraction, self._gmax)
        return fine, r, mask, eps

    def detect(self, values) -> EdgeFeatures:
        fine, r, mask, eps = self.edges(values)
        lab = mesh_components(self.fine.adjacency, mask)
        idx = np.flatnonzero(mask)
        w = r[idx] - eps
        return features(self.fine.positions[idx], lab[idx], w, self.normal,
                        extra={"mask": mask, "response": r, "fine_values": fine},
                        centroid=self.centroid)


def make_detector(method: str, mesh, flat=None, **kw):
    """``"mesh"``, ``"image"`` or ``"subtaxel"`` detector for ``mesh`` (kwargs go to it)."""
    if method == "mesh":
        return MeshEdgeDetector(mesh, **kw)
    if method == "image":
        return ImageEdgeDetector(mesh.positions, mesh.triangles, flat, **kw)
    if method == "subtaxel":
        return SubtaxelEdgeDetector(mesh, **kw)
    raise InputError(f"unknown method {method!r}; use 'mesh', 'image' or 'subtaxel'", key="method")
