"""From edge taxels to a motion cue (seed 002 §5.1): components, Eq. 8, moments, centroid."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp

from ..errors import InputError
from ..geometry import tangent_basis
from ..tolerances import EPS, TINY

#: A component whose second moments differ by less than this fraction of their sum
#: (a single point, a symmetric blob) has no orientation and is left out of the mean.
ISOTROPY_TOL = 1e-9


@dataclass
class EdgeFeatures:
    """Edges found in one frame, in the plane of Eq. 8.

    points : (M, 3) float, metres, the edge elements (taxels, fine-mesh vertices or
        back-projected pixels) in the end-effector frame.
    labels : (M,) int, connected component of each point (0..K-1).
    weights : (M,) float, weight of each point in the moments (1, or a response).
    plane : (M, 2) float, metres, the points projected by Eq. 8 in the plane basis.
    thetas : (K,) float, radians in (-pi/2, pi/2], orientation of each component
        w.r.t. the plane's x axis (NaN-free: 0 where undefined, see ``oriented``).
    oriented : (K,) bool, whether the component's orientation is defined.
    theta : float, radians, mean orientation over oriented components (0 if none).
    centroid : (2,) float, metres, weighted centre of all edge points in the plane.
    found : bool, at least one edge point; ``centroid`` and ``theta`` are 0 otherwise.
    """

    points: np.ndarray
    labels: np.ndarray
    weights: np.ndarray
    plane: np.ndarray
    thetas: np.ndarray
    oriented: np.ndarray
    theta: float
    centroid: np.ndarray
    found: bool
    extra: dict = field(default_factory=dict)

    @property
    def n_components(self) -> int:
        return len(self.thetas)

    @property
    def has_orientation(self) -> bool:
        return bool(np.any(self.oriented))


def plane_basis(normal) -> np.ndarray:
    """(3, 3) rows ``u, v, n``: an orthonormal basis with ``n`` the unit plane normal.

    For ``n = z`` it is the identity, so plane coordinates are the frame's x, y.
    """
    n = np.asarray(normal, dtype=np.float64).reshape(3)
    norm = np.linalg.norm(n)
    if not np.isfinite(norm) or norm < EPS:
        raise InputError(f"plane normal must be a non-zero finite vector, got {n}", key="normal")
    n = n / norm
    u, v = tangent_basis(n)
    return np.vstack([u, v, n])


def skin_frame(layout) -> np.ndarray:
    """Pose (4x4) of the frame the detectors work in, in the layout's frame (metres).

    Eq. 8 projects the edges on the plane normal to the end-effector's approach
    axis at the reference point x_R. Origin at x_R: ``layout.meta["reference_taxel"]``
    (a taxel index) or ``layout.meta["reference_point"]`` (3,), else the taxel nearest
    the centroid. z: the outward normal at x_R. x: for a skin curved about one axis
    (seed 002's non-planar patch) the axis of the curvature, the only direction along
    which a straight edge can lie on the contact line; for a flat skin, the layout's
    x axis (projected). ``vtcore.control.control_frame`` is this frame.
    """
    pos = np.asarray(layout.positions, dtype=np.float64)
    nrm = np.asarray(layout.normals, dtype=np.float64)
    meta = getattr(layout, "meta", {}) or {}
    if "reference_taxel" in meta:
        i = int(meta["reference_taxel"])
        origin = pos[i]
    else:
        origin = np.asarray(meta.get("reference_point", pos.mean(axis=0)), dtype=np.float64)
        i = int(np.argmin(np.linalg.norm(pos - origin, axis=1)))
    z = nrm[i] / np.linalg.norm(nrm[i])
    dev = nrm - nrm.mean(axis=0)
    if np.abs(dev).max() < 0.05:
        # flat skin: keep the layout's own x axis (the patch's long side for seed 002)
        x = np.array([1.0, 0.0, 0.0]) - z * z[0]
        if np.linalg.norm(x) < 1e-9:
            x = np.array([0.0, 1.0, 0.0]) - z * z[1]
    else:
        # curved skin: the normals turn about the curvature axis, which is
        # perpendicular to the direction in which they vary most
        _, _, vt = np.linalg.svd(dev, full_matrices=False)
        x = np.cross(z, vt[0])
        if np.linalg.norm(x) < 1e-9:
            x = np.array([1.0, 0.0, 0.0]) - z * z[0]
        if x @ np.array([1.0, 1.0, 1e-3]) < 0:  # deterministic sign
            x = -x
    x = x - z * (x @ z)
    x /= np.linalg.norm(x)
    y = np.cross(z, x)
    out = np.eye(4)
    out[:3, :3] = np.column_stack([x, y, z])
    out[:3, 3] = origin
    return out


def project_plane(points, normal=(0.0, 0.0, 1.0)) -> np.ndarray:
    """Eq. 8: ``(I - n n^T) t`` expressed in the plane basis; (M, 3) -> (M, 2) metres."""
    b = plane_basis(normal)
    p = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    return p @ b[:2].T


def mesh_components(adjacency, mask) -> np.ndarray:
    """Connected components of the taxels where ``mask`` is True (BFS on the mesh, csgraph).

    adjacency : (N, N) sparse. mask : (N,) bool.
    Returns (N,) int: component label of each masked taxel, -1 elsewhere.
    """
    from scipy.sparse.csgraph import connected_components

    mask = np.asarray(mask, dtype=bool)
    labels = np.full(mask.shape, -1, dtype=np.int64)
    idx = np.flatnonzero(mask)
    if idx.size == 0:
        return labels
    sub = sp.csr_matrix(adjacency)[idx][:, idx]
    _, lab = connected_components(sub, directed=False)
    labels[idx] = lab
    return labels


def component_orientation(plane_points, labels, weights=None, n_components=None):
    """Orientation of each component from its central second moments (image moments).

    plane_points : (M, 2) metres. labels : (M,) int in 0..K-1. weights : (M,) >= 0.
    Returns ``thetas (K,)`` radians in (-pi/2, pi/2] (the axis of least inertia,
    ``0.5 * atan2(2 mu11, mu20 - mu02)``, Rocha et al. [32]), ``oriented (K,)``
    bool (False for single points and isotropic blobs, whose theta is 0),
    ``sizes (K,)`` total weight.
    A collinear component has one zero moment and a well-defined orientation.
    """
    x = np.asarray(plane_points, dtype=np.float64).reshape(-1, 2)
    lab = np.asarray(labels, dtype=np.int64)
    w = np.ones(len(x)) if weights is None else np.asarray(weights, dtype=np.float64)
    k = int(lab.max()) + 1 if n_components is None and lab.size else int(n_components or 0)
    m0 = np.bincount(lab, w, minlength=k)
    safe = np.where(m0 > 0, m0, 1.0)
    cx = np.bincount(lab, w * x[:, 0], minlength=k) / safe
    cy = np.bincount(lab, w * x[:, 1], minlength=k) / safe
    dx, dy = x[:, 0] - cx[lab], x[:, 1] - cy[lab]
    mu20 = np.bincount(lab, w * dx * dx, minlength=k) / safe
    mu02 = np.bincount(lab, w * dy * dy, minlength=k) / safe
    mu11 = np.bincount(lab, w * dx * dy, minlength=k) / safe
    a, b = mu20 - mu02, 2.0 * mu11
    spread = mu20 + mu02
    aniso = np.hypot(a, b)
    oriented = (m0 > 0) & (aniso > ISOTROPY_TOL * np.maximum(spread, TINY)) & (spread > 0)
    thetas = np.where(oriented, 0.5 * np.arctan2(b, a), 0.0)
    thetas = wrap_half_pi(thetas)
    return thetas, oriented, m0


def wrap_half_pi(theta):
    """Map angles (radians) of undirected lines to (-pi/2, pi/2]."""
    t = np.mod(np.asarray(theta, dtype=np.float64) + np.pi / 2, np.pi) - np.pi / 2
    return np.where(t <= -np.pi / 2, t + np.pi, t)


def mean_axis(thetas, weights=None) -> float:
    """Mean of undirected orientations (radians): the doubled-angle mean, in (-pi/2, pi/2].

    Averaging raw angles fails across the +-pi/2 wrap (a line at 89 deg and one at
    -89 deg average to 0, not 90); doubling makes the pi-periodic axes 2pi-periodic.
    Returns 0 for no input or a cancelling set.
    """
    t = np.asarray(thetas, dtype=np.float64)
    if t.size == 0:
        return 0.0
    w = np.ones_like(t) if weights is None else np.asarray(weights, dtype=np.float64)
    c, s = np.sum(w * np.cos(2 * t)), np.sum(w * np.sin(2 * t))
    if np.hypot(c, s) < EPS * max(np.sum(np.abs(w)), TINY):
        return 0.0
    return float(wrap_half_pi(0.5 * np.arctan2(s, c)))


def local_curve(plane, labels, weights, sizes, *, major: float = 0.2, degree: int = 2,
                at: float = 0.0, scale: float = 0.01, ridge: float = 1e-3, min_extent: float = 3e-3):
    """The edge as a curve ``y(x)`` near ``x = at``: value and slope there, or None.

    A weighted polynomial ``y = a + b u + c u^2`` (``u = (x - at) / scale``, a small
    ridge penalty on b and c so a short component cannot swing it) is fitted to each
    major component (total weight >= ``major`` x the largest) spanning at least
    ``min_extent`` metres in x, evaluated at ``at`` clamped into the component's
    x-range, and the components are averaged (the two flanks of a ridge count once each).
    Returns ``(y, theta)`` metres / radians, or None when no component qualifies.
    """
    xy = np.asarray(plane, dtype=np.float64)
    lab = np.asarray(labels, dtype=np.int64)
    w = np.asarray(weights, dtype=np.float64)
    big = np.flatnonzero(sizes >= major * sizes.max())
    ys, slopes = [], []
    for c in big:  # a handful of components per frame, not a loop over taxels
        s = lab == c
        x, y, ww = xy[s, 0], xy[s, 1], w[s]
        if np.ptp(x) < min_extent:
            continue
        u = (x - at) / scale
        a = np.column_stack([u**k for k in range(degree + 1)])
        sw = np.sqrt(ww)
        reg = ridge * ww.sum() * np.eye(degree + 1)
        reg[0, 0] = 0.0
        coef = np.linalg.solve((a * sw[:, None]).T @ (a * sw[:, None]) + reg, (a * sw[:, None]).T @ (y * sw))
        u0 = np.clip(0.0, u.min(), u.max())
        ys.append(sum(coef[k] * u0**k for k in range(degree + 1)))
        slopes.append(sum(k * coef[k] * u0 ** (k - 1) for k in range(1, degree + 1)) / scale)
    if not ys:
        return None
    return float(np.mean(ys)), float(np.arctan(np.mean(slopes)))


def features(points, labels, weights=None, normal=(0.0, 0.0, 1.0), extra=None,
             centroid: str = "points", major: float = 0.2) -> EdgeFeatures:
    """Eq. 8 projection, per-component orientation and the centroid of edge points.

    points : (M, 3) metres. labels : (M,) int component ids (any non-negative ints).
    weights : (M,) >= 0 or None (all 1). normal : the z axis of Eq. 8.
    centroid : ``"points"`` (seed 002: centre of mass of all edge points),
        ``"components"``: the mean of the centroids of the major components
        (total weight >= ``major`` x the largest), so that each flank of a ridge
        counts once whatever its visible length on the patch, or ``"curve"``: the
        edge where it crosses the reference point's x (the plane origin), from a
        local quadratic fit (:func:`local_curve`); ``centroid`` is then ``(0, y)``
        and ``theta`` the edge's direction there. A curved contour's centroid lies
        inside the curve (a 40 mm chord of the 39 mm mug rim: ~1.7 mm) and its
        mean direction lags the direction at x_R; the fit removes both. Falls
        back to ``"components"`` when no component spans 3 mm in x.
    """
    if centroid not in ("points", "components", "curve"):
        raise InputError(f"must be 'points', 'components' or 'curve', got {centroid!r}", key="centroid")
    p = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    lab = np.asarray(labels, dtype=np.int64).reshape(-1)
    if len(lab) != len(p):
        raise InputError(f"{len(lab)} labels for {len(p)} points", key="labels")
    w = np.ones(len(p)) if weights is None else np.asarray(weights, dtype=np.float64).reshape(-1)
    if len(p) == 0 or not np.any(w > 0):
        return EdgeFeatures(p, lab, w, np.zeros((len(p), 2)), np.zeros(0), np.zeros(0, bool), 0.0,
                            np.zeros(2), False, dict(extra or {}))
    _, lab = np.unique(lab, return_inverse=True)
    xy = project_plane(p, normal)
    thetas, oriented, sizes = component_orientation(xy, lab, w)
    theta = mean_axis(thetas[oriented], sizes[oriented])
    if centroid == "curve":
        fit = local_curve(xy, lab, w, sizes, major=major)
        if fit is not None:
            return EdgeFeatures(p, lab, w, xy, thetas, np.ones_like(oriented) | oriented, fit[1],
                                np.array([0.0, fit[0]]), True, dict(extra or {}, located="curve"))
        centroid = "components"
    if centroid == "points":
        c = (w[:, None] * xy).sum(axis=0) / w.sum()
    else:
        k = len(sizes)
        comp = np.column_stack([np.bincount(lab, w * xy[:, 0], minlength=k),
                                np.bincount(lab, w * xy[:, 1], minlength=k)])
        big = sizes >= major * sizes.max()
        c = (comp[big] / sizes[big, None]).mean(axis=0)
    return EdgeFeatures(p, lab, w, xy, thetas, oriented, theta, c, True, dict(extra or {}))
