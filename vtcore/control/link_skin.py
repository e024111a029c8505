"""The skin on the reaching link (seed 000, Sect. 4.3): contact force, taxel counts, contact intensity.

Seed 000's reaching robot carries "an extra link mounted on the end-effector which is
fully covered with the tactile sensors" and compares controllers by "the mean exchanged
contact intensity as measured by the tactile sensors". This module models that skin so
the comparison is in skin counts, as the paper's, not in newtons:

- **Geometry.** A vertical cylindrical link of outer radius ``radius`` (skin surface),
  CySkin taxels (``taxel_radius``, ``pitch``) in rings around it, ``rows`` rings over the
  ``length`` that meets the (vertical, taller) obstacles. The obstacles are vertical too, so
  every contact is a line contact along the link: all rows read the same.
- **Contact.** The soft layer (``thickness``, plane-strain modulus ``e_star``) is the
  Winkler (local) model the contact package uses for thin layers, ``p = E*/h * compression``.
  Against an obstacle of radius ``R_o`` (a pole; ``inf`` for a flat face; a small radius at
  a box corner) the compression across the contact is ``delta - s^2 / (2 R_eff)`` with
  ``1/R_eff = 1/R_link + 1/R_o``, so the line force is ``F = C delta^1.5``,
  ``C = (E*/h) L (4/3) sqrt(2 R_eff)``. The obstacle's own stiffness ``k_o`` is in series:
  a geometric overlap ``pen`` splits into ``delta`` and the obstacle's deflection, with
  ``k_o (pen - delta) = C delta^1.5`` (:class:`ContactLaw`, tabulated once per obstacle).
- **Reading.** A taxel at arc distance ``s`` from the contact line reads the mean pressure
  over its disc, ``E*/h (delta - (s^2 + r_t^2/4) / (2 R_eff))`` (the parabola averaged over
  a disc of radius ``r_t``), times the sensor gain, clipped to the 16-bit range; the skin
  adds its read noise (the measured CySkin sigma) and clips at 0 like the real read-out, at
  CySkin's 20 Hz. **Contact intensity** of a frame is the sum of the counts of the taxels
  above ``detect_k`` noise deviations (below that a real skin cannot tell contact from noise).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..errors import InputError

#: radius of curvature (m) taken for a box's vertical edge (a sponge prism's corner is not a knife)
CORNER_RADIUS = 0.002
#: m: the link radius and skin length accepted (a finger's to a robot arm's; 1e308 made the ring count
#: int(inf), a kilometre a skin of 1e11 taxels)
SIZE_M = (1e-3, 2.0)


@dataclass
class ContactLaw:
    """Normal force (N) of the link's skin against one obstacle as a function of the overlap (m).

    Built by :meth:`LinkSkin.law`; ``force(pen)`` and ``stiffness(pen)`` (dF/dpen, N/m) are
    monotone piecewise-linear interpolations of the exact series solution; ``compression(pen)``
    is the layer's share ``delta`` (m).
    """

    pen: np.ndarray
    delta: np.ndarray
    f: np.ndarray
    r_eff: float

    def force(self, pen: float) -> float:
        return float(np.interp(pen, self.pen, self.f, left=0.0, right=np.nan)) if pen > 0 else 0.0

    def stiffness(self, pen: float) -> float:
        if pen <= 0:
            return 0.0
        j = int(np.clip(np.searchsorted(self.pen, pen) - 1, 0, len(self.pen) - 2))
        return float((self.f[j + 1] - self.f[j]) / (self.pen[j + 1] - self.pen[j]))

    def compression(self, pen: float) -> float:
        return float(np.interp(pen, self.pen, self.delta, left=0.0)) if pen > 0 else 0.0


@dataclass
class LinkSkin:
    """A skin-covered cylindrical link; see the module docstring.

    radius : m, outer (skin surface) radius. length : m of the link that meets the obstacles.
    pitch, taxel_radius : m (CySkin: 7.5 mm, 2 mm). thickness : m of the soft layer over the
    taxels; e_star : Pa, its plane-strain modulus. counts_per_pa : sensor gain. max_counts :
    the converter's ceiling. noise : counts, per-taxel read noise. detect_k : noise deviations
    of a taxel that counts as touched. rate : Hz, skin frames.
    """

    radius: float = 0.025
    length: float = 0.05
    pitch: float = 0.0075
    taxel_radius: float = 0.002
    thickness: float = 0.003
    e_star: float = 8 * 6894.757 / (1 - 0.49 ** 2)     # Ecoflex 00-20 (vtcore.contact.materials)
    counts_per_pa: float = 2.0
    max_counts: float = 65535.0
    noise: float = 180.0
    detect_k: float = 5.0
    rate: float = 20.0
    angles: np.ndarray = field(init=False, repr=False)

    def __post_init__(self):
        for key in ("radius", "length", "pitch", "taxel_radius", "thickness", "e_star", "counts_per_pa",
                    "max_counts", "rate"):
            v = float(getattr(self, key))
            if not (np.isfinite(v) and v > 0):
                raise InputError(f"must be > 0, got {v}", key=key)
        for key in ("radius", "length"):
            v = float(getattr(self, key))
            if not SIZE_M[0] <= v <= SIZE_M[1]:
                raise InputError(f"must be {SIZE_M[0]:g} .. {SIZE_M[1]:g} m (a robot link's skin), got {v:g}", key=key)
        if not (self.noise >= 0 and self.detect_k >= 0):
            raise InputError("noise and detect_k must be >= 0", key="noise")
        n = max(3, int(round(2 * np.pi * self.radius / self.pitch)))
        self.angles = 2 * np.pi * np.arange(n) / n

    @property
    def rows(self) -> int:
        """Rings of taxels along the contact length."""
        return max(1, int(self.length // self.pitch))

    @property
    def taxels(self) -> int:
        return self.rows * len(self.angles)

    @property
    def winkler(self) -> float:
        """Pa per metre of layer compression (E*/h)."""
        return self.e_star / self.thickness

    def compression_counts(self, fraction: float) -> float:
        """Counts a taxel reads where the layer is compressed by ``fraction`` of its thickness."""
        return min(self.counts_per_pa * self.e_star * float(fraction), self.max_counts)

    def law(self, k_obstacle: float, r_obstacle: float = np.inf) -> ContactLaw:
        """The force-overlap law against an obstacle of stiffness ``k_obstacle`` (N/m) and radius
        ``r_obstacle`` (m, ``inf`` for a flat face), up to a layer compressed to 95 % (beyond
        that the taxels would touch the obstacle through nothing: NaN, and the caller says so)."""
        if not (np.isfinite(k_obstacle) and k_obstacle > 0):
            raise InputError(f"obstacle stiffness must be > 0 N/m, got {k_obstacle}", key="stiffness")
        r_eff = 1.0 / (1.0 / self.radius + (0.0 if np.isinf(r_obstacle) else 1.0 / float(r_obstacle)))
        c = self.winkler * self.length * (4.0 / 3.0) * np.sqrt(2.0 * r_eff)
        delta = np.concatenate([[0.0], np.geomspace(1e-9, 0.95 * self.thickness, 400)])
        f = c * delta ** 1.5
        pen = delta + f / float(k_obstacle)
        return ContactLaw(pen=pen, delta=delta, f=f, r_eff=r_eff)

    def pressures(self, contacts) -> np.ndarray:
        """Mean pressure (Pa) on each taxel of one ring, ``(A,)``, for ``contacts``: a list of
        ``(angle rad of the contact line on the link, delta m, r_eff m)``; pressures add."""
        p = np.zeros(len(self.angles))
        for ang, delta, r_eff in contacts:
            if delta <= 0:
                continue
            d = np.angle(np.exp(1j * (self.angles - ang)))          # wrapped to (-pi, pi]
            s2 = (self.radius * d) ** 2 + self.taxel_radius ** 2 / 4
            p += self.winkler * np.clip(delta - s2 / (2 * r_eff), 0.0, None)
        return p

    def counts(self, contacts) -> np.ndarray:
        """Noise-free counts of one ring (A,): gain times pressure, clipped to the converter's range."""
        return np.clip(self.counts_per_pa * self.pressures(contacts), 0.0, self.max_counts)

    def read(self, ring_counts, rng) -> np.ndarray:
        """A skin frame ``(rows, A)``: every ring reads ``ring_counts`` plus independent read noise,
        clipped at 0 and at the ceiling, rounded (the real read-out)."""
        frame = np.broadcast_to(ring_counts, (self.rows, len(self.angles)))
        if self.noise > 0:
            frame = frame + rng.normal(0.0, self.noise, frame.shape)
        return np.round(np.clip(frame, 0.0, self.max_counts))

    def intensity(self, frame) -> float:
        """Contact intensity of a frame: summed counts of the taxels above the detection threshold."""
        f = np.asarray(frame, float)
        return float(f[f > self.detect_k * self.noise].sum()) if self.noise > 0 else float(f[f > 0].sum())

    def touched(self, frame) -> np.ndarray:
        """Per angle (A,), the counts of the ring's taxels above the detection threshold, summed over rows."""
        f = np.asarray(frame, float)
        thr = self.detect_k * self.noise if self.noise > 0 else 0.0
        return np.where(f > thr, f, 0.0).sum(axis=0)

    def contacts(self, frame) -> list[tuple[np.ndarray, float, float]]:
        """The separate contacts a frame shows: ``[(unit vector (2,) from the axis towards the touched
        side, intensity counts, peak taxel counts)]``, one per circular run of touched angles (two
        obstacles touching opposite sides are two contacts, not one that cancels)."""
        w = self.touched(frame)
        peak = np.asarray(frame, float).max(axis=0)
        on = w > 0
        if not on.any():
            return []
        if on.all():
            runs = [np.arange(len(w))]
        else:
            start = int(np.flatnonzero(~on)[0])                  # rotate so that a run never wraps
            order = np.roll(np.arange(len(w)), -start)
            edges = np.flatnonzero(np.diff(np.concatenate([[0], on[order].astype(int), [0]])))
            runs = [order[a:b] for a, b in zip(edges[::2], edges[1::2])]
        out = []
        for idx in runs:
            v = np.array([np.sum(w[idx] * np.cos(self.angles[idx])), np.sum(w[idx] * np.sin(self.angles[idx]))])
            n = float(np.hypot(*v))
            if n > 0:
                out.append((v / n, float(w[idx].sum()), float(peak[idx].max())))
        return out
