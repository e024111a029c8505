"""Two-point discrimination: the smallest separation at which two simultaneous probes give two blobs.

Two probes side by side (two fingers of a hand: their long axes parallel, the pair offset across
them; for a round probe any direction), each at the reference force, centred at ``s -+ (sep / 2) b``
for separations from the probe's width (closer, the two overlap into one wider object) upwards,
give (noise-free, mean) readings that are the sum of two table look-ups: the layer is linear
elastic, so the base stress of two pressure patches is the sum of theirs, and the patches
themselves are those of lone probes as long as each probe does not feel the surface tilt the other
one makes (measured against two-probe press-by-press solves in ``vtcore bench evaluate``). The pair
is turned through ``directions`` orientations over half a turn about the normal.

The probes are told apart from the taxels **across** the pair: those within ``band`` (sqrt 3 / 2 of
the median taxel spacing: at least one lattice row in any orientation) of the line through both
probe centres. Along a finger pad a layer presses hardest at the pad's two ends, so one pad alone
lights two blobs there; the band keeps them out. **Blobs** are the connected components, on the skin
mesh (seed 002, Eqs. 1-2) of the live taxels, of the band's taxels whose reading exceeds both
``k sigma`` and half the band's strongest reading (the half-maximum criterion: the discrete analogue
of resolving two peaks by a dip to half their height); the probes are **told apart** when one blob
lies wholly on one probe's side of the pair's midline and another wholly on the other's. An orientation's discrimination
distance is the smallest tested separation at which the probes are told apart; the point's value is the **worst orientation** (the largest of them): two touches farther
apart than this are told apart however the hand is turned. No separation up to ``max_separation`` in
some orientation: the point is not discriminated (``found = False``, value = ``max_separation``).

All configurations (points x directions x separations) are labelled at once: one sparse graph
whose nodes are (configuration, active taxel) and whose edges are the skin-mesh edges between
active taxels of the same configuration, split by scipy.sparse.csgraph.connected_components.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import InputError
from .maps import Neighbours, neighbours
from .noise import SensorNoise
from .probe import ResponseTable

#: fraction of the strongest reading a taxel must exceed to belong to a blob (half maximum)
BLOB_FRACTION = 0.5
#: half-width of the strip across a pair, in median taxel spacings (one lattice row in any orientation)
BAND_SPACINGS = np.sqrt(3) / 2
#: (points x orientations x taxels) one chunk may hold
CHUNK_VALUES = 2_000_000
#: separations a two-point scan tests, at most (a 0.1 mm step over 10 cm; the default is 50)
MAX_SEPARATIONS = 1000
#: separations tried at once before the (point, orientation)s already split are dropped
SEPARATION_BLOCK = 6


@dataclass
class TwoPoint:
    """distance : (M,) m, the worst orientation's discrimination distance (``max_separation`` where not
    found); found : (M,) bool; per_direction : (M, D) m; directions : (D,) rad, the pair's orientations
    (its probes' axis from the point's first tangent); separations : (S,) m."""

    distance: np.ndarray
    found: np.ndarray
    per_direction: np.ndarray
    directions: np.ndarray
    separations: np.ndarray
    max_separation: float


def split_blobs(active: np.ndarray, index: np.ndarray, side: np.ndarray, adjacency) -> np.ndarray:
    """Whether each configuration's blobs tell its two probes apart.

    active : (C, K) bool. index : (C, K) int, the global taxel of each column (-1: none). side : (C, K)
    float, a taxel's signed offset across the pair (< 0: probe A's side, > 0: B's). adjacency : (N, N)
    CSR skin-mesh adjacency. Returns (C,) bool: some blob lies wholly on A's side and another wholly on
    B's (two blobs of one elongated probe, at its two ends, do not count).
    """
    import scipy.sparse as sp
    from scipy.sparse.csgraph import connected_components

    c_of, k_of = np.nonzero(active & (index >= 0))
    nodes = len(c_of)
    out = np.zeros(active.shape[0], bool)
    if not nodes:
        return out
    n = adjacency.shape[0]
    g = index[c_of, k_of].astype(np.int64)
    key = c_of.astype(np.int64) * n + g
    order = np.argsort(key)
    skey = key[order]
    adj = sp.csr_matrix(adjacency)
    deg = np.diff(adj.indptr)[g]
    src = np.repeat(np.arange(nodes), deg)
    start = np.repeat(adj.indptr[g], deg)
    nbr = adj.indices[start + (np.arange(len(src)) - np.repeat(np.cumsum(deg) - deg, deg))]
    q = c_of[src].astype(np.int64) * n + nbr
    pos = np.minimum(np.searchsorted(skey, q), nodes - 1)
    hit = skey[pos] == q
    graph = sp.csr_matrix((np.ones(int(hit.sum()), np.int8), (src[hit], order[pos[hit]])), shape=(nodes, nodes))
    ncomp, labels = connected_components(graph, directed=False)
    sd = side[c_of, k_of]
    lo = np.full(ncomp, np.inf)
    hi = np.full(ncomp, -np.inf)
    np.minimum.at(lo, labels, sd)
    np.maximum.at(hi, labels, sd)
    comp_cfg = np.zeros(ncomp, np.int64)
    comp_cfg[labels] = c_of
    a_side = np.zeros(active.shape[0], bool)
    b_side = np.zeros(active.shape[0], bool)
    a_side[comp_cfg[hi < 0]] = True
    b_side[comp_cfg[lo > 0]] = True
    return a_side & b_side


def two_point_discrimination(table: ResponseTable, taxels: np.ndarray, taxel_normals: np.ndarray, adjacency,
                             points: np.ndarray, normals: np.ndarray, noise: SensorNoise, reference_force: float,
                             *, directions: int = 4, step: float = 1e-3, max_separation: float = 0.04,
                             yaw: float = 0.0, axis=None, band: float | None = None,
                             min_separation: float = 0.0) -> TwoPoint:
    """Discrimination distance (m) at each point (see the module docstring).

    taxels, taxel_normals : (N, 3) the live taxels; adjacency : (N, N) their skin mesh's adjacency.
    points, normals : (M, 3). directions : how many orientations of the pair over half a turn. step, max_separation :
    the separations tested, m. yaw, axis : the probe frame (:func:`maps.frames`). band : m, half-width
    of the strip across the pair (default: sqrt 3 / 2 of the median nearest-taxel distance).
    min_separation : m, the separations start there (the probe's width: closer probes overlap).
    """
    if not (step > 0 and max_separation >= step):
        raise InputError(f"need 0 < step <= max_separation, got {step}, {max_separation}", key="two_point_step")
    if int(directions) < 1:
        raise InputError(f"must be >= 1, got {directions}", key="two_point_directions")
    k = table.index(reference_force)
    if band is None:
        band = BAND_SPACINGS * taxel_spacing(taxels)
    seps = separations(min_separation, step, max_separation)
    ang = np.arange(int(directions)) * np.pi / int(directions)
    m = len(points)
    # only taxels within reach of k sigma of either probe can be active
    nb = neighbours(taxels, taxel_normals, points, normals, table.radius(k, noise.threshold_pa) + max_separation / 2,
                    yaw, axis=axis)
    kk = nb.index.shape[1]
    per = np.full((m, len(ang)), max_separation)
    found_dir = np.zeros((m, len(ang)), bool)
    if kk == 0:  # no taxel near any point: nothing is told apart
        return TwoPoint(np.full(m, float(max_separation)), np.zeros(m, bool), per, ang, seps, float(max_separation))
    gate = noise.threshold_counts
    n_ang = len(ang)
    chunk = max(1, CHUNK_VALUES // max(1, n_ang * kk))
    ca, sa = np.cos(ang)[None, :, None], np.sin(ang)[None, :, None]
    for s0 in range(0, m, chunk):
        sl = slice(s0, min(s0 + chunk, m))
        p = sl.stop - sl.start
        valid = (nb.index[sl] >= 0)[:, None, :]
        dx = np.where(valid, nb.dx[sl][:, None, :], 1e9)
        dy = np.where(valid, nb.dy[sl][:, None, :], 1e9)
        # in the pair's frame: x along the probes' axis (angle a), y across it, probes at y = -+ sep / 2
        x = dx * ca + dy * sa                                   # (p, A, K)
        y = -dx * sa + dy * ca
        inband = valid & (np.abs(x) <= band)
        # only the band's taxels can light a blob: keep those columns of each (point, orientation)
        kb = max(int(inband.sum(axis=-1).max(initial=0)), 1)
        cols = np.argsort(~inband, axis=-1, kind="stable")[..., :kb]
        take = lambda a: np.take_along_axis(a, cols, axis=-1).reshape(p * n_ang, kb)  # noqa: E731
        bx, by, bm = take(x), take(y), take(inband)
        bidx = np.where(bm, take(np.broadcast_to(nb.index[sl][:, None, :], x.shape)), -1)
        result = np.full(p * n_ang, np.inf)
        pending = np.flatnonzero(bm.any(axis=1))
        # smallest separations first; a (point, orientation) stops at its first split
        block = max(1, min(len(seps), SEPARATION_BLOCK))
        for b0 in range(0, len(seps), block):
            if not len(pending):
                break
            ss = seps[b0:b0 + block]
            hy = (ss / 2)[None, :, None]
            px, py, pm = bx[pending][:, None, :], by[pending][:, None, :], bm[pending][:, None, :]
            v = table.lookup(k, np.broadcast_to(px, (len(pending), len(ss), kb)), py - hy) \
                + table.lookup(k, np.broadcast_to(px, (len(pending), len(ss), kb)), py + hy)
            v = np.where(pm, noise.counts(v), 0.0)  # blobs are judged on the readings (counts)
            level = np.maximum(gate, BLOB_FRACTION * v.max(axis=-1, keepdims=True, initial=0.0))
            cfg = len(pending) * len(ss)
            two = split_blobs((v > level).reshape(cfg, kb),
                              np.ascontiguousarray(np.broadcast_to(bidx[pending][:, None, :], v.shape)).reshape(cfg, kb),
                              np.ascontiguousarray(np.broadcast_to(py, v.shape)).reshape(cfg, kb),
                              adjacency).reshape(len(pending), len(ss))
            hit = two.any(axis=1)
            result[pending[hit]] = ss[np.argmax(two[hit], axis=1)]
            pending = pending[~hit]
        res = result.reshape(p, n_ang)
        found_dir[sl] = np.isfinite(res)
        per[sl] = np.where(np.isfinite(res), res, max_separation)
    found = found_dir.all(axis=1)
    dist = np.where(found, per.max(axis=1), max_separation)
    return TwoPoint(dist, found, per, ang, seps, float(max_separation))


def separations(lo: float, step: float, hi: float) -> np.ndarray:
    """(S,) m: ``lo`` (at least one step), then every ``step`` up to ``hi`` (included when on the grid).
    At most :data:`MAX_SEPARATIONS` (a step of 1e-320, or a largest separation of 1e308, was ``int(inf)``)."""
    first = max(float(lo), float(step))
    n = np.floor((float(hi) - first) / float(step) + 1e-9) + 1
    if not (np.isfinite(n) and n <= MAX_SEPARATIONS):
        raise InputError(f"separations from {first:g} m to {hi:g} m every {step:g} m are more than "
                         f"{MAX_SEPARATIONS:,}: raise two_point_step or lower max_separation", key="two_point_step")
    return first + step * np.arange(int(n))


def taxel_spacing(taxels: np.ndarray) -> float:
    """Median distance of a taxel to its nearest neighbour, metres (the layout's pitch)."""
    from scipy.spatial import cKDTree

    taxels = np.asarray(taxels, float).reshape(-1, 3)
    if len(taxels) < 2:
        return 0.0075
    d, _ = cKDTree(taxels).query(taxels, k=2)
    return float(np.median(d[:, 1]))


def reach_of(nb: Neighbours) -> int:
    """Largest number of taxels around one point (for the docs' cost table)."""
    return int((nb.index >= 0).sum(axis=1).max(initial=0))
