"""Tactile images (seed 001 §III): readings averaged while the force is held, then over trials.

A tactile image is one taxel vector per object: ``readings`` consecutive sensor
readings (10 at 20 Hz) averaged, and the averaged images of ``trials`` (3)
repetitions averaged again. What varies between readings and trials is what
the sensor model adds (noise, drift, ...): the caller passes it as ``sensor``,
a callable, so that a scene can route it through its effect pipeline.
"""

from __future__ import annotations

from typing import Callable

import numpy as np

from ..errors import InputError


def tactile_images(pressure, sensor: Callable[[np.ndarray], np.ndarray] | None = None, *, readings: int = 10,
                   trials: int = 3) -> tuple[np.ndarray, np.ndarray]:
    """Tactile images of M objects from their noise-free taxel pressures.

    Parameters
    ----------
    pressure : (M, N) float, pascals at the N taxels while object m is held at the target force;
        or (trials, M, N): each trial's own pressures (the object placed anew each trial, see
        :mod:`vtcore.categorize.jitter`), ``trials`` then being their number.
    sensor : callable ``(T, N) pascals -> (T, N) readings`` (counts), or None for
        an ideal sensor (the readings are the pressures). It is called once per
        trial and object, trials outer, objects inner, so a seeded sensor gives the
        same images for the same call order.
    readings, trials : int >= 1.

    Returns
    -------
    images : (M, N) float, the tactile images (mean over readings, then over trials).
    frames : (trials, M, readings, N) float, every reading.
    """
    p = np.asarray(pressure, dtype=np.float64)
    if p.ndim == 3:
        if p.shape[0] != trials:
            raise InputError(f"per-trial pressure has {p.shape[0]} trials, trials = {trials}", key="pressure")
    elif p.ndim != 2:
        raise InputError(f"pressure must be (objects, taxels) or (trials, objects, taxels), got shape {p.shape}",
                         key="pressure")
    if not np.isfinite(p).all():
        raise InputError("pressure holds non-finite values", key="pressure")
    for name, val in (("readings", readings), ("trials", trials)):
        if isinstance(val, bool) or not isinstance(val, (int, np.integer)) or val < 1:
            raise InputError(f"must be an integer >= 1, got {val!r}", key=name)
    m, n = p.shape[-2:]
    frames = np.empty((trials, m, readings, n))
    for trial in range(trials):
        pt = p[trial] if p.ndim == 3 else p
        for obj in range(m):
            block = np.broadcast_to(pt[obj], (readings, n)).copy()
            out = block if sensor is None else np.asarray(sensor(block), dtype=np.float64)
            if out.shape != (readings, n):
                raise InputError(f"the sensor model returned shape {out.shape}, expected {(readings, n)}",
                                 key="sensor")
            frames[trial, obj] = out
    images = frames.mean(axis=2).mean(axis=0)
    return images, frames
