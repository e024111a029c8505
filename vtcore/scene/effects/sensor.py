"""Sensor effects: how the stress at a taxel becomes the counts a CySkin AD7147 reports.

Each effect takes either a bare ``frames`` array ((T, N) or (N,)) or a dict
``{"frames": (T, N), "timestamps": (T,)}`` and returns the same kind. Without
timestamps, rows are taken as consecutive readings at 20 Hz (drift) and as
already on the sensor clock (sampling leaves them as they are). Order: gain,
baseline, drift, noise, saturation, quantisation, sampling.

``profile = "NAME_OR_FILE"`` (a shipped sensor profile such as ``"cyskin"`` or a profile TOML
written by ``vtcore calibrate``; :mod:`vtcore.contact.profile`) on ``gain``, ``baseline`` and
``noise`` takes their numbers from measurement: the fitted transfer curve, each taxel's measured
offset and noise (matched to the scene's layout by taxel UID; the profile's medians where a UID
was not measured). A number given beside it is an error (one source per value).
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


def _profile(p, name, numbers):
    """The effect's profile (or None), refusing a number given beside it."""
    if not p.get("profile"):
        return None
    from ...contact.profile import load_profile
    from ...errors import InputError

    given = [k for k in numbers if p.get(k) is not None]
    if given:
        raise InputError(f"give either profile or {', '.join(given)}, not both (the profile holds them)",
                         key=f"effects.{name}.{given[0]}")
    try:
        return load_profile(p["profile"])
    except InputError as exc:
        raise InputError(f"{exc}", key=f"effects.{name}.profile") from None


def _taxel_ids(ctx, n):
    """The UIDs of the scene's layout ((n,) or None when the run has no scene or another size)."""
    if ctx is None or getattr(ctx, "scene", None) is None:
        return None
    from ..sections.layout import build_layout

    ids = np.asarray(build_layout(ctx.scene).taxel_ids)
    return ids if len(ids) == n else None


class Gain:
    def __init__(self, p, ctx):
        prof = _profile(p, "gain", ("counts_per_pa", "p_half"))
        self.profile_obj = prof
        if prof is not None:
            from ...errors import InputError

            if prof.response is None:
                raise InputError(f"profile {prof.name!r} ({prof.path}) has no [response] (a transfer curve): "
                                 "calibrate it with the response fit, or give counts_per_pa", key="effects.gain.profile")
            self.counts_per_pa, self.p_half = prof.response.counts_per_pa, prof.response.p_half
        else:
            self.counts_per_pa = 0.1 if p["counts_per_pa"] is None else p["counts_per_pa"]
            self.p_half = p["p_half"]

    def counts(self, pressure):
        """Noise-free counts of ``pressure`` (Pa): the transfer curve alone (used by force control)."""
        return S.gain(pressure, self.counts_per_pa, self.p_half)

    def apply(self, state, ctx):
        f, _, st = _split(state)
        return _join(self.counts(f), st)


class Baseline:
    def __init__(self, p, ctx):
        self.profile = _profile(p, "baseline", ("offset", "spread"))
        self.offset = 0.0 if p["offset"] is None else p["offset"]
        self.spread = 0.0 if p["spread"] is None else p["spread"]
        self.rng = _rng(ctx, "baseline")
        self.ctx = ctx
        self._per_taxel = None

    def apply(self, state, ctx):
        f, _, st = _split(state)
        n = f.shape[-1]
        if self._per_taxel is None or len(self._per_taxel) != n:
            ids = _taxel_ids(self.ctx, n) if self.profile is not None else None
            if self.profile is not None:
                self._per_taxel = self.profile.per_taxel(ids, "offset") if ids is not None else \
                    np.full(n, self.profile.offset_counts)
            else:
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
        self.profile = _profile(p, "noise", ("sigma",))
        self.sigma = 20.0 if p["sigma"] is None else p["sigma"]
        self.rng = _rng(ctx, "noise")
        self.ctx = ctx
        self._per_taxel = None

    def sigmas(self, n):
        """(n,) counts: each taxel's sigma (the profile's by UID), or the scalar sigma."""
        if self.profile is None:
            return self.sigma
        if self._per_taxel is None or len(self._per_taxel) != n:
            ids = _taxel_ids(self.ctx, n)
            self._per_taxel = self.profile.per_taxel(ids, "sigma") if ids is not None else \
                np.full(n, self.profile.noise_sigma)
        return self._per_taxel

    def apply(self, state, ctx):
        f, _, st = _split(state)
        sig = self.sigmas(f.shape[-1])
        if np.ndim(sig) == 0:
            return _join(S.add_noise(f, sig, self.rng), st)
        return _join(f + self.rng.normal(0.0, 1.0, size=f.shape) * sig, st)


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


_PROFILE_FIELD = Field("str", default=None, doc="sensor profile: a shipped name (\"cyskin\") or a .toml file "
                                                 "from vtcore calibrate (measured values instead of the numbers)")

register_effect(EffectSpec("gain", "sensor", 10, Gain, Section({
    "profile": _PROFILE_FIELD,
    "counts_per_pa": Field("float", default=None, gt=0, le=MAX_GAIN,
                           doc="sensor counts per pascal (slope at 0; default 0.1)"),
    "p_half": Field("float", default=None, gt=0, le=1e12, unit="Pa",
                    doc="saturating transfer: pressure at half the ceiling (none: linear)")}),
    doc="pressure to counts (linear or saturating transfer curve)"))
register_effect(EffectSpec("baseline", "sensor", 20, Baseline, Section({
    "profile": _PROFILE_FIELD,
    "offset": Field("float", default=None, ge=-MAX_COUNTS, le=MAX_COUNTS, doc="mean offset, counts (default 0)"),
    "spread": Field("float", default=None, ge=0, le=MAX_COUNTS,
                    doc="standard deviation of the offset across taxels, counts")}),
    doc="per-taxel baseline offset"))
register_effect(EffectSpec("drift", "sensor", 30, Drift, Section({
    "rate": Field("float", default=0.5, ge=-MAX_COUNTS, le=MAX_COUNTS, doc="linear drift, counts per second"),
    "walk": Field("float", default=0.0, ge=0, le=MAX_COUNTS, doc="random-walk drift, counts per sqrt(second)")}),
    doc="slow baseline drift"))
register_effect(EffectSpec("noise", "sensor", 40, Noise, Section({
    "profile": _PROFILE_FIELD,
    "sigma": Field("float", default=None, ge=0, le=MAX_COUNTS,
                   doc="standard deviation, counts (default 20: an assumption; the measured CySkin noise is "
                       "profile = \"cyskin\")")}),
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
