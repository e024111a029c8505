"""The tactile-image baseline of seed 002 (§2 steps i-v, §5.2).

(i) flatten the skin (the layout's flat patch coordinates, or a log-map
parameterisation of the skin mesh for imported layouts); (ii) resample the flat
domain on a regular grid (1 mm in seed 002, a 74 x 132 image for its curved
patch); (iii) interpolate every pixel linearly from the taxels of the flat
triangle it falls in; (iv) Canny (scikit-image); (v) back-project the edge
pixels through the same barycentric weights onto the 3-D skin mesh.

Steps (ii), (iii) and (v) depend only on the geometry, so they are precomputed:
a CSR matrix (pixels x taxels) makes an image from a frame, and a (pixels x 3)
array holds the 3-D point of every pixel.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from ..errors import InputError
from ..tolerances import EPS, TINY


def flatten(positions, triangles, flat=None) -> np.ndarray:
    """Flat (N, 2) metres coordinates of a skin for the tactile image.

    ``flat`` (the layout's own patch coordinates) is used when given. Otherwise
    the skin mesh is parameterised by the logarithmic map (geodesic polar
    coordinates) about its most central taxel, from potpourri3d's vector heat
    method: distances from the centre are kept, which is what a designer's
    unrolled patch keeps too. Falls back to projection on the best-fit plane
    (PCA) if potpourri3d is unavailable or the mesh is degenerate.
    """
    if flat is not None:
        f = np.asarray(flat, dtype=np.float64).reshape(-1, 2)
        if len(f) != len(positions):
            raise InputError(f"{len(f)} flat rows for {len(positions)} taxels", key="flat")
        return f
    pos = np.asarray(positions, dtype=np.float64)
    tri = np.asarray(triangles, dtype=np.int64).reshape(-1, 3)
    if len(tri) and (tri.min() < 0 or tri.max() >= len(pos)):
        raise InputError(f"triangles must index the {len(pos)} taxels (0..{len(pos) - 1}); "
                         f"got indices {tri.min()}..{tri.max()}", key="triangles")
    centre = pos.mean(axis=0)
    f = log_map(pos, tri, int(np.argmin(np.linalg.norm(pos - centre, axis=1)))) if len(tri) else None
    if f is not None:
        return f
    _, _, vt = np.linalg.svd(pos - centre, full_matrices=False)
    return (pos - centre) @ vt[:2].T


def log_map(positions, triangles, centre: int) -> np.ndarray | None:
    """Logarithmic map (N, 2) metres of a triangle mesh about vertex ``centre`` (potpourri3d).

    None when potpourri3d is not installed (it is the optional extra ``geodesic``) or
    when the mesh is one it cannot parameterise: geometry-central raises RuntimeError
    for a non-manifold mesh, and a mesh in several pieces leaves vertices without a
    finite coordinate. Any other error is a real one and propagates.
    """
    try:
        import potpourri3d as pp3d
    except ImportError:
        return None
    try:
        solver = pp3d.MeshVectorHeatSolver(positions, triangles)
        f = np.asarray(solver.compute_log_map(centre), dtype=np.float64)
    except RuntimeError:  # GC_SAFETY_ASSERT: not a manifold surface mesh
        return None
    return f if f.shape == (len(positions), 2) and np.all(np.isfinite(f)) else None


class TactileImage:
    """Resampling of a flattened skin on a regular grid, and its inverse.

    Parameters
    ----------
    positions : (N, 3) metres, taxels on the 3-D skin.
    triangles : (F, 3) int, the skin mesh.
    flat : (N, 2) metres or None (see :func:`flatten`).
    resolution : pixel size, metres (seed 002: 1 mm).

    Attributes
    ----------
    shape : (H, W) pixels. interp : (H*W, N) CSR barycentric weights (zero rows
    outside the mesh). inside : (H, W) bool. pixel_points : (H*W, 3) metres,
    back-projection of each pixel centre onto the 3-D mesh.
    """

    def __init__(self, positions, triangles, flat=None, resolution: float = 1e-3):
        if not resolution > 0:
            raise InputError(f"must be > 0, got {resolution}", key="resolution")
        from matplotlib.tri import Triangulation

        pos = np.asarray(positions, dtype=np.float64).reshape(-1, 3)
        tri = np.asarray(triangles, dtype=np.int64).reshape(-1, 3)
        if len(tri) == 0:
            raise InputError("the skin mesh has no triangles; a tactile image needs at least one",
                             key="triangles")
        self.flat = flatten(pos, tri, flat)
        self.resolution = float(resolution)
        lo = self.flat.min(axis=0)
        hi = self.flat.max(axis=0)
        w = int(np.floor((hi[0] - lo[0]) / resolution)) + 1
        h = int(np.floor((hi[1] - lo[1]) / resolution)) + 1
        self.shape = (h, w)
        self.origin = lo
        xs = lo[0] + resolution * np.arange(w)
        ys = lo[1] + resolution * np.arange(h)
        gx, gy = np.meshgrid(xs, ys)
        px, py = gx.ravel(), gy.ravel()
        t = Triangulation(self.flat[:, 0], self.flat[:, 1], tri)
        face = t.get_trifinder()(px, py)
        inside = face >= 0
        f = tri[face[inside]]
        a, b, c = self.flat[f[:, 0]], self.flat[f[:, 1]], self.flat[f[:, 2]]
        p = np.column_stack([px[inside], py[inside]])
        v0, v1, v2 = b - a, c - a, p - a
        den = v0[:, 0] * v1[:, 1] - v1[:, 0] * v0[:, 1]
        den = np.where(np.abs(den) > TINY, den, TINY)
        l1 = (v2[:, 0] * v1[:, 1] - v1[:, 0] * v2[:, 1]) / den
        l2 = (v0[:, 0] * v2[:, 1] - v2[:, 0] * v0[:, 1]) / den
        bary = np.clip(np.column_stack([1.0 - l1 - l2, l1, l2]), 0.0, 1.0)
        bary /= bary.sum(axis=1, keepdims=True)
        pix = np.flatnonzero(inside)
        self.interp = sp.csr_matrix((bary.ravel(), (np.repeat(pix, 3), f.ravel())),
                                    shape=(h * w, len(pos)))
        self.inside = inside.reshape(h, w)
        self.pixel_points = np.zeros((h * w, 3))
        self.pixel_points[pix] = np.einsum("pk,pkd->pd", bary, pos[f])

    def image(self, values) -> np.ndarray:
        """(N,) -> (H, W) or (T, N) -> (T, H, W) image; 0 outside the skin."""
        v = np.asarray(values, dtype=np.float64)
        if v.ndim == 1:
            return (self.interp @ v).reshape(self.shape)
        return (self.interp @ v.T).T.reshape((v.shape[0],) + self.shape)

    def back_project(self, pixel_mask) -> np.ndarray:
        """3-D points (M, 3) metres of the pixels where ``pixel_mask`` (H, W) is True."""
        return self.pixel_points[np.asarray(pixel_mask, dtype=bool).ravel()]


def canny_edges(img, inside, sigma: float = 1.5, low: float = 0.1, high: float = 0.2):
    """Canny (scikit-image) with hysteresis thresholds relative to the strongest gradient.

    img : (H, W). inside : (H, W) bool, pixels on the skin (edges of the image's
    support are not contact edges). low, high : fractions of the frame's maximum
    smoothed-gradient magnitude, so the same setting works at any force or unit.
    Returns (H, W) bool edge pixels (all False for a flat image).
    """
    from skimage.feature import canny

    img = np.asarray(img, dtype=np.float64)
    peak = float(np.max(np.abs(img))) if img.size else 0.0
    if peak <= 0.0:
        return np.zeros(img.shape, dtype=bool)
    x = img / peak
    # the gradient magnitude Canny thresholds: Sobel of the Gaussian-smoothed image
    from scipy import ndimage

    sm = ndimage.gaussian_filter(x, sigma, mode="nearest")
    mag = np.hypot(ndimage.sobel(sm, axis=0), ndimage.sobel(sm, axis=1))[inside]
    gmax = float(mag.max()) if mag.size else 0.0
    if gmax <= EPS:
        return np.zeros(img.shape, dtype=bool)
    return canny(x, sigma=sigma, low_threshold=low * gmax, high_threshold=high * gmax, mask=inside)
