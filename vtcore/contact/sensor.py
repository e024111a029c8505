"""The sensor model: how the stress at a taxel becomes the counts a CySkin AD7147 reports.

Pure functions on ``(T, N)`` (or ``(N,)``) arrays; the scene effects in
``vtcore/scene/effects/sensor.py`` wrap them so that each runs only when a scene
lists it. Order of a real read-out: transduction (gain, optionally saturating),
baseline offset and drift, read noise, 16-bit clipping, integer quantisation,
and the 20 Hz sampling clock.
"""

from __future__ import annotations

import numpy as np

from ..errors import InputError
from ..inputs import need_memory

MAX_COUNTS = 65535.0  # AD7147: 16-bit conversions (seed 001)
RATE_HZ = 20.0        # CySkin read-out rate (seeds 001, 002)


def gain(pressure, counts_per_pa: float, p_half: float | None = None):
    """Pressure (Pa) -> counts.

    Linear ``counts = counts_per_pa * p`` when ``p_half`` is None, else a
    saturating transfer ``counts_per_pa * p_half * p / (p + p_half)`` whose slope at
    0 is ``counts_per_pa`` and which reaches half its ceiling at ``p_half`` (Pa):
    the shape of a capacitive taxel whose air gap closes under load. Negative
    pressures (tension) read as their linear value.
    """
    p = np.asarray(pressure, float)
    if p_half is None:
        return counts_per_pa * p
    pp = np.clip(p, 0.0, None)
    return np.where(p > 0, counts_per_pa * p_half * pp / (pp + p_half), counts_per_pa * p)


def saturate(counts, max_counts: float = MAX_COUNTS, min_counts: float = 0.0):
    """Clip counts to the converter's range."""
    return np.clip(np.asarray(counts, float), min_counts, max_counts)


def quantise(counts, step: float = 1.0):
    """Round to multiples of ``step`` counts (integers by default)."""
    return np.round(np.asarray(counts, float) / step) * step


def add_noise(counts, sigma: float, rng: np.random.Generator):
    """Add zero-mean Gaussian read noise of standard deviation ``sigma`` counts."""
    c = np.asarray(counts, float)
    return c + rng.normal(0.0, sigma, size=c.shape) if sigma > 0 else c.copy()


def baseline(counts, offsets):
    """Add a per-taxel offset (counts, (N,) or scalar)."""
    return np.asarray(counts, float) + np.asarray(offsets, float)


def drift(counts, timestamps, rate, walk: float = 0.0, rng: np.random.Generator | None = None):
    """Slow baseline drift: ``rate`` (counts/s per taxel, (N,) or scalar) times t,
    plus a random walk of ``walk`` counts/sqrt(s). counts : (T, N); timestamps : (T,) s."""
    c = np.asarray(counts, float)
    t = np.asarray(timestamps, float).reshape(-1)
    if c.ndim != 2 or len(t) != c.shape[0]:
        raise InputError(f"drift needs frames (T, N) and timestamps (T,), got {c.shape} and {t.shape}",
                         key="timestamps")
    out = c + (t - t[0])[:, None] * np.asarray(rate, float)
    if walk > 0 and len(t) > 1:
        rng = rng or np.random.default_rng(0)
        dt = np.diff(t, prepend=t[0])
        steps = rng.normal(0.0, 1.0, size=c.shape) * np.sqrt(np.clip(dt, 0, None))[:, None] * walk
        out += np.cumsum(steps, axis=0)
    return out


def sample_clock(frames, timestamps, rate: float = RATE_HZ, phase: float = 0.0):
    """Sample-and-hold ``frames (T, N)`` known at ``timestamps (T,)`` on a clock of ``rate`` Hz.

    Returns (frames (K, N), clock (K,)): at each tick, the latest frame at or
    before it (ticks before the first timestamp are dropped, never filled).
    """
    f = np.asarray(frames, float)
    t = np.asarray(timestamps, float).reshape(-1)
    if f.ndim != 2 or len(t) != f.shape[0]:
        raise InputError(f"sampling needs frames (T, N) and timestamps (T,), got {f.shape} and {t.shape}",
                         key="timestamps")
    if len(t) == 0:
        return f.copy(), t.copy()
    if np.any(np.diff(t) < 0):
        raise InputError("timestamps must not decrease", key="timestamps")
    start = t[0] + phase
    with np.errstate(over="ignore"):  # counted in floats: 1e308 Hz must not reach int()
        ticks = np.floor((t[-1] - start) * rate + 1e-9) + 1
    need_memory(8.0 * 3 * max(float(ticks), 0.0) * max(f.shape[1], 1), key="rate",
                what=f"{ticks:.3g} samples ({t[-1] - t[0]:.3g} s at {rate:.3g} Hz) x {f.shape[1]} taxels",
                remedy="lower the sampling rate")
    k = int(ticks) if ticks > 0 else 0  # (+inf was refused above; a phase past the last frame: no tick)
    clock = start + np.arange(max(k, 0)) / rate
    idx = np.searchsorted(t, clock + 1e-12, side="right") - 1
    return f[idx], clock
