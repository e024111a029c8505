"""``vtcore validate``: simulated presses matched to recorded ones, compared footprint by footprint.

For every recording: its contact frames (the rule of :mod:`vtcore.calibrate.recordings`, with the
profile's per-taxel noise), its idle baseline per taxel (a censored fit of its idle frames), the
pose of each frame's press (:mod:`vtcore.calibrate.simulate`), the force that reproduces each
frame's recorded peak, and the simulated counts: the transfer curve, the recording's own baseline,
the profile's noise, the clip at 0 and integer counts. Both sides then go through the same
footprint statistics (:mod:`vtcore.calibrate.footprint`).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..errors import InputError
from .footprint import METRICS, footprint_metrics
from .recordings import detect_contacts, detection_sigma, load_recordings
from .simulate import LADDER_N, MatchedPress, at_forces, force_for_peak, frame_poses, recording_pose

from ..contact.materials import LARGE_COMPRESSION


@dataclass
class Sensor:
    """The read-out a validation simulates: ``gain(pressure) -> counts`` (noise-free transfer),
    ``sigma`` (N,) counts, the clip range and the quantisation step (0: none)."""

    gain: object
    sigma: np.ndarray
    clip: tuple = (0.0, 65535.0)
    step: float = 1.0


@dataclass
class Validation:
    """Arrays (layout order): real, sim (K, N) counts (NaN where not recorded), pressure (K, N) Pa,
    force (K,) N, compression (K,) share of the thickness, recording (K,) int, frame (K,) int,
    held_out (K,) bool, baselines (R, N) counts. metrics: the flat result metrics. paths: (R,)."""

    real: np.ndarray
    sim: np.ndarray
    pressure: np.ndarray
    force: np.ndarray
    compression: np.ndarray
    recording: np.ndarray
    frame: np.ndarray
    held_out: np.ndarray
    baselines: np.ndarray
    paths: list
    real_metrics: dict
    sim_metrics: dict
    metrics: dict = field(default_factory=dict)
    warnings: list = field(default_factory=list)


def _matches(path: str, names) -> bool:
    """Whether ``path`` ends with one of ``names`` (relative names such as 1_finger/sample_12.txt)."""
    p = Path(path).resolve().as_posix()
    return any(p.endswith("/" + Path(n).as_posix().lstrip("./")) or p == Path(n).resolve().as_posix()
               for n in names)


def summarise_metrics(m: dict, sel, prefix: str) -> dict:
    """``{prefix_metric_median, _q25, _q75}`` of the frames ``sel`` (K,) bool."""
    out = {}
    for name in METRICS:
        v = np.asarray(m[name], float)[sel]
        v = v[np.isfinite(v)]
        q = np.percentile(v, [25, 50, 75]) if len(v) else [np.nan] * 3
        out.update({f"{prefix}_{name}_q25": float(q[0]), f"{prefix}_{name}_median": float(q[1]),
                    f"{prefix}_{name}_q75": float(q[2])})
    return out


def validate(paths, layout, *, layer, indenter: dict, sensor: Sensor, rng, k: float = 5.0, conform: bool = True,
             held_out=(), grid=None, samples_per_taxel: int = 7, warn=None, progress=None) -> Validation:
    """Simulate every contact frame of the recordings ``paths`` on ``layout`` (see the module docstring).

    layer : SoftLayer; indenter : make_object dict; sensor : :class:`Sensor`; rng : numpy Generator
    (the simulated noise). held_out : names (path endings) of recordings the calibration did not see.
    Raises InputError when no recording has a contact frame (naming the files).
    """
    from .._progress import progress as bar

    recs = load_recordings(list(paths), layout, warn=warn)
    pos = np.asarray(layout.positions, float)
    sig = np.asarray(sensor.sigma, float)
    det = detection_sigma(sig)
    contacts, base = detect_contacts(recs, sig, pos, k=k)
    none = [r.path for r, c in zip(recs, contacts) if not c.any()]
    if len(none) == len(recs):
        raise InputError(f"no contact frame in {', '.join(none[:4])}{' ...' if len(none) > 4 else ''}: no frame has "
                         f"3 taxels above {k:g} noise deviations within 30 mm of its strongest taxel (an idle "
                         "recording? validate needs presses)", key="RECORDING")
    warnings = [f"{p}: no contact frame, skipped" for p in none]
    mp = MatchedPress(layout, layer, indenter, conform=conform, grid=grid, samples_per_taxel=samples_per_taxel)
    rows = {k_: [] for k_ in ("real", "sim", "pressure", "force", "compression", "recording", "frame")}
    todo = [i for i, c in enumerate(contacts) if c.any()]
    for i in bar(todo, desc="validate: recordings", total=len(todo), unit="recording"):
        r, c = recs[i], contacts[i]
        idx = np.flatnonzero(c)
        real = r.counts[idx]
        poses = frame_poses(np.where(np.isfinite(real), real, np.nan), layout, det, k)
        ref = recording_pose(poses, layout)
        fs, ps, comp = mp.ladder(ref, LADDER_N)
        if len(fs) < 2:
            warnings.append(f"{r.path}: the layer bottoms out below {LADDER_N[1]} N at this pose; skipped")
            continue
        peaks = sensor.gain(ps).max(axis=1)
        pk = np.nanargmax(np.where(np.isfinite(real), real, -np.inf), axis=1)
        target = np.nanmax(real, axis=1) - np.maximum(base[i][pk], 0.0)
        f_star, ok = force_for_peak(fs, peaks, target)
        if not ok.all():
            warnings.append(f"{r.path}: {int((~ok).sum())} frame(s) outside the force ladder "
                            f"({fs[0]:g}-{fs[-1]:g} N): pressed at its end")
        p_k, c_k = at_forces(fs, ps, comp, f_star)
        rows["real"] += list(real)
        rows["pressure"] += list(p_k)
        rows["force"] += list(f_star)
        rows["compression"] += list(c_k)
        rows["recording"] += [i] * len(idx)
        rows["frame"] += [int(j) for j in idx]
        if progress is not None:
            progress()
    if not rows["real"]:
        raise InputError("no contact frame could be simulated (see the warnings)", key="RECORDING")
    real = np.asarray(rows["real"], float)
    pressure = np.asarray(rows["pressure"], float)
    rec_i = np.asarray(rows["recording"], int)
    clean = sensor.gain(pressure) + base[rec_i]
    noisy = clean + rng.normal(0.0, 1.0, size=clean.shape) * sig[None, :]
    sim = np.clip(noisy, *sensor.clip)
    if sensor.step:
        sim = np.round(sim / sensor.step) * sensor.step
    sim = np.where(np.isfinite(real), sim, np.nan)          # unrecorded taxels: unknown on both sides
    held = np.array([_matches(recs[i].path, held_out) for i in rec_i], bool)
    rm = footprint_metrics(real, pos, det, k=k)
    sm = footprint_metrics(sim, pos, det, k=k)
    comp = np.asarray(rows["compression"], float)
    v = Validation(real=real, sim=sim, pressure=pressure, force=np.asarray(rows["force"], float), compression=comp,
                   recording=rec_i, frame=np.asarray(rows["frame"], int), held_out=held, baselines=base,
                   paths=[r.path for r in recs], real_metrics=rm, sim_metrics=sm, warnings=warnings)
    v.metrics = result_metrics(v)
    big = comp > LARGE_COMPRESSION
    if big.any():
        v.warnings.append(f"{int(big.sum())} of {len(comp)} simulated presses compress the layer by more than "
                          f"{LARGE_COMPRESSION:.0%} (up to {comp.max():.0%}): outside linear elasticity")
    return v


def result_metrics(v: Validation) -> dict:
    """The flat metrics of result.json: real and simulated quartiles of each footprint statistic, for
    all frames, the frames of held-out recordings and the others, and whether each simulated median
    lies within the recorded interquartile range. ``peak_*``: each recording's strongest frame only
    (:func:`peak_frames`), all, held-out and fitted recordings; ``rest_all``: the other frames."""
    out = {"frames": int(len(v.real)), "recordings": int(len(np.unique(v.recording))),
           "frames_held_out": int(v.held_out.sum()), "force_n_median": float(np.median(v.force)),
           "force_n_max": float(v.force.max()), "compression_max": float(v.compression.max()),
           "frames_compressed_over_30pct": int((v.compression > LARGE_COMPRESSION).sum())}
    peak = peak_frames(v)
    groups = {"all": np.ones(len(v.real), bool), "heldout": v.held_out, "fitted": ~v.held_out,
              "peak_all": peak, "peak_heldout": peak & v.held_out, "peak_fitted": peak & ~v.held_out,
              "rest_all": ~peak}
    for g, sel in groups.items():
        if not sel.any():
            continue
        r = summarise_metrics(v.real_metrics, sel, f"{g}_real")
        s = summarise_metrics(v.sim_metrics, sel, f"{g}_sim")
        out.update(r)
        out.update(s)
        for name in METRICS:
            med = s[f"{g}_sim_{name}_median"]
            out[f"{g}_sim_{name}_within_real_iqr"] = bool(r[f"{g}_real_{name}_q25"] <= med <= r[f"{g}_real_{name}_q75"])
    return out


def peak_frames(v: Validation) -> np.ndarray:
    """(K,) bool: each recording's strongest frame (its largest recorded reading), one per recording.

    The footprint of a press changes with its force (a real one concentrates as it grows); a
    recording's frames run from light touches to its peak, so statistics over all frames mix force
    levels. The peak frames compare like with like: each recording at its own strongest press."""
    pk = np.nanmax(np.where(np.isfinite(v.real), v.real, -np.inf), axis=1)
    out = np.zeros(len(v.real), bool)
    for r in np.unique(v.recording):
        idx = np.flatnonzero(v.recording == r)
        out[idx[np.argmax(pk[idx])]] = True
    return out


def by_force(v: Validation, metrics=("ring1", "ring2", "active", "minor_mm"), bins: int = 5) -> dict:
    """Each footprint statistic as a function of the pressed force: the frames binned by their
    matched force (N, quantile bins of equal frame count, in log force) and, per bin, the real and
    simulated medians. Returns ``{"force_n": (B,) bin median force, "frames": (B,), "<metric>_real":
    (B,), "<metric>_sim": (B,)}`` (NaN where a bin holds no finite value)."""
    f = np.asarray(v.force, float)
    edges = np.unique(np.quantile(np.log(f), np.linspace(0.0, 1.0, bins + 1)))
    which = np.clip(np.searchsorted(edges, np.log(f), side="right") - 1, 0, max(len(edges) - 2, 0))
    nb = max(len(edges) - 1, 1)
    out = {"force_n": np.full(nb, np.nan), "frames": np.zeros(nb, int)}
    for name in metrics:
        out[f"{name}_real"] = np.full(nb, np.nan)
        out[f"{name}_sim"] = np.full(nb, np.nan)
    for b in range(nb):
        sel = which == b
        out["frames"][b] = int(sel.sum())
        if not sel.any():
            continue
        out["force_n"][b] = float(np.median(f[sel]))
        for name in metrics:
            for side, mm in (("real", v.real_metrics), ("sim", v.sim_metrics)):
                x = np.asarray(mm[name], float)[sel]
                x = x[np.isfinite(x)]
                out[f"{name}_{side}"][b] = float(np.median(x)) if len(x) else np.nan
    return out


def sensor_from_profile(profile, taxel_ids) -> Sensor:
    """The :class:`Sensor` of a :class:`vtcore.contact.profile.SensorProfile` (its fitted transfer curve,
    per-taxel noise by UID, the clip at 0 and 16 bits, integer counts) for a layout's ``taxel_ids``."""
    from ..contact.sensor import MAX_COUNTS, gain

    r = profile.response
    if r is None:
        raise InputError(f"profile {profile.name!r} has no [response] (transfer curve)", key="profile")
    return Sensor(gain=lambda p: gain(p, r.counts_per_pa, r.p_half), sigma=profile.per_taxel(taxel_ids, "sigma"),
                  clip=(profile.clip_counts, MAX_COUNTS), step=1.0)
