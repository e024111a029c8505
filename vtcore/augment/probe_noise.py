"""What a real probe adds to Eq. 1: skin noise, robot position noise, late contact detection.

Seed 000 measures ``c = p̄ / ||v_ss - v||`` (Eq. 1) with a real robot and a real skin.
The displacement is small on stiff objects (0.3-0.6 mm through the skin's soft layer),
so micrometres of error matter. This module states the error model of one touch and
what happens to a touch whose measured displacement comes out non-physical.

The model (each number is an assumption or a measurement, named as such):

- **skin noise** (measurement): the per-taxel read noise of a real CySkin skin, from the
  sensor profile (``vtcore.contact.profile.load_profile("cyskin")``) where it exists, else
  the median of ~180 counts measured on the untouched recordings of
  ``shared/data/cyskin_gesture`` (README there). It enters p̄ through the scene's sensor
  effects; here it sets the contact-detection threshold.
- **contact detection** (model): the robot approaches along ``-n`` at ``approach_speed``
  and declares contact at the first skin frame (``read_rate``, CySkin's 20 Hz) whose mean
  over the module's ``taxels`` exceeds ``detect_k`` noise deviations of that mean. The
  displacement counted from there misses what was pressed before the threshold (assuming
  p̄ grows linearly with displacement: ``disp * threshold / p̄``) and the travel between
  the threshold crossing and the next frame (uniform in ``[0, approach_speed / read_rate]``).
- **robot position** (assumption): each of the two positions (at detection, at steady
  state) is measured with Gaussian error ``position_sigma`` (50 micrometres by default:
  the order of a Franka Panda's pose repeatability, 0.1 mm).

A touch whose measured displacement is at or below ``min_displacement`` (or not finite)
is non-physical for Eq. 1. The scene tasks set it to what this measurement reads, on
average, for the skin's soft layer alone pressed to p̄* on a rigid flat plate
(:func:`rigid_floor` through :meth:`ProbeNoise.expected`, a calibration a real robot can
make too): no object, however stiff, gives less, so a smaller reading (a colour above a
rigid object's) is the noise's, not the object's. It is **repeated** (the robot backs off and touches again:
fresh detection and position errors) up to ``retries`` times; if it never comes out
physical it is **rejected**, and the caller samples another contact point. Both are
counted; neither stops a scan.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import InputError
from .compliance import MIN_DISPLACEMENT

#: the measured median per-taxel noise (counts) of a real CySkin skin, used until a sensor
#: profile gives it: shared/data/cyskin_gesture/README.md (untouched recordings, IQR 90-310)
CYSKIN_NOISE_COUNTS = 180.0
CYSKIN_NOISE_SOURCE = ("median per-taxel standard deviation of the untouched CySkin recordings in "
                       "shared/data/cyskin_gesture (README: ~180 counts, IQR 90-310)")
#: noise deviations above which a reading counts as contact, when no profile gives one
DETECT_K = 5.0


@dataclass(frozen=True)
class SkinNoise:
    """Per-taxel read noise of the skin. sigma : counts (one reading of one taxel);
    detect_k : noise deviations of a contact threshold; source : where the numbers come from."""

    sigma: float
    detect_k: float
    source: str

    def mean_sigma(self, taxels: int) -> float:
        """Standard deviation (counts) of the mean of ``taxels`` loaded taxels (independent noise)."""
        return self.sigma / np.sqrt(max(int(taxels), 1))


def skin_noise(profile: str = "cyskin") -> SkinNoise:
    """The measured noise of a real skin: from the sensor profile ``profile`` when the package
    ships a loader for it (``vtcore.contact.profile``), else the measured CySkin median."""
    try:
        from ..contact.profile import load_profile
    except ImportError:
        return SkinNoise(CYSKIN_NOISE_COUNTS, DETECT_K, CYSKIN_NOISE_SOURCE)
    prof = load_profile(profile)
    return SkinNoise(float(prof.noise_sigma), float(prof.detection_k),
                     f"sensor profile {prof.name!r} (median per-taxel sigma, clipping at 0 accounted for, fitted "
                     f"on the untouched recordings of shared/data/cyskin_gesture)")


@dataclass
class ProbeNoise:
    """The error model of one touch (see the module docstring).

    position_sigma : m, per measured robot position. approach_speed : m/s. read_rate : Hz.
    detect_counts : counts, the contact threshold on p̄ (``detect_k * sigma / sqrt(taxels)``
    of the skin's noise, :meth:`from_skin`). retries : how many times a non-physical touch is
    repeated before it is rejected. min_displacement : m, at or below it a measured
    displacement is non-physical (see the module docstring).
    """

    position_sigma: float = 50e-6
    approach_speed: float = 2e-3
    read_rate: float = 20.0
    detect_counts: float = 0.0
    retries: int = 2
    min_displacement: float = MIN_DISPLACEMENT

    def __post_init__(self):
        for key in ("position_sigma", "approach_speed", "detect_counts", "min_displacement"):
            v = getattr(self, key)
            if not (np.isfinite(v) and v >= 0):
                raise InputError(f"must be a finite number >= 0, got {v}", key=key)
        if not (np.isfinite(self.read_rate) and self.read_rate > 0):
            raise InputError(f"must be > 0 Hz, got {self.read_rate}", key="read_rate")
        if int(self.retries) < 0:
            raise InputError(f"must be >= 0, got {self.retries}", key="retries")

    @classmethod
    def from_skin(cls, skin: SkinNoise, taxels: int = 10, **kw) -> "ProbeNoise":
        """The detection threshold of a ``taxels``-taxel module with the skin's measured noise."""
        return cls(detect_counts=skin.detect_k * skin.mean_sigma(taxels), **kw)

    @property
    def latency_travel(self) -> float:
        """Metres the probe can travel between the threshold crossing and the frame that sees it."""
        return self.approach_speed / self.read_rate

    def expected(self, disp, p_mean):
        """The mean measured displacement (m) of a touch whose true one is ``disp`` at ``p_mean`` counts:
        less the part pressed before the threshold and half the latency travel (position noise is
        zero-mean)."""
        return float(disp) * (1.0 - min(self.detect_counts / float(p_mean), 1.0)) - 0.5 * self.latency_travel

    def _draw(self, disp, p_mean, rng):
        """One measurement of each touch: (n,) metres."""
        p = np.asarray(p_mean, float)
        with np.errstate(divide="ignore", invalid="ignore"):
            missed = np.where(p > 0, disp * np.minimum(self.detect_counts / p, 1.0), np.nan)
        late = rng.uniform(0.0, self.latency_travel, len(disp))
        err = rng.normal(0.0, self.position_sigma, (2, len(disp)))
        return disp - missed - late + (err[1] - err[0])

    def measure(self, disp, p_mean, rng):
        """Measured displacements of touches whose true displacement is ``disp`` (n,) m at p̄ ``p_mean``.

        Returns ``(measured (n,) m, repeats (n,) int, ok (n,) bool)``: ``ok`` is False for a
        touch still non-physical after ``retries`` repeats (its measured value is NaN then).
        """
        rng = np.random.default_rng(rng)
        disp = np.asarray(disp, float).reshape(-1)
        out = self._draw(disp, p_mean, rng)
        repeats = np.zeros(len(disp), dtype=np.int64)
        p = np.broadcast_to(np.asarray(p_mean, float), disp.shape)
        for _ in range(int(self.retries)):
            bad = ~(np.isfinite(out) & (out > self.min_displacement))
            if not bad.any():
                break
            repeats[bad] += 1
            out[bad] = self._draw(disp[bad], p[bad], rng)
        ok = np.isfinite(out) & (out > self.min_displacement)
        return np.where(ok, out, np.nan), repeats, ok


def rigid_floor(probe_fn) -> float:
    """Displacement (m) of a probe pressed to its target on a rigid flat plate: its skin's layer alone.

    probe_fn : ``(points (n, 3), normals (n, 3)) -> (p_mean (n,), v_ss (n, 3))`` built for a rigid
    plate whose top face is z = 0 (a :class:`~vtcore.augment.probing.ContactProber` of
    :func:`rigid_plate`), or any probe of the same shape.
    """
    v, n = np.zeros((1, 3)), np.array([[0.0, 0.0, 1.0]])
    p, v_ss = probe_fn(v, n)
    d = float((v - np.asarray(v_ss, float))[0] @ n[0])
    if not (np.isfinite(p[0]) and np.isfinite(d) and d > 0):
        raise InputError(f"the probe did not reach its target on a rigid plate (displacement {d} m)", key="target")
    return d


def rigid_plate(size: float = 0.2):
    """A rigid flat plate (its own stiffness 1e12 N/m), top face at z = 0, as a CompliantObject."""
    import trimesh

    from .objects import CompliantObject

    mesh = trimesh.creation.box(extents=[size, size, 0.02])
    mesh.apply_translation([0.0, 0.0, -0.01])
    return CompliantObject("rigid_plate", mesh, lambda p: np.full(len(np.atleast_2d(p)), 1e12),
                           lambda p: np.full(len(np.atleast_2d(p)), 0.5))
