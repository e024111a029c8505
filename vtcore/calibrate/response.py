"""The response's free parameters fitted to recorded footprints.

Model: the finger pad (:data:`INDENTER`, conforming to the skin along its length) pressed through a
bonded layer of thickness ``h`` (Ecoflex 00-20's modulus, an assumption), the taxels reading
``gain(stress)`` (slope ``counts_per_pa`` at 0, half-ceiling ``p_half`` or linear) plus their
measured offsets and noise, clipped at 0. Force is not recorded: each frame is pressed with the
force that reproduces its recorded peak (:mod:`vtcore.calibrate.simulate`).

What the data can identify: for a linear layer the stress field of a press scales with E at a
given indentation, so E and force enter only as F / E, and the gain only as counts per unit of
stress / E (``counts_per_pa x E``). The footprint's *shape* (how many taxels light, how far, how
wide) depends on the thickness, on the indentation (so on F / E, set per frame by the peak rule
through the gain) and on the saturation, and these trade against each other: a thicker layer or
a stronger saturation both widen the footprint relative to its peak.

Force enters through F / E only, and a finger pad that conforms to the skin prints its own outline
at any force, so nothing in the footprints keeps the fit from vanishing forces through the
thickest layer: a plausible force range (:data:`FORCE_BOUNDS_N`, at the assumed modulus) bounds it.

The finger pad's length (tip to tip), radius and wrap are the probe's, not the sensor's, but the
recordings are the only measure of them (how long and wide the footprints are, how even along their
length), so they are scanned with the rest. The wrap is how far the pad's axis follows a convex skin:
a pad fully wrapped (as soft as the layer) presses evenly along its length, and its footprint's first
ring is then stronger than a finger's (0.35 of the peak against the recorded 0.29 with wrap 1; a
finger's bone under the pulp makes its pressure peak under the middle).

The fit scans a grid of (pad length, thickness, wrap, gain, p_half) within stated bounds. Each point
simulates every contact frame of the fit's recordings as the validation does (the force rule, the
recording's baseline, one seeded draw of the measured noise, the clip at 0) and is scored by how
far the quartiles (25, 50, 75 %) of its footprint statistics over all frames (ring ratios, active
taxels, principal radii: :mod:`vtcore.calibrate.footprint`) lie from the recorded ones, in units
of each statistic's recorded interquartile range: a method of simulated moments. Why not the per-taxel likelihood:
the pose of a recorded press is known only to about a taxel (from its footprint's centroid), and
a millimetre of pose moves the readings next to the peak by thousands of counts, so a per-taxel
score is ruled by where the finger was, not by the layer; the statistics' distribution is what a
millimetre does not change. Intervals: 95 % of the best grid value over a bootstrap of the recordings (each
recording is one placement of the finger). A parameter whose interval reaches a bound of its grid
is reported as not identified within that bound. The validation (``vtcore validate``) reports the
same statistics, on recordings the fit did not see as well.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..contact import ContactGrid, SoftLayer
from ..contact.materials import MATERIALS
from ..errors import InputError
from .footprint import footprint_metrics
from .recordings import detection_sigma
from .simulate import WINDOW_M, MatchedPress, at_forces, force_for_peak, frame_poses, recording_pose

#: the indenter of the fit: a finger pad (docs/contact.md: 'A finger pad')
INDENTER = {"kind": "fingerpad", "radius": 0.008, "length": 0.04}
#: plausible bounds: cover layers of a robot skin are 1.5-8 mm (seed 001's are 3-10 mm of Ecoflex)
THICKNESS_GRID_M = (0.002, 0.003, 0.004, 0.005, 0.006, 0.008)
#: finger pad length tip to tip, m: a finger lying on the skin touches with its distal pad (~25 mm)
#: and part or all of its middle phalanx (~25 mm more)
LENGTH_GRID_M = (0.04, 0.05, 0.06)
#: finger pad radius, m: half the width of an adult fingertip's pad, 7-11 mm (wider as it flattens)
RADIUS_GRID_M = (0.007, 0.008, 0.009, 0.010, 0.011)
#: how far the pad wraps a convex skin (vtcore.calibrate.simulate.MatchedPress): 1 an even pressure along
#: it (a pad as soft as the layer), less a pressure that peaks at its middle (a finger's bone under the pulp)
WRAP_GRID = (0.7, 0.85, 1.0)
#: pad lengths of the wrap stage, m: a pad that wraps less lifts its ends, so a longer finger (distal and
#: middle phalanx, up to most of an index finger's ~75 mm) may be what touches
WRAP_LENGTH_GRID_M = (0.05, 0.06, 0.07, 0.08)
#: counts per pascal at Ecoflex 00-20's modulus: 0.05-20 (seed scenes assume 0.1-1)
GAIN_GRID = tuple(float(x) for x in np.geomspace(0.05, 20.0, 15))
#: half-ceiling pressures, Pa (inf: linear)
P_HALF_GRID = (np.inf, 3e3, 1e4, 3e4, 1e5)
#: plausible force of a one-finger press, N, at the assumed modulus (a gentle touch to a firm press):
#: only F / E is identified, and without a bound the fit runs to vanishing forces through a thick
#: layer (a conforming pad then prints its own outline at any force), so grid points whose frames
#: need a median force outside this range are not candidates
FORCE_BOUNDS_N = (0.3, 10.0)
#: the calibration's force ladder, N (twice as coarse as the validation's: a grid point only ranks)
CAL_LADDER_N = tuple(float(x) for x in 2.0 ** np.arange(-2, 4))
MATERIAL = "ecoflex_00_20"
FRAMES_PER_RECORDING = None   # every contact frame (what the validation compares)


@dataclass
class ResponseFit:
    """Outcome of :func:`fit_response`. best : dict (thickness_m, counts_per_pa, p_half_pa (inf:
    linear)). intervals : name -> (lo, hi, identified). score : (H, G, P) the scan's scores (sum of squared
    standardised quartile differences); dof : the number of terms (3 quartiles x statistics).
    force_over_modulus : (K,) m^2, the fitted F / E of each frame used. compression : (K,) largest
    compression / thickness at the fit. frames : list of (recording path, frame index)."""

    best: dict
    intervals: dict
    score: np.ndarray
    dof: int
    grids: dict
    force_over_modulus: np.ndarray
    compression: np.ndarray
    frames: list = field(default_factory=list)
    young_modulus: float = 0.0
    seconds: float = 0.0

    def summary_lines(self) -> list[str]:
        b, iv = self.best, self.intervals
        out = []
        for name, unit, scale in (("radius_m", "mm (finger pad)", 1e3), ("length_m", "mm (finger pad)", 1e3),
                                  ("wrap", "(finger pad; 1: follows the skin)", 1.0), ("thickness_m", "mm", 1e3),
                                  ("counts_per_pa", "counts/Pa", 1.0), ("p_half_pa", "kPa", 1e-3)):
            lo, hi, ok = iv[name]
            v = b[name]
            vs = "linear" if not np.isfinite(v) else f"{v * scale:.3g}"
            out.append(f"response: {name} {vs} {unit} (95 % {lo * scale:.3g}-{hi * scale:.3g}"
                       f"{'' if ok else ', NOT identified within the bounds'})")
        fe = np.median(self.force_over_modulus)
        out.append(f"response: F/E median {fe * 1e6:.3g} mm^2 per frame (= {fe * self.young_modulus:.2g} N at the "
                   f"assumed E {self.young_modulus / 1e3:.0f} kPa); score {self.score.min() / max(self.dof, 1):.2f} IQR^2 per statistic quartile "
                   f"over {len(self.frames)} frames; largest compression {self.compression.max():.0%}")
        return out

    def table(self, held_out=()) -> tuple[dict, str]:
        """The profile's ``[response]`` table and its comment."""
        b, iv = self.best, self.intervals
        ok = {k: bool(v[2]) for k, v in iv.items()}
        t = {
            "thickness_m": float(b["thickness_m"]),
            "thickness_ci_m": [float(iv["thickness_m"][0]), float(iv["thickness_m"][1])],
            "young_modulus_pa": float(self.young_modulus), "poisson": float(MATERIALS[MATERIAL]["poisson"]),
            "material": MATERIAL, "base": "bonded",
            "counts_per_pa": float(b["counts_per_pa"]),
            "counts_per_pa_ci": [float(iv["counts_per_pa"][0]), float(iv["counts_per_pa"][1])],
            "indenter": {**INDENTER, "radius": float(b["radius_m"]), "length": float(b["length_m"]), "conform": True,
                         "wrap": float(b["wrap"])},
            "radius_ci_m": [float(iv["radius_m"][0]), float(iv["radius_m"][1])],
            "length_ci_m": [float(iv["length_m"][0]), float(iv["length_m"][1])],
            "wrap_ci": [float(iv["wrap"][0]), float(iv["wrap"][1])],
            "fitted": sorted({"/".join(Path(p).parts[-2:]) for p, _ in self.frames}),
            "force_over_modulus_m2_median": float(np.median(self.force_over_modulus)),
            "force_over_modulus_m2_iqr": [float(x) for x in np.percentile(self.force_over_modulus, [25, 75])],
            "implied_force_n_median": float(np.median(self.force_over_modulus) * self.young_modulus),
            "max_compression": float(self.compression.max()),
            "score_per_term": float(self.score.min() / max(self.dof, 1)),
            "frames": len(self.frames),
            "identified": [k for k, v in ok.items() if v],
            "not_identified": [k for k, v in ok.items() if not v],
            "held_out": list(held_out),
        }
        if np.isfinite(b["p_half_pa"]):
            t["p_half_pa"] = float(b["p_half_pa"])
        lo, hi, _ = iv["p_half_pa"]
        t["p_half_ci_pa"] = [float(lo), float(hi) if np.isfinite(hi) else 1e12]
        note = ("Response fitted to the footprints of the recordings' contact frames (vtcore.calibrate.response):\n"
                "a finger pad wrapping the skin (wrap: the fraction of its curvature), pressed through a bonded layer\n"
                "with the force that gives each frame's recorded peak; scanned in three stages (pad length x thickness,\n"
                "pad radius, wrap x pad length; each with gain x p_half), scored by the distance of the frames' footprint\n"
                "statistics (rings, active taxels, principal radii) from the recorded ones. Intervals: 95 % bootstrap\n"
                "over the recordings.\n"
                "young_modulus_pa is an ASSUMPTION (Ecoflex 00-20): force is not recorded, only F/E and counts_per_pa x E\n"
                "are identified; counts_per_pa and p_half_pa hold for that modulus. p_half_ci_pa upper 1e12: linear\n"
                "within the interval. identified / not_identified: whether each interval stays inside its grid.")
        return t, note


SCORED = ("ring1", "ring2", "active", "minor_mm", "major_mm")


def _iqr_scale(v) -> float:
    """The interquartile range of the finite values of ``v`` (floored: a metric that never varies
    still gets a finite scale)."""
    v = np.asarray(v, float)
    v = v[np.isfinite(v)]
    if v.size == 0:
        return 1.0
    q = np.percentile(v, [25, 75])
    return float(max(q[1] - q[0], 1e-3 * max(abs(np.median(v)), 1e-9), 1e-9))


def _bootstrap(score_of, rec_of, grids: dict, n_boot: int = 100, seed: int = 0) -> dict:
    """95 % intervals of each parameter's best grid value when the recordings are resampled with
    replacement (a recording is one placement of the finger, so this carries the spread between
    presses, which the per-taxel noise alone does not). ``score_of(rows)`` scores the grid (shape of
    ``grids``' lengths) on the frames ``rows``; ``rec_of`` (F,) the recording of each frame.
    ``identified``: the interval stays off the grid's bounds (for p_half, ordered from the strongest
    saturation to linear: neither the smallest p_half nor linear)."""
    rng = np.random.default_rng(seed)
    recs = np.unique(rec_of)
    by_rec = [np.flatnonzero(rec_of == r) for r in recs]
    picks = []
    for _ in range(n_boot):
        rows = np.concatenate([by_rec[i] for i in rng.integers(0, len(recs), len(recs))])
        sc = score_of(rows)
        picks.append(np.unravel_index(np.argmin(sc), sc.shape))
    picks = np.asarray(picks)
    out = {}
    for j, (name, grid_vals) in enumerate(grids.items()):
        vals = np.asarray(grid_vals, float)
        lo, hi = np.percentile(vals[picks[:, j]], [2.5, 97.5], method="nearest")
        if name == "p_half_pa":
            fin = np.sort(vals[np.isfinite(vals)])
            identified = bool(lo > fin[0] and np.isfinite(hi))   # reaching linear (inf) is reaching a bound
        else:
            identified = bool(vals.min() < lo and hi < vals.max())
        out[name] = (float(lo), float(hi), identified)
    return out


def _choose_frames(counts, contact, per):
    """Every contact frame (``per`` None), or up to ``per`` of them evenly spread over those reaching
    3/4 of the recording's highest peak (the held press)."""
    idx = np.flatnonzero(contact)
    if len(idx) == 0 or per is None:
        return idx
    pk = np.nanmax(counts[idx], axis=1)
    idx = idx[pk >= 0.75 * pk.max()]
    take = np.unique(np.round(np.linspace(0, len(idx) - 1, min(per, len(idx)))).astype(int))
    return idx[take]


class _Frames:
    """The recorded frames of the fit and their footprint statistics (what every grid point is scored on).

    The statistics are computed on the taxels within :data:`WINDOW_M` of each recording's contact
    (``win[r]``, indices into the layout), simulated and recorded alike: a footprint's statistics reach
    30 mm from its peak, and the grid's thousands of evaluations then cost a fifth."""

    def __init__(self, per_rec, offs, layout, sigma, k, poses):
        self.per_rec, self.k = per_rec, k
        pos = np.asarray(layout.positions, float)
        sig = detection_sigma(sigma)
        self.win = [np.flatnonzero(np.linalg.norm(pos - p.centre, axis=1) <= WINDOW_M) for p in poses]
        self.pos = [pos[w] for w in self.win]
        self.sig = [sig[w] for w in self.win]
        self.offs = [o[w] for o, w in zip(offs, self.win)]
        self.real = [footprint_metrics(r.counts[fr][:, w], p_, s_, k=k)
                     for (r, fr), w, p_, s_ in zip(per_rec, self.win, self.pos, self.sig)]
        self.scales = {m: _iqr_scale(np.concatenate([rm[m] for rm in self.real])) for m in SCORED}
        self.targets = [np.nanmax(r.counts[fr], axis=1) for r, fr in per_rec]


def _scan(frames: _Frames, ladder_of, n_geom: int, gains, p_halfs, force_bounds, noise_sigma, seed: int = 0):
    """Simulate the fit's frames at every (geometry, gain, p_half) point.

    ``ladder_of(g, r)`` gives recording r's ladder ``(forces, pressures, compression)`` for geometry g.
    Each frame is read as the validation reads it: the force that reproduces its recorded peak, the
    recording's idle baseline, one seeded draw of the measured noise (``noise_sigma`` (N,) counts),
    the clip at 0. Returns ``(sim (n_geom, G, P, F, M) footprint statistics of SCORED per frame,
    valid (n_geom, G, P) bool, f_star, compression)`` (the last two (n_geom, G, P, F)); a point is
    not valid when a frame's peak lies beyond its ladder or the frames' median force lies outside
    ``force_bounds``."""
    from ..contact.sensor import gain as transfer

    n_f = sum(len(fr) for _, fr in frames.per_rec)
    shape = (n_geom, len(gains), len(p_halfs))
    sim = np.full(shape + (n_f, len(SCORED)), np.nan)
    valid = np.ones(shape, bool)
    f_all = np.full(shape + (n_f,), np.nan)
    c_all = np.full(shape + (n_f,), np.nan)
    start = np.cumsum([0] + [len(fr) for _, fr in frames.per_rec])
    sig = np.asarray(noise_sigma, float)
    for ri in range(len(frames.per_rec)):
        sl = slice(start[ri], start[ri + 1])
        w = frames.win[ri]
        draw = np.random.default_rng([seed, ri]).normal(size=(start[ri + 1] - start[ri], len(w))) * sig[w]
        for gi in range(n_geom):
            fs, ps, comp = ladder_of(gi, ri)
            if len(fs) < 2:
                valid[gi] = False
                continue
            for c_, p_half in enumerate(p_halfs):
                for b, g in enumerate(gains):
                    cl = transfer(ps, g, None if not np.isfinite(p_half) else p_half)     # (L, N)
                    f_star, ok = force_for_peak(fs, cl.max(axis=1), frames.targets[ri])
                    model, c_star = at_forces(fs, cl, comp, f_star)                      # (K, N), (K,)
                    m = footprint_metrics(np.maximum(model[:, w] + frames.offs[ri] + draw, 0.0), frames.pos[ri],
                                          frames.sig[ri], k=frames.k)
                    sim[gi, b, c_, sl] = np.stack([m[name] for name in SCORED], axis=1)
                    valid[gi, b, c_] &= bool(ok.all())
                    f_all[gi, b, c_, sl], c_all[gi, b, c_, sl] = f_star, c_star
    med_f = np.nanmedian(f_all, axis=-1)
    valid &= (med_f >= force_bounds[0]) & (med_f <= force_bounds[1])
    return sim, valid, f_all, c_all


def nan_quartiles(a, axis: int = 0) -> np.ndarray:
    """The 25, 50 and 75 % points of ``a`` along ``axis`` ignoring NaN, as ``np.nanpercentile(a, [25, 50,
    75], axis)`` (its default linear interpolation) gives them: (3, ...) with ``axis`` removed, NaN where a
    slice holds only NaN.

    Written here because nanpercentile loops in Python over the slices (``apply_along_axis``): the
    calibration's bootstrap asks for it on ~7,000 slices a hundred times, 1-2 minutes of its time; one
    sort (NaN sorts last) and a gather do the same at once."""
    x = np.sort(np.moveaxis(np.asarray(a, float), axis, -1), axis=-1)
    n = (~np.isnan(x)).sum(axis=-1)                                   # NaN sorts to the end
    pos = np.array([0.25, 0.5, 0.75]).reshape((3,) + (1,) * n.ndim) * np.maximum(n - 1, 0)
    lo = np.floor(pos).astype(np.intp)
    hi = np.minimum(lo + 1, np.maximum(n - 1, 0))
    w = pos - lo
    xl = np.take_along_axis(x[None], lo[..., None], axis=-1)[..., 0]
    xh = np.take_along_axis(x[None], hi[..., None], axis=-1)[..., 0]
    out = xl + w * (xh - xl)
    return np.where(n > 0, out, np.nan)


def _quantile_score(sim, valid, real, scales, rows=None):
    """(points...) score: sum over SCORED statistics and their quartiles (25, 50, 75 %) of the squared
    difference between simulated and recorded quartile, in recorded IQRs; inf where not valid.
    sim (..., F, M); real (F, M); rows: the frames to use (a bootstrap sample; all by default)."""
    if rows is not None:
        sim, real = sim[..., rows, :], real[rows]
    with np.errstate(all="ignore"):
        qs = nan_quartiles(sim, axis=-2)                             # (3, ..., M); NaN: no frame defines it
        qr = nan_quartiles(real, axis=0)                             # (3, M)
    sc = np.asarray([scales[m] for m in SCORED])
    d = (qs - qr.reshape((3,) + (1,) * (qs.ndim - 2) + (len(SCORED),))) / sc
    out = np.nansum(d * d, axis=(0, -1))
    return np.where(valid, out, np.inf)


def fit_response(recs, contacts, layout, sigma, baselines=None, *, k: float = 5.0, progress=None,
                 thicknesses=THICKNESS_GRID_M, gains=GAIN_GRID, p_halfs=P_HALF_GRID, lengths=LENGTH_GRID_M,
                 radii=RADIUS_GRID_M, wraps=WRAP_GRID, wrap_lengths=WRAP_LENGTH_GRID_M, force_bounds=FORCE_BOUNDS_N,
                 frames_per_recording: int = FRAMES_PER_RECORDING, grid_spacing: float = 1e-3) -> ResponseFit:
    """Fit the pad's length, radius and wrap, the layer's thickness, the gain and the saturation to the
    contact frames of ``recs`` (see the module docstring).

    recs : LoadedRecording list; contacts : (T_i,) bool per recording; sigma : (N,) counts (the noise
    fit; NaN: the taxel is left out of the score); baselines : (R, N) counts, each recording's idle
    offsets (added to the model before the clip at 0), or None (0).

    Three stages (coordinate descent, so the presses stay affordable): (pad length x thickness x gain
    x p_half) at the pad's default radius, fully wrapped; (pad radius x gain x p_half) at the best
    length and thickness; (wrap x pad length x gain x p_half) at the best radius and thickness. Each
    interval therefore holds the parameters of the other stages fixed; the gain's and p_half's are the
    last stage's.
    """
    import time

    t0 = time.perf_counter()
    sig = np.asarray(sigma, float)
    base = np.zeros((len(recs), len(layout.positions))) if baselines is None else np.asarray(baselines, float)
    per_rec, offs = [], []
    for i, (r, c) in enumerate(zip(recs, contacts)):
        fr = _choose_frames(r.counts, c, frames_per_recording)
        if len(fr):
            per_rec.append((r, fr))
            offs.append(base[i])
    if not per_rec:
        raise InputError("no contact frame in the recordings given for the response fit (a contact frame has "
                         f"at least 3 taxels above {k:g} noise deviations within 30 mm of its peak)",
                         key="recordings")
    E = MATERIALS[MATERIAL]["young_modulus"]
    poses = [recording_pose(frame_poses(np.where(np.isfinite(r.counts[fr]), r.counts[fr], np.nan), layout,
                                        detection_sigma(sig), k), layout) for r, fr in per_rec]
    frames = _Frames(per_rec, offs, layout, sig, k, poses)
    stage = _Stages(frames, layout, poses, gains, p_halfs, force_bounds, sig, grid_spacing, progress)
    r0 = INDENTER["radius"]
    s1 = stage.run([(r0, ln, h, 1.0) for ln in lengths for h in thicknesses], "length x thickness")
    _, ln1, h1, _ = s1.best_geometry
    s2 = stage.run([(rad, ln1, h1, 1.0) for rad in radii], "pad radius")
    rad2 = s2.best_geometry[0]
    s3 = stage.run([(rad2, ln, h1, w) for w in wraps for ln in wrap_lengths], "wrap x length")
    _, ln3, _, w3 = s3.best_geometry
    best = {"radius_m": float(rad2), "length_m": float(ln3), "thickness_m": float(h1), "wrap": float(w3),
            "counts_per_pa": float(gains[s3.at[1]]), "p_half_pa": float(p_halfs[s3.at[2]])}
    # intervals: resample the recordings (each one placement of the finger), refit on each stage's grid
    intervals = {name: iv for name, iv in stage.intervals(
        s1, {"length_m": lengths, "thickness_m": thicknesses}).items() if name == "thickness_m"}
    intervals["radius_m"] = stage.intervals(s2, {"radius_m": radii})["radius_m"]
    intervals.update(stage.intervals(s3, {"wrap": wraps, "length_m": wrap_lengths}))
    return ResponseFit(best=best, intervals=intervals, score=s3.score, dof=3 * len(SCORED),
                       grids={"radius_m": [float(x) for x in radii], "length_m": [float(x) for x in wrap_lengths],
                              "wrap": [float(x) for x in wraps],
                              "thickness_m": [float(x) for x in thicknesses], "counts_per_pa": [float(x) for x in gains],
                              "p_half_pa": [float(x) for x in p_halfs]},
                       force_over_modulus=s3.force[s3.at] / E, compression=s3.compression[s3.at],
                       frames=[(r.path, int(j)) for r, fr in per_rec for j in fr],
                       young_modulus=float(E), seconds=time.perf_counter() - t0)


@dataclass
class _Stage:
    """One scanned stage of the fit: ``geoms`` (radius, length, thickness, wrap) tuples; ``sim``, ``ok``,
    ``force``, ``compression`` as :func:`_scan` returns them; ``score`` (n_geom, G, P); ``at`` the
    best (geometry, gain, p_half) index."""

    geoms: list
    sim: np.ndarray
    ok: np.ndarray
    force: np.ndarray
    compression: np.ndarray
    score: np.ndarray
    at: tuple

    @property
    def best_geometry(self):
        return self.geoms[self.at[0]]


class _Stages:
    """Presses (cached per geometry and recording) and scans of the fit's stages."""

    def __init__(self, frames, layout, poses, gains, p_halfs, force_bounds, sigma, grid_spacing, progress):
        self.frames, self.layout, self.poses = frames, layout, poses
        self.gains, self.p_halfs, self.force_bounds = gains, p_halfs, force_bounds
        self.noise = np.where(np.isfinite(sigma), sigma, np.nanmedian(sigma))
        self.grid_spacing, self.progress = grid_spacing, progress
        self.ladders: dict = {}
        self.real = np.concatenate([np.stack([rm[name] for name in SCORED], axis=1) for rm in frames.real])  # (F, M)
        self.rec_of = np.concatenate([np.full(len(fr), i) for i, (_, fr) in enumerate(frames.per_rec)])

    def _press(self, geoms, desc):
        from .._progress import progress as bar

        jobs = [(g, i) for g in geoms for i in range(len(self.poses)) if (g, i) not in self.ladders]
        for (radius, ln, h, wrap), i in bar(jobs, desc=f"calibrate: pressing ({desc})", total=len(jobs),
                                            unit="ladder"):
            mp = MatchedPress(self.layout, SoftLayer(thickness=h, material=MATERIAL),
                              {**INDENTER, "radius": radius, "length": ln, "wrap": wrap},
                              grid=ContactGrid(spacing=self.grid_spacing))
            self.ladders[((radius, ln, h, wrap), i)] = mp.ladder(self.poses[i], CAL_LADDER_N)
            if self.progress is not None:
                self.progress()

    def run(self, geoms, desc) -> _Stage:
        self._press(geoms, desc)
        sim, ok, f, c = _scan(self.frames, lambda g, r: self.ladders[(geoms[g], r)], len(geoms), self.gains,
                              self.p_halfs, self.force_bounds, self.noise)
        sc = _quantile_score(sim, ok, self.real, self.frames.scales)
        at = tuple(int(x) for x in np.unravel_index(np.argmin(sc), sc.shape))
        return _Stage(list(geoms), sim, ok, f, c, sc, at)

    def intervals(self, st: _Stage, geom_grids: dict) -> dict:
        """Bootstrap intervals of a stage whose geometries span ``geom_grids`` (name -> values, in the
        order the stage's geometries were made, outermost first), with the gain and p_half."""
        shape = tuple(len(v) for v in geom_grids.values()) + (len(self.gains), len(self.p_halfs))
        return _bootstrap(lambda rows: _quantile_score(st.sim, st.ok, self.real, self.frames.scales,
                                                       rows).reshape(shape),
                          self.rec_of, {**geom_grids, "counts_per_pa": self.gains, "p_half_pa": self.p_halfs})
