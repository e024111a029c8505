"""Shared builders for the CAN tests (imported by test_can_*.py; holds no tests itself)."""

from __future__ import annotations

import hashlib

import numpy as np

from vtcore.contact import SoftLayer, make_object, placement_pose, press_sequence
from vtcore.layout import Layout, hexagon_flat, wrap_on_sphere

_PRESSURE_CACHE: dict = {}


def hexagon_layout(icub: bool = False) -> Layout:
    """The 60-taxel hexagon; CySkin UIDs ``(module + 1) << 4 | 1..10`` or iCub ids of board 1."""
    flat, modules = hexagon_flat()
    pos, nrm = wrap_on_sphere(flat, np.inf)
    if icub:
        ids = 192 * 1 + np.arange(len(pos))        # board 1, triangles 0..4, 12 slots each
        mods = ids // 12
    else:
        ids = ((modules + 1) << 4) | np.tile(np.arange(1, 11), 6)[: len(modules)]
        mods = modules + 1
    return Layout(pos, nrm, ids, mods, flat=flat)


def sphere_press(layout: Layout, t: int = 12) -> np.ndarray:
    """Taxel pressure ``(T, N)`` Pa of a 20 mm sphere pressed with a 0 -> 5 N -> 0 force ramp
    through a 3 mm Ecoflex 00-20 layer (``vtcore.contact.press``, numpy back-end: deterministic).
    Cached per layout geometry (the tests share a few layouts)."""
    key = (hashlib.sha1(layout.positions.tobytes() + layout.normals.tobytes()).hexdigest(), t)
    if key not in _PRESSURE_CACHE:
        layer = SoftLayer(thickness=0.003, material="ecoflex_00_20")
        sphere = make_object("sphere", radius=0.02)
        top = float(layout.positions[:, 2].max()) + layer.thickness
        pose = placement_pose(sphere, xy=(0.004, -0.002), top=top, gap=0.0005)
        force = 5.0 * np.sin(np.linspace(0.0, np.pi, t)) ** 2
        res = press_sequence(layout, sphere, np.repeat(pose[None], t, axis=0), layer, force=force, backend="numpy")
        _PRESSURE_CACHE[key] = np.array([r.pressure for r in res])
    return _PRESSURE_CACHE[key].copy()


def press_counts(layout: Layout, t: int = 12, peak_counts: float = 800.0, seed: int = 0):
    """A sphere pressing with a force ramp: ``timestamps (T,)`` at 20 Hz and counts ``(T, N)``
    (pressure scaled so the peak is ``peak_counts``, plus 3-count noise)."""
    pressure = sphere_press(layout, t)
    rng = np.random.default_rng(seed)
    counts = pressure / pressure.max() * peak_counts
    counts = counts + rng.normal(0, 3.0, counts.shape)
    ts = 1700000000.0 + np.arange(t) * 0.05
    return ts, counts
