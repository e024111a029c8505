"""Two-point discrimination: the smallest separation at which two simultaneous probes give two blobs.

Two probes at the reference force each, centred at ``s -+ (sep / 2) u`` for a direction ``u`` of the
tangent plane, give (noise-free, mean) readings that are the sum of two table look-ups: the layer is
linear elastic, so the base stress of two pressure patches is the sum of theirs, and the patches
themselves are those of lone probes as long as each probe does not feel the surface tilt the other
one makes (measured against two-probe press-by-press solves in ``vtcore bench evaluate``).

**Blobs** are the connected components, on the skin mesh (seed 002, Eqs. 1-2) of the live taxels,
of the taxels whose reading exceeds both ``k sigma`` and half the strongest reading of that press
(the half-maximum criterion: the discrete analogue of resolving two peaks by a dip to half their
height). A direction's discrimination distance is the smallest tested separation with two or more
blobs; the point's value is the **worst direction** (the largest of them): two touches farther apart
than this are told apart whatever their direction. No separation up to ``max_separation`` in some
direction: the point is not discriminated (``found = False``, value = ``max_separation``).

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
#: (configurations x taxels) readings one chunk may hold
CHUNK_VALUES = 6_000_000


@dataclass
class TwoPoint:
    """distance : (M,) m, the worst direction's discrimination distance (``max_separation`` where not
    found); found : (M,) bool; per_direction : (M, D) m; directions : (D,) rad; separations : (S,) m."""

    distance: np.ndarray
    found: np.ndarray
    per_direction: np.ndarray
    directions: np.ndarray
    separations: np.ndarray
    max_separation: float


def count_blobs(active: np.ndarray, index: np.ndarray, adjacency) -> np.ndarray:
    """Connected components of the active taxels of each configuration.

    active : (C, K) bool. index : (C, K) int, global taxel of each column (-1: none). adjacency : (N, N)
    CSR skin-mesh adjacency. Returns (C,) int blob counts.
    """
    import scipy.sparse as sp
    from scipy.sparse.csgraph import connected_components

    c_of, k_of = np.nonzero(active & (index >= 0))
    nodes = len(c_of)
    out = np.zeros(active.shape[0], np.int64)
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
    pos = np.searchsorted(skey, q)
    pos = np.minimum(pos, nodes - 1)
    hit = skey[pos] == q
    graph = sp.csr_matrix((np.ones(int(hit.sum()), np.int8), (src[hit], order[pos[hit]])), shape=(nodes, nodes))
    _, labels = connected_components(graph, directed=False)
    _, first = np.unique(labels, return_index=True)
    np.add.at(out, c_of[first], 1)
    return out


def two_point_discrimination(table: ResponseTable, taxels: np.ndarray, taxel_normals: np.ndarray, adjacency,
                             points: np.ndarray, normals: np.ndarray, noise: SensorNoise, reference_force: float,
                             *, directions: int = 4, step: float = 1e-3, max_separation: float = 0.04,
                             yaw: float = 0.0, axis=None) -> TwoPoint:
    """Discrimination distance (m) at each point (see the module docstring).

    taxels, taxel_normals : (N, 3) the live taxels; adjacency : (N, N) their skin mesh's adjacency.
    points, normals : (M, 3). directions : how many directions over half a turn. step, max_separation :
    the separations tested, m. yaw, axis : the probe frame (:func:`maps.frames`).
    """
    if not (step > 0 and max_separation >= step):
        raise InputError(f"need 0 < step <= max_separation, got {step}, {max_separation}", key="two_point_step")
    if int(directions) < 1:
        raise InputError(f"must be >= 1, got {directions}", key="two_point_directions")
    k = table.index(reference_force)
    seps = np.arange(step, max_separation + step / 2, step)
    ang = np.arange(int(directions)) * np.pi / int(directions)
    m = len(points)
    nb = neighbours(taxels, taxel_normals, points, normals, table.reach + max_separation / 2, yaw, axis=axis)
    kk = nb.index.shape[1]
    per = np.full((m, len(ang)), max_separation)
    found_dir = np.zeros((m, len(ang)), bool)
    if kk == 0:  # no taxel near any point: nothing is told apart
        return TwoPoint(np.full(m, float(max_separation)), np.zeros(m, bool), per, ang, seps, float(max_separation))
    gate = noise.threshold_pa
    n_cfg = len(ang) * len(seps)
    chunk = max(1, CHUNK_VALUES // max(1, n_cfg * max(kk, 1)))
    half = seps / 2
    for s0 in range(0, m, chunk):
        sl = slice(s0, min(s0 + chunk, m))
        p = sl.stop - sl.start
        idx = np.broadcast_to(nb.index[sl][:, None, None, :], (p, len(ang), len(seps), kk))
        valid = idx >= 0
        dx = np.where(valid, nb.dx[sl][:, None, None, :], 1e9)
        dy = np.where(valid, nb.dy[sl][:, None, None, :], 1e9)
        ux = (np.cos(ang)[:, None] * half[None, :])[None, :, :, None]
        uy = (np.sin(ang)[:, None] * half[None, :])[None, :, :, None]
        v = table.lookup(k, dx - ux, dy - uy) + table.lookup(k, dx + ux, dy + uy)
        v = np.where(valid, v, 0.0)
        level = np.maximum(gate, BLOB_FRACTION * v.max(axis=-1, keepdims=True, initial=0.0))
        active = v > level
        blobs = count_blobs(active.reshape(-1, kk), np.ascontiguousarray(idx).reshape(-1, kk),
                            adjacency).reshape(p, len(ang), len(seps))
        two = blobs >= 2
        any_two = two.any(axis=-1)
        first = np.argmax(two, axis=-1)
        per[sl] = np.where(any_two, seps[first], max_separation)
        found_dir[sl] = any_two
    found = found_dir.all(axis=1)
    dist = np.where(found, per.max(axis=1), max_separation)
    return TwoPoint(dist, found, per, ang, seps, float(max_separation))


def reach_of(nb: Neighbours) -> int:
    """Largest number of taxels around one point (for the docs' cost table)."""
    return int((nb.index >= 0).sum(axis=1).max(initial=0))
