"""Augmented point clouds for a front end: propagate probe values over a cloud."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ...errors import InputError


def augment(cloud_points, probe_points, probe_values, *, method: str = "smooth", beta: float = -300.0,
            c_min: float | None = None, c_max: float | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Propagate tactile values from probes to a visual point cloud (seed 000).

    cloud_points : (M, 3) metres. probe_points : (n, 3) metres; probe_values : (n,).
    method : "cluster" (Eq. 2) or "smooth" (Eqs. 3-4, ``beta`` per metre, <= 0).
    Returns ``values (M,)`` and ``colours (M, 3)`` float in [0, 1] (viridis_r
    between c_min and c_max, default the probes' range).
    """
    from ...augment import ClusterPropagation, SmoothPropagation, colour_map

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
    from ...augment import load_probes

    path = Path(path)
    if not path.is_file():
        raise InputError("is not a readable probe file", file=path)
    tpc = load_probes(path)
    vals = np.asarray(tpc.values, float)
    return np.asarray(tpc.points, float), vals[:, 0] if vals.ndim == 2 else vals
