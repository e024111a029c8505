"""A sphere pressed on a skin through a soft layer (foundation model).

Local (Winkler) layer: pressure ``q = E' * delta / h`` where the sphere
penetrates the layer's outer surface, ``E' = E / (1 - nu^2)``; optionally spread
to the taxels at depth ``h`` with the Boussinesq vertical-stress kernel. The
contact issue replaces this with an elastic contact solve.
"""

from __future__ import annotations

import numpy as np
from scipy.optimize import brentq

from ..errors import UnreachableTargetError


def boussinesq_kernel(r: np.ndarray, h: float) -> np.ndarray:
    """Vertical stress at depth h under a unit point load at radial distance r (1/m^2).

    sigma_z(r) = 3 h^3 / (2 pi (r^2 + h^2)^(5/2)); integrates to 1 over the plane.
    """
    return 3.0 * h**3 / (2.0 * np.pi * (r**2 + h**2) ** 2.5)


def spread_through_layer(positions, surface_pressure, thickness, taxel_area):
    """Stress reaching the taxels at depth ``thickness`` (Boussinesq spreading).

    positions : (N, 3) metres. surface_pressure : (N,) or (T, N) pascals on the
    layer's surface above each taxel. Returns the same shape, pascals.
    """
    p = np.asarray(positions, float)
    q = np.asarray(surface_pressure, float)
    if thickness <= 0:
        return q.copy()
    r = np.linalg.norm(p[:, None, :] - p[None, :, :], axis=-1)
    kernel = boussinesq_kernel(r, thickness) * taxel_area
    return q @ kernel.T


def median_taxel_area(positions) -> float:
    """Skin area (m^2) one taxel stands for on a triangular lattice of its median spacing."""
    from scipy.spatial import cKDTree

    d, _ = cKDTree(positions).query(positions, k=2)
    return float(np.sqrt(3) / 2 * np.median(d[:, 1]) ** 2)


def press_sphere(positions, normals, centre_xy, radius, force, thickness, young_modulus,
                 poisson=0.49, taxel_area=None):
    """Press a rigid sphere along -z onto the skin until the total force is ``force``.

    positions, normals : (N, 3) metres / unit. centre_xy : (2,) metres, where the
    sphere's centre passes. radius, thickness : metres. force : newtons.
    young_modulus : pascals. taxel_area : m^2 of skin each taxel stands for.

    Returns the layer's ``surface_pressure (N,)`` pascals above each taxel and
    the ``indentation`` (m). Raises UnreachableTargetError when the target force
    cannot be reached within the layer.
    """
    p = np.asarray(positions, float)
    n = np.asarray(normals, float)
    h = max(float(thickness), 1e-6)
    outer = p + h * n
    if taxel_area is None:
        taxel_area = median_taxel_area(p)
    e_star = young_modulus / (1.0 - poisson**2)
    cxy = np.asarray(centre_xy, float)
    top = outer[:, 2].max()

    def surface_pressure(depth):
        c = np.array([cxy[0], cxy[1], top + radius - depth])
        pen = np.clip(radius - np.linalg.norm(outer - c, axis=1), 0.0, h)
        return e_star * pen / h

    def total(depth):
        return surface_pressure(depth).sum() * taxel_area - force

    if total(h) < 0:
        raise UnreachableTargetError(
            f"a force of {force} N is not reached before the sphere bottoms out the "
            f"{h * 1e3:.1f} mm layer (at most {total(h) + force:.3g} N)")
    depth = brentq(total, 0.0, h, xtol=1e-12) if force > 0 else 0.0
    return surface_pressure(depth), depth
