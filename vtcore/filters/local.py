"""Local filters on the skin mesh (seed 002, Eqs. 3-7).

A local filter computes every taxel's output from its own value and the values
of its mesh neighbours (Eq. 4), ``p_hat_i = sum_{j in adj(i)} w_ji p_j`` with
``E_ii = 1``. With constant weights this is a sparse linear operator ``W``
(``p_hat = W @ p``, CSR ``N x N`` on the pattern of ``E + I``); the low-pass,
Gaussian and Laplacian filters that seed 002 names as extensions are such
operators (:func:`local_operator`).

The edge filter (Eqs. 5-6) uses data-dependent weights, the directional
derivative along each mesh edge, ``w_ij = (p_j - p_i) / D_ij`` (``t_i + D_ij
k_ij = t_j``), so

    p_hat_i = sum_{j in adj(i)} p_j (p_j - p_i) / D_ij                   (Eq. 6)
            = [G (p * p)]_i - p_i [G p]_i,    G_ij = 1 / D_ij on mesh edges,

i.e. two applications of the same constant Eq. 4 operator ``G``. Eq. 6 is
quadratic in ``p`` (units: pressure^2 / metre): positive on the low side of a
sharp rise (just outside a contact), zero inside a uniform region and at an
isolated taxel, negative on a pressure ridge. Eq. 7 thresholds it.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from ..errors import InputError, InputTypeError
from ..tolerances import LENGTH_TOL

#: Edges shorter than this (metres) join coincident taxels: no direction, no weight.
MIN_EDGE_LENGTH = LENGTH_TOL

#: Below this many multiply-adds per call the exact per-edge form of Eq. 6 is used
#: (fast for single frames and small batches, no cancellation); above it the
#: two-product sparse form, which is several times faster on big batches.
_GATHER_LIMIT = 2_000_000
#: Bytes of one transposed frame chunk in the batched sparse form: each stored edge
#: streams a row of the chunk, so the chunk must stay in cache (measured on 4,000
#: taxels x 10,000 frames: 2 MB chunks 100 M taxel-frames/s in float64, 8 MB 46 M/s).
_CHUNK_BYTES = 2 << 20


def _values(values, n, name="values"):
    """Check ``values`` is (N,) or (T, N) and finite; return a float array (float32 kept)."""
    v = np.asanyarray(values)
    if v.dtype.kind not in "fiub":
        raise InputTypeError(f"{name}: expected numbers, got dtype {v.dtype}")
    if v.dtype != np.float32:
        v = v.astype(np.float64, copy=False)
    if v.ndim not in (1, 2) or v.shape[-1] != n:
        raise InputError(f"expected shape ({n},) or (T, {n}), got {v.shape}", key=name)
    if not np.all(np.isfinite(v)):
        raise InputError("contains NaN or inf; mask missing samples before filtering", key=name)
    return v


def inverse_distance(mesh) -> sp.csr_matrix:
    """``G`` (N, N) CSR, ``1 / D_ij`` (1/m) on every mesh edge (Eq. 2), sorted indices.

    The pattern is the mesh adjacency ``E`` without its diagonal; ``D_ij`` is the
    Euclidean distance of the taxel positions (Eq. 2). Edges between coincident
    taxels (``D_ij < MIN_EDGE_LENGTH``) get no weight: their direction ``k_ij``
    is undefined, so Eq. 5 has no value there.
    """
    adj = sp.csr_matrix(mesh.adjacency, dtype=np.float64, copy=True)
    n = adj.shape[0]
    if adj.shape != (n, n) or len(mesh.positions) != n:
        raise InputError(f"adjacency {adj.shape} does not match {len(mesh.positions)} positions",
                         key="mesh")
    adj.setdiag(0)
    adj.eliminate_zeros()
    coo = adj.tocoo()
    pos = np.asarray(mesh.positions, dtype=np.float64)
    d = np.linalg.norm(pos[coo.row] - pos[coo.col], axis=1)
    ok = d >= MIN_EDGE_LENGTH
    g = sp.csr_matrix((1.0 / d[ok], (coo.row[ok], coo.col[ok])), shape=(n, n))
    g.sum_duplicates()
    g.sort_indices()
    return g


class EdgeFilter:
    """Eq. 6 of seed 002 on one skin mesh, precomputed.

    Parameters
    ----------
    mesh : SkinMesh (``adjacency``, ``distances`` CSR N x N, metres).
    dtype : float64 (default) or float32 for the batched form (twice the
        throughput, relative rounding ~1e-7).

    ``filter(values)`` maps (N,) or (T, N) pressures (any unit) to the Eq. 6
    response with the same shape, in unit^2 / metre.
    """

    def __init__(self, mesh, dtype=np.float64):
        self.n = int(mesh.adjacency.shape[0])
        self.dtype = np.dtype(dtype)
        if self.dtype not in (np.float64, np.float32):
            raise InputTypeError(f"dtype must be float64 or float32, got {self.dtype}")
        self.G = inverse_distance(mesh)
        self._G = self.G.astype(self.dtype)
        g = self.G
        deg = np.diff(g.indptr)
        self.rows = np.repeat(np.arange(self.n), deg)
        self.cols = g.indices.astype(np.intp)
        self.g = g.data
        self._nonempty = deg > 0
        self._starts = g.indptr[:-1][self._nonempty]

    # -- exact per-edge form: sum in CSR (ascending neighbour) order -----------------
    def _gather(self, v):
        out = np.zeros(v.shape, dtype=np.result_type(v, self.g))
        if self.g.size == 0:
            return out
        if v.ndim == 1:
            pj = v[self.cols]
            c = pj * (pj - v[self.rows])
            c *= self.g
            out[self._nonempty] = np.add.reduceat(c, self._starts)
            return out
        vt = np.ascontiguousarray(v.T)
        pj = vt[self.cols]
        c = pj * (pj - vt[self.rows])
        c *= self.g[:, None]
        out[:, self._nonempty] = np.add.reduceat(c, self._starts, axis=0).T
        return out

    # -- batched form: G (p*p) - p * (G p), transposed chunks so CSR products stream --
    def _sparse(self, v):
        t = v.shape[0]
        out = np.empty((t, self.n), dtype=self.dtype)
        chunk = int(np.clip(_CHUNK_BYTES // max(self.n * self.dtype.itemsize, 1), 16, 4096))
        for s in range(0, t, chunk):
            x = np.ascontiguousarray(v[s:s + chunk].T, dtype=self.dtype)
            a = self._G @ (x * x)
            a -= x * (self._G @ x)
            out[s:s + chunk] = a.T
        return out

    def __call__(self, values) -> np.ndarray:
        """Eq. 6 response, same shape as ``values`` ((N,) or (T, N)); unit^2 / m."""
        v = _values(values, self.n)
        peak = float(np.abs(v).max()) if v.size else 0.0
        big = np.finfo(self.dtype).max ** 0.25
        if peak <= big:  # (virtually always) no rescaling: results bit-identical to Eq. 6 as written
            return self._response(v)
        # Eq. 6 is homogeneous of degree 2: R(s p) = s^2 R(p). Filter p / s with s a power of two
        # (exact scaling), then scale back; an overflow then means the true response is not representable.
        s = 2.0 ** np.floor(np.log2(peak))
        r = self._response((v / s).astype(v.dtype))
        with np.errstate(over="ignore", invalid="ignore"):
            r = (r * s) * s
        if not np.all(np.isfinite(r)):
            raise InputError(f"the response to values up to {peak:g} exceeds the {self.dtype} range; values must "
                             f"stay below about {np.sqrt(np.finfo(self.dtype).max / max(self.g.max(), 1.0)) / 4:g}",
                             key="values")
        return r

    def _response(self, v):
        if v.ndim == 1 or v.shape[0] * self.g.size <= _GATHER_LIMIT:
            return self._gather(v)
        return self._sparse(v)

    filter = __call__


def edge_filter(mesh, values) -> np.ndarray:
    """Eq. 6 of seed 002 before thresholding.

    mesh : SkinMesh. values : (N,) or (T, N) taxel pressures (pascals or counts).
    Returns the response with the shape of ``values`` (unit^2 / metre). Build an
    :class:`EdgeFilter` once to filter many frames of the same mesh.
    """
    return EdgeFilter(mesh)(values)


def threshold(response, epsilon) -> np.ndarray:
    """Eq. 7: ``response > epsilon`` (bool, same shape).

    epsilon : scalar, or (T,) / (T, 1) for one threshold per frame.
    """
    r = np.asarray(response)
    eps = np.asarray(epsilon, dtype=np.float64)
    if r.ndim == 2 and eps.ndim == 1:
        eps = eps[:, None]
    return r > eps


def relative_threshold(response, fraction: float, floor: float = 0.0) -> np.ndarray:
    """Per-frame threshold ``max(fraction * max_i response_i, floor)`` ((T,) or scalar).

    Eq. 7 leaves ``epsilon`` to tuning; Eq. 6 scales with pressure squared, so a
    fraction of the frame's strongest response carries over between forces,
    sensors and units. ``floor`` (same unit as the response) keeps rounding
    residue of a uniform frame from being called an edge.
    """
    if not 0.0 <= fraction <= 1.0:
        raise InputError(f"must be in [0, 1], got {fraction}", key="fraction")
    r = np.asarray(response, dtype=np.float64)
    peak = r.max(axis=-1) if r.shape[-1] else np.zeros(r.shape[:-1])
    return np.maximum(fraction * np.maximum(peak, 0.0), floor)


# ---------------------------------------------------------------------------------------
# Constant-weight local filters (Eq. 4): the same mechanism for the extensions seed 002 names
# ---------------------------------------------------------------------------------------

def local_operator(mesh, weights="mean", *, sigma: float | None = None, self_weight: float | None = None):
    """The Eq. 4 filter ``p_hat = W @ p`` as a CSR (N, N) operator.

    weights :
        ``"mean"``     low-pass: the mean of a taxel and its neighbours (rows sum to 1);
        ``"gaussian"`` noise reduction: ``exp(-D_ij^2 / 2 sigma^2)`` (default sigma: median
                       edge length), normalised per row, self weight 1;
        ``"laplacian"`` graph Laplacian with inverse-distance weights,
                       ``sum_j (p_j - p_i) / D_ij`` (zero on uniform input);
        ``"inverse_distance"`` ``G`` itself (the operator Eq. 6 applies twice);
        a callable ``f(i, j, d) -> w`` over edge arrays (``w_ij`` for neighbours
        j of i); or a CSR matrix on the mesh pattern, used as is.
    self_weight : overrides ``w_ii`` for ``"mean"``/``"gaussian"``/callable.
    Returns ``W`` such that ``(W @ p.T).T`` filters (T, N) frames.
    """
    n = int(mesh.adjacency.shape[0])
    if sp.issparse(weights):
        w = sp.csr_matrix(weights)
        if w.shape != (n, n):
            raise InputError(f"operator shape {w.shape} does not match {n} taxels", key="weights")
        return w
    g = inverse_distance(mesh)
    rows = np.repeat(np.arange(n), np.diff(g.indptr))
    cols = g.indices
    d = 1.0 / g.data
    if weights == "inverse_distance":
        return g
    if weights == "laplacian":
        return (g - sp.diags(np.asarray(g.sum(axis=1)).ravel())).tocsr()
    if weights == "mean":
        off = np.ones_like(d)
        diag = np.ones(n) if self_weight is None else np.full(n, float(self_weight))
    elif weights == "gaussian":
        s = float(np.median(d)) if sigma is None and d.size else float(sigma or 1.0)
        if s <= 0:
            raise InputError(f"must be > 0, got {s}", key="sigma")
        off = np.exp(-0.5 * (d / s) ** 2)
        diag = np.ones(n) if self_weight is None else np.full(n, float(self_weight))
    elif callable(weights):
        off = np.asarray(weights(rows, cols, d), dtype=np.float64).reshape(-1)
        if off.shape != d.shape:
            raise InputError(f"callable returned {off.shape}, expected {d.shape}", key="weights")
        diag = np.zeros(n) if self_weight is None else np.full(n, float(self_weight))
        w = sp.csr_matrix((np.r_[off, diag], (np.r_[rows, np.arange(n)], np.r_[cols, np.arange(n)])),
                          shape=(n, n))
        w.sort_indices()
        return w
    else:
        raise InputError(f"unknown weights {weights!r}; use 'mean', 'gaussian', 'laplacian', "
                         "'inverse_distance', a callable or a CSR matrix", key="weights")
    w = sp.csr_matrix((np.r_[off, diag], (np.r_[rows, np.arange(n)], np.r_[cols, np.arange(n)])),
                      shape=(n, n))
    norm = np.asarray(w.sum(axis=1)).ravel()
    w = sp.diags(1.0 / np.where(norm > 0, norm, 1.0)) @ w  # rows sum to 1 (low-pass)
    w = w.tocsr()
    w.sort_indices()
    return w


def apply_local(operator, values) -> np.ndarray:
    """Apply an Eq. 4 operator to (N,) or (T, N) values; returns the same shape."""
    w = sp.csr_matrix(operator)
    v = _values(values, w.shape[1])
    if v.ndim == 1:
        return w @ v
    return (w @ v.T).T
