"""Loop subdivision of the skin mesh as a sparse linear operator.

Seed 002 (§6) names the limitation of its filter: edges land exactly on taxel
positions. Its proposed fix is to resample and interpolate on the 3-D mesh
itself. Loop subdivision does that on the triangle mesh, without flattening:
every new vertex (and every value on it) is a fixed linear combination of the
coarse ones, so one CSR matrix ``S`` (N_fine x N) maps taxel pressures
``(T, N)`` to fine-mesh values in a single sparse product per batch.

Why not ``trimesh.remesh.subdivide_loop``: it subdivides 3-D coordinates only
and returns no operator; we need the same weights applied to pressure frames.
The stencils are Loop's (1987): odd vertices 3/8, 3/8, 1/8, 1/8 (boundary 1/2,
1/2); even vertices ``(1 - k beta) v + beta sum(neighbours)`` with Loop's beta
(boundary 3/4, 1/8, 1/8).
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp


def _loop_once(n: int, tri: np.ndarray):
    """One Loop step: returns ``S`` ((n + n_edges) x n, CSR) and the new triangles."""
    tri = np.asarray(tri, dtype=np.int64).reshape(-1, 3)
    if len(tri) == 0:
        return sp.identity(n, format="csr"), tri
    fe = np.stack([tri[:, [0, 1]], tri[:, [1, 2]], tri[:, [2, 0]]], axis=1)  # (F, 3, 2)
    opp = tri[:, [2, 0, 1]]                                                   # vertex opposite each edge
    flat = np.sort(fe.reshape(-1, 2), axis=1)
    edges, inv, count = np.unique(flat, axis=0, return_inverse=True, return_counts=True)
    inv = inv.reshape(-1)
    ne = len(edges)
    # odd (edge) vertices
    rows, cols, vals = [], [], []
    e_idx = np.arange(ne)
    interior = count == 2
    w_end = np.where(interior, 3.0 / 8.0, 0.5)
    rows += [n + e_idx, n + e_idx]
    cols += [edges[:, 0], edges[:, 1]]
    vals += [w_end, w_end]
    opp_flat = opp.reshape(-1)
    face_edge_interior = interior[inv]
    rows.append(n + inv[face_edge_interior])
    cols.append(opp_flat[face_edge_interior])
    vals.append(np.full(int(face_edge_interior.sum()), 1.0 / 8.0))
    # even (original) vertices
    deg = np.bincount(edges.ravel(), minlength=n)
    bnd = edges[count == 1]
    bdeg = np.bincount(bnd.ravel(), minlength=n)
    k = np.maximum(deg, 1).astype(np.float64)
    beta = (5.0 / 8.0 - (3.0 / 8.0 + 0.25 * np.cos(2.0 * np.pi / k)) ** 2) / k
    is_int = (bdeg == 0) & (deg > 0)
    is_bnd = bdeg == 2
    keep = ~(is_int | is_bnd)  # isolated taxels, non-manifold boundary: left where they are
    ii = np.concatenate([edges[:, 0], edges[:, 1]])
    jj = np.concatenate([edges[:, 1], edges[:, 0]])
    sel = is_int[ii]
    rows.append(ii[sel]); cols.append(jj[sel]); vals.append(beta[ii[sel]])
    bi = np.concatenate([bnd[:, 0], bnd[:, 1]])
    bj = np.concatenate([bnd[:, 1], bnd[:, 0]])
    selb = is_bnd[bi]
    rows.append(bi[selb]); cols.append(bj[selb]); vals.append(np.full(int(selb.sum()), 1.0 / 8.0))
    diag = np.where(is_int, 1.0 - k * beta, np.where(is_bnd, 0.75, 1.0))
    diag = np.where(keep, 1.0, diag)
    rows.append(np.arange(n)); cols.append(np.arange(n)); vals.append(diag)
    s = sp.csr_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))),
                      shape=(n + ne, n))
    s.sum_duplicates()
    o = n + inv.reshape(-1, 3)  # odd vertex of edges (0,1), (1,2), (2,0) of each face
    new = np.concatenate([
        np.column_stack([tri[:, 0], o[:, 0], o[:, 2]]),
        np.column_stack([o[:, 0], tri[:, 1], o[:, 1]]),
        np.column_stack([o[:, 2], o[:, 1], tri[:, 2]]),
        np.column_stack([o[:, 0], o[:, 1], o[:, 2]]),
    ])
    return s, new


def loop_subdivision(n: int, triangles, levels: int = 1):
    """Loop subdivision operator of a triangle mesh with ``n`` vertices.

    triangles : (F, 3) int. levels : number of subdivision steps (>= 0).
    Returns ``S`` (N_fine, n) CSR (rows sum to 1) and the fine triangles (F * 4**levels, 3).
    ``S @ positions`` gives the fine vertices, ``(S @ values.T).T`` the fine values.
    """
    s = sp.identity(n, format="csr")
    tri = np.asarray(triangles, dtype=np.int64).reshape(-1, 3)
    m = n
    for _ in range(int(levels)):
        step, tri = _loop_once(m, tri)
        s = (step @ s).tocsr()
        m = step.shape[0]
    s.sort_indices()
    return s, tri
