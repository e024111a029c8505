"""Sensor effects: how the stress at a taxel becomes the counts a CySkin AD7147 reports.

Each effect takes either a bare ``frames`` array ((T, N) or (N,)) or a dict
``{"frames": (T, N), "timestamps": (T,)}`` and returns the same kind. Without
timestamps, rows are taken as consecutive readings at 20 Hz (drift) and as
already on the sensor clock (sampling leaves them as they are). Order: gain,
baseline, drift, noise, saturation, quantisation, sampling.
"""

from __future__ import annotations

import numpy as np

from ...contact import sensor as S
from ...errors import InputError
from ..budget import MAX_COUNTS, MAX_GAIN
from ..registry import EffectSpec, register_effect
from ..schema import Field, Section


def _split(state):
    if isinstance(state, dict):
        return np.asarray(state["frames"], float), state.get("timestamps"), state
    return np.asarray(state, float), None, None


def _join(frames, state, timestamps=None):
    if state is None:
        return frames
    out = dict(state)
    out["frames"] = frames
    if timestamps is not None:
        out["timestamps"] = timestamps
    return out


def _rng(ctx, tag):
    return ctx.child_rng(tag) if ctx is not None else np.random.default_rng(0)


class Gain:
    def __init__(self, p, ctx):
        self.counts_per_pa = p["counts_per_pa"]
        self.p_half = p["p_half"]

    def counts(self, pressure):
        """Noise-free counts of ``pressure`` (Pa): the transfer curve alone (used by force control)."""
        return S.gain(pressure, self.counts_per_pa, self.p_half)

    def apply(self, state, ctx):
        f, _, st = _split(state)
        return _join(self.counts(f), st)


class Baseline:
    def __init__(self, p, ctx):
        self.offset, self.spread = p["offset"], p["spread"]
        self.rng = _rng(ctx, "baseline")
        self._per_taxel = None

    def apply(self, state, ctx):
        f, _, st = _split(state)
        n = f.shape[-1]
        if self._per_taxel is None or len(self._per_taxel) != n:
            self._per_taxel = self.offset + self.rng.normal(0.0, self.spread, n) if self.spread > 0 \
                else np.full(n, self.offset)
        return _join(S.baseline(f, self._per_taxel), st)


class Drift:
    def __init__(self, p, ctx):
        self.rate, self.walk = p["rate"], p["walk"]
        self.rng = _rng(ctx, "drift")

    def apply(self, state, ctx):
        f, t, st = _split(state)
        f2 = np.atleast_2d(f)
        if t is None:
            t = np.arange(len(f2)) / S.RATE_HZ
        out = S.drift(f2, t, self.rate, self.walk, self.rng)
        return _join(out.reshape(f.shape), st)


class Noise:
    def __init__(self, p, ctx):
        self.sigma = p["sigma"]
        self.rng = _rng(ctx, "noise")

    def apply(self, state, ctx):
        f, _, st = _split(state)
        return _join(S.add_noise(f, self.sigma, self.rng), st)


class Saturation:
    def __init__(self, p, ctx):
        self.lo, self.hi = p["min_counts"], p["max_counts"]

    def apply(self, state, ctx):
        f, _, st = _split(state)
        return _join(S.saturate(f, self.hi, self.lo), st)


class Quantisation:
    def __init__(self, p, ctx):
        self.step = p["step"]

    def apply(self, state, ctx):
        f, _, st = _split(state)
        return _join(S.quantise(f, self.step), st)


class Sampling:
    def __init__(self, p, ctx):
        self.rate, self.phase = p["rate"], p["phase"]

    def apply(self, state, ctx):
        f, t, st = _split(state)
        if t is None:
            return _join(f, st)  # rows are already readings on the sensor clock
        frames, clock = S.sample_clock(np.atleast_2d(f), t, self.rate, self.phase)
        if len(t) and not len(clock):  # a run without a single reading has no result to give
            raise InputError(f"{self.phase:g} s is past the last frame ({float(np.max(t) - np.min(t)):g} s after the "
                             "first): the clock never ticks", key="phase")
        out = _join(frames, st, clock)
        if isinstance(out, dict):
            out["sample_index"] = np.searchsorted(np.asarray(t, float), clock + 1e-12, side="right") - 1
        return out


register_effect(EffectSpec("gain", "sensor", 10, Gain, Section({
    "counts_per_pa": Field("float", default=0.1, gt=0, le=MAX_GAIN, doc="sensor counts per pascal (slope at 0)"),
    "p_half": Field("float", default=None, gt=0, le=1e12, unit="Pa",
                    doc="saturating transfer: pressure at half the ceiling (none: linear)")}),
    doc="pressure to counts (linear or saturating transfer curve)"))
register_effect(EffectSpec("baseline", "sensor", 20, Baseline, Section({
    "offset": Field("float", default=0.0, ge=-MAX_COUNTS, le=MAX_COUNTS, doc="mean offset, counts"),
    "spread": Field("float", default=0.0, ge=0, le=MAX_COUNTS,
                    doc="standard deviation of the offset across taxels, counts")}),
    doc="per-taxel baseline offset"))
register_effect(EffectSpec("drift", "sensor", 30, Drift, Section({
    "rate": Field("float", default=0.5, ge=-MAX_COUNTS, le=MAX_COUNTS, doc="linear drift, counts per second"),
    "walk": Field("float", default=0.0, ge=0, le=MAX_COUNTS, doc="random-walk drift, counts per sqrt(second)")}),
    doc="slow baseline drift"))
register_effect(EffectSpec("noise", "sensor", 40, Noise, Section({
    "sigma": Field("float", default=20.0, ge=0, le=MAX_COUNTS, doc="standard deviation, counts")}),
    doc="Gaussian read noise"))
register_effect(EffectSpec("saturation", "sensor", 80, Saturation, Section({
    "max_counts": Field("float", default=65535.0, gt=0, le=MAX_COUNTS, doc="16-bit ceiling"),
    "min_counts": Field("float", default=0.0, ge=-MAX_COUNTS, le=MAX_COUNTS, doc="floor")}),
    doc="clip to the converter's range"))
register_effect(EffectSpec("quantisation", "sensor", 90, Quantisation, Section({
    "step": Field("float", default=1.0, ge=1e-6, le=1e6,
                  doc="counts per step (1e-6..1e6: finer is no quantisation, and counts / 1e-320 overflow)")}), doc="integer counts"))
register_effect(EffectSpec("sampling", "sensor", 95, Sampling, Section({
    "rate": Field("float", default=20.0, gt=0, unit="Hz", doc="read-out clock"),
    "phase": Field("float", default=0.0, ge=0, le=3600.0, unit="s", doc="first tick after the first frame")}),
    doc="sample-and-hold on the sensor clock"))
