"""The sensor's noise and gain as a design map needs them: counts per pascal, noise sigma, k.

The values come from a sensor profile (``vtcore.contact.profile.load_profile``; the shipped
``"cyskin"`` one by default: the median per-taxel noise of the idle CySkin recordings with their
clipping at 0 accounted for, 191 counts, and its detection k, 5); the gain from the profile's fitted
``[response]`` where it has one, else vtcore's default linear gain, named as an assumption. Every
value can be given instead, and the report says where each came from.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..contact.sensor import MAX_COUNTS
from ..errors import InputError

#: Fallbacks where no profile is named (``profile=None``) or it lacks the value.
MEASURED_SIGMA_COUNTS = 180.0
MEASURED_SOURCE = ("median per-taxel noise of the untouched CySkin recordings "
                   "(shared/data/cyskin_gesture/README.md, 0_finger)")
DEFAULT_K = 5.0
DEFAULT_K_SOURCE = "five noise deviations (the level a finger lights 9-10 taxels above, cyskin_gesture README)"
#: counts per pascal of the add-on's and the demo's linear gain (an assumption: the papers give none)
DEFAULT_GAIN = 0.1
DEFAULT_GAIN_SOURCE = "vtcore's default linear gain (assumption; the papers give no transfer curve)"


@dataclass
class SensorNoise:
    """What decides detection: a taxel detects when its reading exceeds ``k * sigma`` counts.

    sigma : counts, per-taxel noise standard deviation. k : noise deviations. counts_per_pa : the
    transfer's slope at 0 (counts / Pa). p_half : Pa or None: a saturating transfer that reaches half its
    ceiling there (vtcore.contact.sensor.gain), None: linear. source : where each number came from.
    max_counts : the read-out's ceiling (the AD7147's 16-bit range, as Simulate and the scene's sensor
    clip): a reading never exceeds it, so a press that drives taxels past it reads a flat top.
    """

    sigma: float = MEASURED_SIGMA_COUNTS
    k: float = DEFAULT_K
    counts_per_pa: float = DEFAULT_GAIN
    source: str = ""
    p_half: float | None = None
    max_counts: float = MAX_COUNTS

    def __post_init__(self):
        if self.p_half is not None and not (np.isfinite(self.p_half) and self.p_half > 0):
            raise InputError(f"must be a finite number > 0 Pa, got {self.p_half}", key="sensor.p_half")
        for name, lo in (("sigma", 0.0), ("k", 0.0), ("counts_per_pa", 0.0), ("max_counts", 0.0)):
            v = float(getattr(self, name))
            if not (np.isfinite(v) and v > lo) and not (name == "sigma" and v == 0):
                raise InputError(f"must be a finite number > {lo:g}, got {v}", key=f"sensor.{name}")
            setattr(self, name, v)

    @property
    def threshold_counts(self) -> float:
        """Reading a taxel must exceed to detect, counts (k sigma; 1 count without noise)."""
        return self.k * self.sigma if self.sigma > 0 else 1.0

    @property
    def threshold_pa(self) -> float:
        """The same at the taxel, as stress (Pa): the transfer's inverse at k sigma (``inf`` where a
        saturating transfer's ceiling stays below it: no stress is ever detected)."""
        return self.pa_at(self.threshold_counts)

    def pa_at(self, counts: float) -> float:
        """The stress (Pa) a taxel must bear to read ``counts`` on average: the transfer's inverse (0 for
        counts <= 0; ``inf`` at or beyond the read-out's or the saturating transfer's ceiling)."""
        t = float(counts)
        if t <= 0:
            return 0.0
        if t >= self.max_counts:
            return float("inf")
        if self.p_half is None:
            return t / self.counts_per_pa
        ceiling = self.counts_per_pa * self.p_half
        return t * self.p_half / (ceiling - t) if ceiling > t else float("inf")

    def counts(self, pressure):
        """Mean readings (counts) of taxel stresses ``pressure`` (Pa, any shape): the sensor's transfer, up to
        the read-out's ceiling."""
        from ..contact.sensor import gain

        return np.minimum(gain(pressure, self.counts_per_pa, self.p_half), self.max_counts)


def sensor_noise(sigma: float | None = None, k: float | None = None, counts_per_pa: float | None = None,
                 profile: str | None = "cyskin") -> SensorNoise:
    """A :class:`SensorNoise` from sensor profile ``profile`` (a name of a shipped profile or a file;
    None: none), each value overridable; what neither gives falls back to the numbers above."""
    from ..contact.profile import load_profile

    prof = load_profile(profile) if profile else None
    name = getattr(prof, "name", profile)
    response = getattr(prof, "response", None)
    parts = []

    def pick(given, value, what, fallback, fallback_src, label):
        if given is not None:
            parts.append(f"{label} {float(given):g}: given")
            return float(given)
        if value is not None:
            parts.append(f"{label} {float(value):g}: sensor profile {name!r} ({what})")
            return float(value)
        parts.append(f"{label} {fallback:g}: {fallback_src}")
        return fallback

    s = pick(sigma, getattr(prof, "noise_sigma", None), "median per-taxel noise, clipping accounted for",
             MEASURED_SIGMA_COUNTS, MEASURED_SOURCE, "noise sigma (counts)")
    kk = pick(k, getattr(prof, "detection_k", None), "detection k", DEFAULT_K, DEFAULT_K_SOURCE, "k")
    g = pick(counts_per_pa, getattr(response, "counts_per_pa", None), "fitted response", DEFAULT_GAIN,
             DEFAULT_GAIN_SOURCE, "gain (counts/Pa)")
    # the fitted transfer's saturation goes with the fitted gain only
    p_half = getattr(response, "p_half", None) if counts_per_pa is None else None
    if p_half is not None:
        parts.append(f"saturating at p_half {float(p_half):g} Pa: sensor profile {name!r} (fitted response)")
    return SensorNoise(s, kk, g, "; ".join(parts), None if p_half is None else float(p_half))
