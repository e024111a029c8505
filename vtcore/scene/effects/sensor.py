"""Sensor effects: how pressure becomes the counts a CySkin AD7147 reports."""

from __future__ import annotations

import numpy as np

from ..registry import EffectSpec, register_effect
from ..schema import Field, Section


class Gain:
    def __init__(self, p, ctx):
        self.counts_per_pa = p["counts_per_pa"]

    def apply(self, frames, ctx):
        return frames * self.counts_per_pa


class Noise:
    def __init__(self, p, ctx):
        self.sigma = p["sigma"]
        self.rng = ctx.child_rng("noise") if ctx is not None else np.random.default_rng(0)

    def apply(self, frames, ctx):
        return frames + self.rng.normal(0.0, self.sigma, size=np.shape(frames))


class Saturation:
    def __init__(self, p, ctx):
        self.lo, self.hi = 0.0, p["max_counts"]

    def apply(self, frames, ctx):
        return np.clip(frames, self.lo, self.hi)


class Quantisation:
    def __init__(self, p, ctx):
        self.step = p["step"]

    def apply(self, frames, ctx):
        return np.round(np.asarray(frames) / self.step) * self.step


register_effect(EffectSpec("gain", "sensor", 10, Gain, Section({
    "counts_per_pa": Field("float", default=0.1, gt=0, doc="sensor counts per pascal")}),
    doc="pressure to counts"))
register_effect(EffectSpec("noise", "sensor", 40, Noise, Section({
    "sigma": Field("float", default=20.0, ge=0, doc="standard deviation, counts")}),
    doc="Gaussian read noise"))
register_effect(EffectSpec("saturation", "sensor", 80, Saturation, Section({
    "max_counts": Field("float", default=65535.0, gt=0)}), doc="clip to the 16-bit range"))
register_effect(EffectSpec("quantisation", "sensor", 90, Quantisation, Section({
    "step": Field("float", default=1.0, gt=0, doc="counts per step")}), doc="integer counts"))
