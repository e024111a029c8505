"""The sensor's noise and gain as a design map needs them: counts per pascal, noise sigma, k.

The values come from the shipped CySkin sensor profile (``vtcore.contact.profile.load_profile``)
when this vtcore has it; otherwise from the measurement the profile is built on, named as the
source: the median per-taxel noise of the untouched CySkin recordings (shared/data/cyskin_gesture,
about 180 counts, interquartile range 90-310) and the five noise deviations a finger lights
taxels above there.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import InputError

#: Fallbacks while no sensor profile is available (see the module docstring for their sources).
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

    sigma : counts, per-taxel noise standard deviation. k : noise deviations. counts_per_pa : linear
    gain (counts / Pa). source : where each number came from (shown in every report).
    """

    sigma: float = MEASURED_SIGMA_COUNTS
    k: float = DEFAULT_K
    counts_per_pa: float = DEFAULT_GAIN
    source: str = ""

    def __post_init__(self):
        for name, lo in (("sigma", 0.0), ("k", 0.0), ("counts_per_pa", 0.0)):
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
        """The same at the taxel, as stress (Pa)."""
        return self.threshold_counts / self.counts_per_pa


def sensor_noise(sigma: float | None = None, k: float | None = None, counts_per_pa: float | None = None,
                 profile: str | None = "cyskin") -> SensorNoise:
    """A :class:`SensorNoise` from the named sensor profile where this vtcore ships one, each value
    overridable; what was not given and has no profile falls back to the measured numbers."""
    prof, why = None, ""
    if profile:
        try:
            from ..contact.profile import load_profile  # the sensor profile (issue 27)
        except ImportError:
            why = "no sensor profile module in this vtcore"
        else:
            prof = load_profile(profile)
    parts = []

    def pick(given, names, fallback, fallback_src, label):
        if given is not None:
            parts.append(f"{label}: given")
            return float(given)
        for name in names:
            v = getattr(prof, name, None) if prof is not None else None
            if v is not None:
                parts.append(f"{label}: sensor profile {profile!r} ({name})")
                return float(v)
        parts.append(f"{label}: {fallback_src}" + (f" [{why}]" if why and prof is None else ""))
        return fallback

    s = pick(sigma, ("noise_sigma", "noise_sigma_counts", "sigma"), MEASURED_SIGMA_COUNTS, MEASURED_SOURCE,
             "noise sigma")
    kk = pick(k, ("detection_k", "k"), DEFAULT_K, DEFAULT_K_SOURCE, "k")
    g = pick(counts_per_pa, ("counts_per_pa", "gain"), DEFAULT_GAIN, DEFAULT_GAIN_SOURCE, "gain")
    return SensorNoise(s, kk, g, "; ".join(parts))
