"""Synthetic, CySkin-like calibrated patches for tests and benchmarks.

No manufacturer file ships with this project, so the "agree with the maker's
triangulation" check runs on a realistic stand-in: a half-cylinder forearm-style
patch (500-650 taxels in 50-60 modules, as the format notes describe real ones),
with calibration noise on the 3-D positions and a maker-style triangulation:
the 2-D Delaunay of a slightly distorted unrolled map ("isomap", edge lengths
within about 0.9-1.2x of 3-D), boundary slivers included, as the maker's tools
produce. It is synthetic and says so in its ``meta``.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial import Delaunay

from .model import Layout
from .modules import get_module
from .patches import fill_patch


def cyskin_half_cylinder(radius: float = 0.05, length: float = 0.22, noise: float = 3e-4,
                         distortion: float = 0.08, seed: int = 0, module: str = "cyskin10"):
    """A half-cylinder CySkin patch as a maker's calibration file would describe it.

    radius, length : metres, of the half cylinder (axis along y, top at z = radius).
    noise : metres, standard deviation of the calibration error added to the 3-D positions.
    distortion : relative amplitude of the smooth stretch of the maker's unrolled map.
    Returns ``(layout, maker_faces (F, 3), maker_map (N, 2))``; the layout has 3-D
    positions and normals only (``flat`` is None), like a CSV of positions.
    """
    rng = np.random.default_rng(seed)
    mod = get_module(module)
    half = np.pi * radius / 2  # unrolled half-width of the half cylinder
    lo, hi = np.array([-half, -length / 2]), np.array([half, length / 2])
    r = mod.taxel_diameter / 2
    patch = fill_patch(mod, lambda f: np.all((f >= lo + r) & (f <= hi - r), axis=1), lo, hi,
                       angles=(0.0,), offsets=3)
    u, v = patch.flat[:, 0], patch.flat[:, 1]
    th = u / radius
    nrm = np.column_stack([np.sin(th), np.zeros_like(th), np.cos(th)])
    pos = np.column_stack([radius * np.sin(th), v, radius * np.cos(th)])
    pos = pos + rng.normal(0.0, noise, pos.shape)
    # the maker's isomap: a smooth stretch plus a little noise
    s = 1.0 + distortion * np.sin(2 * np.pi * v / length) * np.cos(th)
    maker_map = np.column_stack([u * s, v * (1.0 + 0.5 * distortion * np.cos(th))])
    maker_map = maker_map + rng.normal(0.0, noise, maker_map.shape)
    faces = Delaunay(maker_map).simplices.astype(np.int64)
    layout = Layout(pos, nrm, patch.taxel_ids, patch.module_ids,
                    meta={"synthetic": True, "source": "vtcore.layout.synthetic.cyskin_half_cylinder",
                          "module_type": mod.name, "pitch_m": mod.pitch})
    return layout, faces, maker_map


def edge_agreement(edges_a: np.ndarray, edges_b: np.ndarray) -> float:
    """Fraction of the undirected edges of ``edges_b`` (the reference) also in ``edges_a``."""
    a = {tuple(e) for e in np.sort(np.asarray(edges_a).reshape(-1, 2), axis=1).tolist()}
    b = {tuple(e) for e in np.sort(np.asarray(edges_b).reshape(-1, 2), axis=1).tolist()}
    return len(a & b) / max(len(b), 1)


def faces_to_edges(faces: np.ndarray) -> np.ndarray:
    f = np.asarray(faces, dtype=np.int64).reshape(-1, 3)
    e = np.sort(np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]]), axis=1)
    return np.unique(e, axis=0)
