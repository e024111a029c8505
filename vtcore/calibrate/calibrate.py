"""``vtcore calibrate``: a sensor profile from real recordings.

Noise first (every recording's idle frames, the clipping at 0 accounted for: see
:mod:`vtcore.calibrate.noise`), then the contact frames are found with that noise, and the
response's free parameters are fitted to their footprints (:mod:`vtcore.calibrate.response`).
The result is a profile document (:func:`vtcore.contact.profile.save_profile` writes it) whose
comments say what each value is, what it was measured on and how sure it is.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass, field

import numpy as np

from .. import __version__
from ..errors import InputError
from ..contact.profile import profile_toml
from .noise import NoiseFit, censored_normal_fit, summarise
from .recordings import (GUARD_FRAMES, K_DETECT, MIN_ACTIVE, RADIUS_M, LoadedRecording, contact_frames,
                         detection_sigma, first_baselines, idle_segments, neighbourhoods,
                         recording_baselines)


@dataclass
class NoiseCalibration:
    """What the noise stage found. fit : the per-taxel :class:`NoiseFit` (layout order).
    contacts : list of (T_i,) bool per recording. sigma : (N,) counts used for detection (the
    fit, the median where a taxel is not identified). summary : medians, IQRs and intervals.
    baselines : (R, N) counts, each recording's idle offsets (recording_baselines)."""

    fit: NoiseFit
    contacts: list
    sigma: np.ndarray
    summary: dict = field(default_factory=dict)
    baselines: np.ndarray | None = None     # (R, N) counts, each recording's idle offsets


def fit_noise(recs: list[LoadedRecording], layout, *, k: float = K_DETECT, min_active: int = MIN_ACTIVE,
              radius: float = RADIUS_M, guard: int = GUARD_FRAMES, rounds: int = 2) -> NoiseCalibration:
    """Noise of every taxel from the recordings' idle frames.

    First all frames are fitted (a press touches ~15 taxels in a third of a file's frames: it
    inflates only those taxels' first estimate), the contact frames found with that noise, then the
    noise refitted on the idle frames alone (``rounds`` times).
    """
    pos = np.asarray(layout.positions, float)
    near = neighbourhoods(pos, radius)
    # round 0: the noise of every frame, each recording's baseline from a low quantile of its own
    # readings (a press covers at most ~60 % of a file's frames, so the 30th percentile is idle)
    owners: list = []
    fit = censored_normal_fit(idle_segments(recs, [np.zeros(len(r.timestamps), bool) for r in recs], guard, owners))
    base = first_baselines(recs)
    # the pressed taxels' first sigma absorbs the press: round 0 detects with the median over taxels
    sigma = np.full(len(pos), float(np.nanmedian(fit.sigma)))
    for _ in range(max(1, rounds)):
        contacts = [contact_frames(r.counts, detection_sigma(sigma), pos, k=k, min_active=min_active,
                                   radius=radius, near=near, baseline=base[i]) for i, r in enumerate(recs)]
        owners = []
        fit = censored_normal_fit(idle_segments(recs, contacts, guard, owners))
        med = float(np.nanmedian(fit.sigma))
        sigma = np.where(np.isfinite(fit.sigma), fit.sigma, med)
        base = recording_baselines(fit, owners, len(recs), sigma)
    rng = np.random.default_rng(0)
    summary = {name: summarise(getattr(fit, name), rng) for name in ("sigma", "offset", "drift", "lag1", "censored")}
    with np.errstate(all="ignore"), warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)   # unrecorded taxels: an all-NaN column
        naive = np.concatenate([np.nanstd(r.counts[~c], axis=0) for r, c in zip(recs, contacts) if (~c).sum() > 1])
    summary["naive_std"] = summarise(naive, rng)
    summary["identified"] = int(np.isfinite(fit.sigma).sum())
    summary["recorded"] = int(np.any([r.recorded for r in recs], axis=0).sum())
    summary["idle_frames"] = int(sum((~c).sum() for c in contacts))
    summary["contact_frames"] = int(sum(c.sum() for c in contacts))
    return NoiseCalibration(fit, contacts, sigma, summary, base)


def noise_document(noise: NoiseCalibration, layout, *, name: str, sources: list[str], k: float = K_DETECT,
                   description: str = "") -> tuple[dict, dict]:
    """The ``[profile]``, ``[noise]``, ``[detection]`` and ``[taxels]`` tables and their comments."""
    s = noise.summary
    f = noise.fit
    doc = {
        "profile": {"name": name, "version": 1, "description": description or
                    f"measured by vtcore calibrate {__version__}", "source": "; ".join(sources)},
        "noise": {
            "sigma_counts": round(s["sigma"]["median"], 2),
            "sigma_counts_iqr": [round(x, 2) for x in s["sigma"]["iqr"]],
            "sigma_counts_ci95": [round(x, 2) for x in s["sigma"]["ci95"]],
            "clip_counts": 0.0,
            "offset_counts": round(s["offset"]["median"], 2),
            "drift_counts_per_s": round(s["drift"]["median"], 3),
            "lag1_correlation": round(s["lag1"]["median"], 4),
            "naive_std_counts": round(s["naive_std"]["median"], 2),
            "taxels_identified": s["identified"], "taxels_recorded": s["recorded"],
            "idle_frames": s["idle_frames"], "contact_frames": s["contact_frames"],
        },
        "detection": {"k": float(k), "min_active": MIN_ACTIVE, "radius_m": RADIUS_M},
        "taxels": {
            "uid": [int(u) for u in np.asarray(layout.taxel_ids)],
            "sigma_counts": [round(float(v), 2) for v in f.sigma],
            "offset_counts": [round(float(v), 2) for v in f.offset],
            "drift_counts_per_s": [round(float(v), 3) for v in f.drift],
        },
    }
    comments = {
        "profile": "A vtcore sensor profile (docs/contact.md, 'Sensor profiles'). Written by vtcore calibrate.",
        "noise": ("Read noise of idle taxels: per-taxel censored-normal (Tobit) maximum-likelihood fit, the\n"
                  "recorder's clipping at 0 accounted for (vtcore.calibrate.noise). Medians over taxels;\n"
                  "_iqr: the spread across taxels; _ci95: bootstrap interval of the median.\n"
                  f"naive_std_counts: the plain std of the same clipped samples ({s['naive_std']['median']:.0f}), "
                  "shown to say why it is not used.\n"
                  f"drift: within-file slope (files are ~3 s: per taxel it is known to ~{np.nanmedian(f.drift_se):.0f}"
                  " counts/s only);\nlag1: lag-1 correlation of the unclipped noise (white when ~0)."),
        "detection": "A taxel is active above k of its noise deviations; a frame is a contact frame when at\n"
                     "least min_active taxels within radius_m of its strongest taxel are active.",
        "taxels": ("Per recorded taxel (UID order of the calibration layout). nan: not identified (the taxel\n"
                   "reads 0 nearly always: its offset lies below about -2 sigma); layouts use the medians there."),
    }
    return doc, comments


def document_text(doc: dict, comments: dict) -> str:
    """The profile as TOML text (what ``--out`` receives)."""
    return profile_toml(doc, comments)


@dataclass
class Calibration:
    """The outcome of :func:`calibrate`: the profile document, its comments, and what was found."""

    doc: dict
    comments: dict
    noise: NoiseCalibration
    response: object = None

    def summary_lines(self) -> list[str]:
        s = self.noise.summary
        out = [f"noise: sigma median {s['sigma']['median']:.1f} counts (IQR {s['sigma']['iqr'][0]:.0f}-"
               f"{s['sigma']['iqr'][1]:.0f}, 95 % CI of the median {s['sigma']['ci95'][0]:.0f}-"
               f"{s['sigma']['ci95'][1]:.0f}) over {s['identified']} of {s['recorded']} recorded taxels; "
               f"naive std of the clipped samples {s['naive_std']['median']:.0f}",
               f"frames: {s['idle_frames']} idle, {s['contact_frames']} contact"]
        if self.response is not None:
            out += self.response.summary_lines()
        return out


def recording_name(path) -> str:
    """How a profile names a recording: its folder and file (``1_finger/sample_12.txt``)."""
    from pathlib import Path

    return "/".join(Path(path).parts[-2:])


def calibrate(paths, layout, *, name: str | None = None, k: float = K_DETECT, response: bool = True, warn=None,
              holdout=()) -> Calibration:
    """Fit a sensor profile to CySkin text recordings on ``layout``.

    paths : recording files (untouched and touched alike: the noise comes from every idle frame,
    the response from the contact frames). holdout : recordings left out of the whole calibration
    (named in the profile's ``[response] held_out``, so ``vtcore validate`` reports them apart).
    """
    from pathlib import Path

    from .recordings import load_recordings

    held = {str(Path(h).resolve()) for h in holdout}
    use = [p for p in paths if str(Path(p).resolve()) not in held]
    if not use:
        raise InputError("every recording is held out: nothing to calibrate on", key="--holdout")
    recs = load_recordings(use, layout, warn=warn)
    noise = fit_noise(recs, layout, k=k)
    doc, comments = noise_document(noise, layout, name=name or "profile",
                                   sources=["/".join(Path(p).parts[-3:]) for p in use], k=k)
    resp = None
    if response:
        from .response import fit_response

        resp = fit_response(recs, noise.contacts, layout, noise.fit.sigma, noise.baselines, k=k)
        doc["response"], comments["response"] = resp.table(held_out=sorted(recording_name(h) for h in holdout))
    return Calibration(doc, comments, noise, resp)
