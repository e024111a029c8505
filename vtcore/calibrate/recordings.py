"""Real recordings as calibration and validation see them: loaded onto a layout, split into
contact frames and idle stretches.

The contact rule (stated once, used by ``vtcore calibrate`` and ``vtcore validate``): a frame is a
*contact frame* when at least ``min_active`` taxels within ``radius`` of its strongest taxel read
more than ``k`` of their own noise deviations above the recording's idle baseline (the strongest
included), and its strongest excess is at least ``relative`` (1/10) of the recording's largest: real
skins have taxels that sit hundreds of counts high for a whole file with almost no noise (a region
still loaded from an earlier press), a steady cluster that is not this recording's press. *Idle* frames are the
frames of a recording at least ``guard`` frames away from any contact frame: the noise is fitted
on them, never on a press or its onset and release.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..errors import InputError

#: defaults of the contact rule
K_DETECT = 5.0
MIN_ACTIVE = 3
RADIUS_M = 0.030
RELATIVE = 0.1
#: a taxel's noise deviation used for detection is at least this share of the median over taxels
SIGMA_FLOOR = 0.25
GUARD_FRAMES = 2
#: a recording must reach this share of the layout's taxels (else its UIDs belong to another skin)
MIN_MATCHED_SHARE = 0.05


@dataclass
class LoadedRecording:
    """One recording on the layout. counts : (T, N) float counts (NaN where not recorded);
    timestamps : (T,) s; recorded : (N,) bool; report : the reader's join report; path : str."""

    path: str
    counts: np.ndarray
    timestamps: np.ndarray
    recorded: np.ndarray
    report: dict = field(default_factory=dict)


def load_recordings(paths, layout, *, warn=None) -> list[LoadedRecording]:
    """Read CySkin text recordings onto ``layout`` (joined by UID).

    A recording whose UIDs match only part of the layout is kept with the rest masked (NaN), and
    ``warn(text)`` is told; one that reaches fewer than 5 % of the layout's taxels is refused
    (its UIDs belong to another skin), naming the file.
    """
    from ..can.recording import read_cyskin_txt

    if not paths:
        raise InputError("no recording given", key="RECORDING")
    out = []
    n = len(layout.positions)
    for p in paths:
        rec = read_cyskin_txt(p, layout)
        recorded = rec.mask.any(axis=0) if len(rec.mask) else np.zeros(n, bool)
        share = recorded.sum() / max(n, 1)
        if share < MIN_MATCHED_SHARE:
            raise InputError(f"only {int(recorded.sum())} of the layout's {n} taxels are in this recording "
                             f"(UIDs {rec.report['unmatched_uids'][:5]}... are not on the layout): is it the "
                             "layout of this skin?", file=p, key="--layout")
        if len(rec.timestamps) == 0:
            raise InputError("the recording has no data rows", file=p)
        if warn is not None and (rec.report["unrecorded_taxels"] or rec.report["unmatched_uids"]):
            warn(f"{p}: {int(recorded.sum())} of {n} layout taxels recorded; "
                 f"{len(rec.report['unmatched_uids'])} recorded UIDs not on the layout (ignored)")
        c = rec.frames.astype(float)
        c[~rec.mask] = np.nan
        out.append(LoadedRecording(str(p), c, rec.timestamps.astype(float), recorded, rec.report))
    return out


def neighbourhoods(positions, radius: float = RADIUS_M):
    """Sparse (N, N) CSR: True where two taxels lie within ``radius`` m (3-D distance), the diagonal
    included (a distance of 0 is not stored by the sparse distance matrix: added explicitly)."""
    from scipy.sparse import identity
    from scipy.spatial import cKDTree

    tree = cKDTree(np.asarray(positions, float))
    d = tree.sparse_distance_matrix(tree, radius, output_type="coo_matrix").tocsr()
    d.data[:] = 1.0
    return ((d + identity(len(positions), format="csr")) > 0).tocsr()


def contact_frames(counts, sigma, positions, *, k: float = K_DETECT, min_active: int = MIN_ACTIVE,
                   radius: float = RADIUS_M, near=None, baseline=None, relative: float = RELATIVE) -> np.ndarray:
    """(T,) bool: the frames of ``counts`` (T, N) that are contact frames by the module's rule.

    sigma : (N,) counts, each taxel's noise deviation. positions : (N, 3) m. near : the
    :func:`neighbourhoods` matrix (computed when None). baseline : (N,) counts or None, the
    recording's own idle offset of each taxel (its positive part is subtracted first: a taxel
    whose idle reading sits 3 sigma above 0 is not pressed when it reads 5 sigma). relative : a
    frame's strongest excess must reach this share of the recording's largest.
    """
    c = np.asarray(counts, float)
    if c.ndim != 2 or c.shape[1] != len(positions):
        raise InputError(f"counts must be (T, {len(positions)}), got {c.shape}", key="counts")
    if len(c) == 0:
        return np.zeros(0, bool)
    b = 0.0 if baseline is None else np.clip(np.nan_to_num(np.asarray(baseline, float)), 0.0, None)
    z = (np.where(np.isfinite(c), c, 0.0) - b) / np.asarray(sigma, float)
    peak = np.argmax(z, axis=1)
    near = neighbourhoods(positions, radius) if near is None else near
    rows = near[peak]                                       # (T, N) sparse: the peaks' neighbourhoods
    active = (z > k)
    n_act = np.asarray(rows.multiply(active).sum(axis=1)).ravel()
    zp = z[np.arange(len(c)), peak]
    return (zp > k) & (n_act >= min_active) & (zp >= relative * zp.max())


def idle_mask(contact, guard: int = GUARD_FRAMES) -> np.ndarray:
    """(T,) bool: frames at least ``guard`` frames away from every contact frame."""
    contact = np.asarray(contact, bool)
    if not contact.any():
        return np.ones_like(contact)
    grown = contact.copy()
    for s in range(1, guard + 1):
        grown[s:] |= contact[:-s]
        grown[:-s] |= contact[s:]
    return ~grown


def idle_segments(recs, contacts, guard: int = GUARD_FRAMES, owners: list | None = None):
    """``[(counts (T_i, N), timestamps (T_i,), valid (T_i, N))]``: the idle runs of every recording
    (a run is broken at each contact, so a segment's offset and drift stay its own). ``owners``, a
    list, receives the recording index of each segment."""
    out = []
    for ri, (r, c) in enumerate(zip(recs, contacts)):
        idle = idle_mask(c, guard)
        edges = np.flatnonzero(np.diff(np.concatenate([[0], idle.astype(int), [0]])))
        for a, b in zip(edges[::2], edges[1::2]):
            if b - a >= 2:
                v = r.counts[a:b]
                out.append((np.where(np.isfinite(v), v, 0.0), r.timestamps[a:b], np.isfinite(v)))
                if owners is not None:
                    owners.append(ri)
    return out


def recording_baselines(fit, owners, n_recordings: int, sigma) -> np.ndarray:
    """(R, N) counts: each recording's idle offset per taxel, the mean of its segments' offsets
    (``fit.segment_offset`` (S, N), ``owners`` (S,) the recording of each segment). A taxel that
    never rose above the clip in a recording's idle frames sits far below it there: -3 sigma."""
    seg = np.asarray(fit.segment_offset, float)
    own = np.asarray(owners, int)
    sig = np.asarray(sigma, float)
    out = np.full((n_recordings, seg.shape[1]), np.nan)
    for r in range(n_recordings):   # a loop over recordings (a handful), vectorised over taxels
        rows = seg[own == r]
        n = np.isfinite(rows).sum(axis=0)
        out[r] = np.where(n > 0, np.where(np.isfinite(rows), rows, 0.0).sum(axis=0) / np.maximum(n, 1), np.nan)
    return np.where(np.isfinite(out), out, -3.0 * sig[None, :])


def detection_sigma(sigma) -> np.ndarray:
    """(N,) counts: each taxel's noise deviation for detection and for the footprint statistics, NaN
    replaced by the median and floored at :data:`SIGMA_FLOOR` x the median. Some taxels of a real
    skin read an almost constant value for a whole file (5 % of the shared patch's have a fitted
    sigma below 11 counts, against a median of 185): divided by their own sigma, a wobble of a few
    counts would look like a press."""
    s = np.asarray(sigma, float)
    med = float(np.nanmedian(s)) if np.isfinite(s).any() else 1.0
    return np.maximum(np.where(np.isfinite(s), s, med), SIGMA_FLOOR * med)


def first_baselines(recs) -> np.ndarray:
    """(R, N) counts: each recording's 30th percentile per taxel, a first baseline before any contact
    is known (a press covers at most ~60 % of a file's frames, so that quantile is an idle one)."""
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)    # unrecorded taxels: all-NaN columns
        return np.stack([np.nan_to_num(np.nanpercentile(r.counts, 30, axis=0)) for r in recs])


def detect_contacts(recs, sigma, positions, *, k: float = K_DETECT, min_active: int = MIN_ACTIVE,
                    radius: float = RADIUS_M, guard: int = GUARD_FRAMES, rounds: int = 2, near=None):
    """Contact frames and idle baselines of recordings whose noise ``sigma`` (N,) counts is known.

    Round 0 detects with :func:`first_baselines`; each round then fits every recording's idle
    offsets (sigma through :func:`detection_sigma`) (a censored fit of its idle frames, :func:`recording_baselines`) and detects again.
    Returns ``(contacts: list of (T_i,) bool, baselines (R, N) counts)``.
    """
    from .noise import censored_normal_fit

    pos = np.asarray(positions, float)
    sig = detection_sigma(sigma)
    near = neighbourhoods(pos, radius) if near is None else near
    base = first_baselines(recs)
    contacts = []
    for _ in range(max(1, rounds)):
        contacts = [contact_frames(r.counts, sig, pos, k=k, min_active=min_active, radius=radius, near=near,
                                   baseline=base[i]) for i, r in enumerate(recs)]
        owners: list = []
        segs = idle_segments(recs, contacts, guard, owners)
        if not segs:
            break
        base = recording_baselines(censored_normal_fit(segs), owners, len(recs), sig)
    return contacts, base
