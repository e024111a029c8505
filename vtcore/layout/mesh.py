"""The skin mesh of seed 002 (Eqs. 1-2): which taxels are neighbours, and how far apart.

Two ways to triangulate, chosen by :func:`skin_mesh`:

- ``"flat"``: a 2-D Delaunay triangulation of the layout's flat (unrolled) patch
  coordinates, as in seed 002; boundary triangles that are slivers or span a
  gap (an edge much longer than the local taxel spacing) are peeled off.
- ``"surface"``: for layouts that only have 3-D positions (imported files), a
  surface-aware triangulation: the taxels are covered by small overlapping
  charts; each chart keeps only taxels whose normals agree with its centre's
  (so the far side of a cylinder and the other face of a thin part never enter
  it), is projected onto its tangent plane and triangulated with Delaunay; each
  triangle is taken from the chart nearest to it. The same peeling follows.

Duplicate positions (closer than ``tol``) are merged explicitly: only one
representative is triangulated, the duplicates get their representative's
edges (and no triangles), and ``SkinMesh.meta["duplicates"]`` lists them; or,
with ``duplicates="error"``, they are rejected with the indices named.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp
from scipy.spatial import Delaunay, cKDTree

from ..errors import InputError
from ..geometry import cross2
from ..tolerances import TINY
from .model import Layout


class LayoutWarning(UserWarning):
    """Something in a layout or a layout file is suspect but usable (vtcore warning class)."""


@dataclass
class SkinMesh:
    """Taxel graph of a layout.

    positions : (N, 3) metres. normals : (N, 3) unit.
    triangles : (F, 3) int, taxel indices.
    adjacency : (N, N) CSR, 1.0 where two taxels share a mesh edge (E of seed 002, Eq. 1).
    distances : (N, N) CSR, Euclidean edge length in metres on the same pattern (D, Eq. 2).
    meta : how it was built (method, peeled triangles, merged duplicates).
    """

    positions: np.ndarray
    normals: np.ndarray
    triangles: np.ndarray
    adjacency: sp.csr_matrix
    distances: sp.csr_matrix
    meta: dict = field(default_factory=dict)

    @property
    def edges(self) -> np.ndarray:
        """(M, 2) int, each undirected edge once with i < j."""
        coo = sp.triu(self.adjacency, k=1).tocoo()
        order = np.lexsort((coo.col, coo.row))
        return np.column_stack([coo.row[order], coo.col[order]]).astype(np.int64)

    def __len__(self) -> int:
        return len(self.positions)


def _edges_of(tri: np.ndarray) -> np.ndarray:
    e = np.concatenate([tri[:, [0, 1]], tri[:, [1, 2]], tri[:, [2, 0]]])
    e = np.sort(e, axis=1)
    return e[e[:, 0] != e[:, 1]]


def mesh_from_triangles(positions, normals, triangles, extra_edges=None, meta=None) -> SkinMesh:
    """Build E and D (CSR, symmetric) from a triangle list over ``positions`` (N, 3).

    extra_edges : (K, 2) int, edges that belong to no triangle (collinear taxels,
        merged duplicates) but are neighbours all the same.
    """
    positions = np.asarray(positions, dtype=np.float64).reshape(-1, 3)
    tri = np.asarray(triangles, dtype=np.int64).reshape(-1, 3)
    n = len(positions)
    e = _edges_of(tri)
    if extra_edges is not None and len(extra_edges):
        x = np.sort(np.asarray(extra_edges, dtype=np.int64).reshape(-1, 2), axis=1)
        e = np.concatenate([e, x[x[:, 0] != x[:, 1]]])
    e = np.unique(e, axis=0) if len(e) else np.zeros((0, 2), np.int64)
    i = np.concatenate([e[:, 0], e[:, 1]])
    j = np.concatenate([e[:, 1], e[:, 0]])
    length = np.linalg.norm(positions[i] - positions[j], axis=1)
    adj = sp.csr_matrix((np.ones(len(i)), (i, j)), shape=(n, n))
    dist = sp.csr_matrix((length, (i, j)), shape=(n, n))
    dist.sort_indices()
    adj.sort_indices()
    return SkinMesh(positions, np.asarray(normals, dtype=np.float64).reshape(-1, 3), tri, adj, dist,
                    dict(meta or {}))


# --- duplicates ---------------------------------------------------------------------------------
def find_duplicates(positions: np.ndarray, tol: float = 1e-6) -> np.ndarray:
    """(N,) int: the representative (lowest index) of each taxel's group of positions within ``tol`` m."""
    positions = np.asarray(positions, dtype=np.float64)
    n = len(positions)
    rep = np.arange(n)
    if n < 2:
        return rep
    pairs = cKDTree(positions).query_pairs(tol, output_type="ndarray")
    if len(pairs) == 0:
        return rep
    from scipy.sparse.csgraph import connected_components

    g = sp.csr_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])), shape=(n, n))
    _, lab = connected_components(g, directed=False)
    first = np.full(lab.max() + 1, n)
    np.minimum.at(first, lab, np.arange(n))
    return first[lab]


# --- 2-D triangulation with peeling ----------------------------------------------------------------
def _rank2(uv: np.ndarray, rtol: float = 1e-9) -> bool:
    if len(uv) < 3:
        return False
    c = uv - uv.mean(axis=0)
    s = np.linalg.svd(c, compute_uv=False)
    return s[1] > rtol * max(s[0], TINY)


def _chain(points: np.ndarray) -> np.ndarray:
    """Edges joining collinear points in order along their line, (n-1, 2)."""
    if len(points) < 2:
        return np.zeros((0, 2), np.int64)
    c = points - points.mean(axis=0)
    d = np.linalg.svd(c, full_matrices=False)[2][0]
    order = np.argsort(c @ d, kind="stable")
    return np.column_stack([order[:-1], order[1:]]).astype(np.int64)


def delaunay_2d(uv: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Delaunay of ``uv`` (n, 2). Returns ``(triangles (F, 3), chain_edges (K, 2))``: for a
    collinear set there are no triangles and the points are chained along their line."""
    uv = np.asarray(uv, dtype=np.float64)
    if not _rank2(uv):
        return np.zeros((0, 3), np.int64), _chain(uv)
    from scipy.spatial import QhullError

    try:
        tri = Delaunay(uv).simplices.astype(np.int64)
    except QhullError:  # pragma: no cover - rank test above catches the usual cases
        return np.zeros((0, 3), np.int64), _chain(uv)
    return tri, np.zeros((0, 2), np.int64)


def _triangle_geometry(tri: np.ndarray, pts: np.ndarray):
    """Edge lengths (F, 3) (edge k opposite vertex k) and doubled areas (F,)."""
    a, b, c = pts[tri[:, 0]], pts[tri[:, 1]], pts[tri[:, 2]]
    lens = np.stack([np.linalg.norm(b - c, axis=1), np.linalg.norm(c - a, axis=1),
                     np.linalg.norm(a - b, axis=1)], axis=1)
    u, v = b - a, c - a
    area2 = np.abs(cross2(u, v)) if pts.shape[1] == 2 else np.linalg.norm(np.cross(u, v), axis=-1)
    return lens, area2


def peel(tri: np.ndarray, pts: np.ndarray, spacing: np.ndarray, max_edge: float = 1.5,
         max_angle_deg: float = 150.0) -> tuple[np.ndarray, int]:
    """Remove degenerate triangles, then peel boundary triangles that bridge a gap.

    A triangle is degenerate when its area is below 1e-6 of its longest edge squared.
    A boundary triangle (one with an edge no other triangle shares) is peeled when
    that boundary edge is longer than ``max_edge`` times the local spacing
    (``max(spacing[i], spacing[j])``, nearest-neighbour distances) or the angle
    facing it exceeds ``max_angle_deg`` (a sliver along a straight border).
    Repeats until nothing changes. Returns the kept triangles and how many were removed.
    """
    tri = np.asarray(tri, dtype=np.int64).reshape(-1, 3)
    n0 = len(tri)
    if n0 == 0:
        return tri, 0
    lens, area2 = _triangle_geometry(tri, pts)
    good = area2 > 1e-6 * lens.max(axis=1) ** 2
    tri, lens = tri[good], lens[good]
    cos_lim = np.cos(np.deg2rad(max_angle_deg))
    # cosine of the angle at vertex k (facing edge k) by the law of cosines
    l2 = lens ** 2
    with np.errstate(invalid="ignore", divide="ignore"):
        cosang = np.stack([(l2[:, 1] + l2[:, 2] - l2[:, 0]) / (2 * lens[:, 1] * lens[:, 2]),
                           (l2[:, 2] + l2[:, 0] - l2[:, 1]) / (2 * lens[:, 2] * lens[:, 0]),
                           (l2[:, 0] + l2[:, 1] - l2[:, 2]) / (2 * lens[:, 0] * lens[:, 1])], axis=1)
    opp = np.stack([tri[:, [1, 2]], tri[:, [2, 0]], tri[:, [0, 1]]], axis=1)  # (F, 3, 2) edge k
    loc = np.maximum(spacing[opp[..., 0]], spacing[opp[..., 1]])
    bad_edge = (lens > max_edge * loc) | (cosang < cos_lim)
    keep = np.ones(len(tri), bool)
    key = np.sort(opp, axis=2)
    key = key[..., 0] * (len(pts) + 1) + key[..., 1]  # (F, 3) edge ids
    while True:
        k = key[keep].ravel()
        uniq, counts = np.unique(k, return_counts=True)
        on_boundary = np.isin(key, uniq[counts == 1]) & keep[:, None]
        drop = np.any(on_boundary & bad_edge, axis=1)
        if not drop.any():
            break
        keep &= ~drop
    return tri[keep], n0 - int(keep.sum())


def drop_bridges(tri: np.ndarray, chain: np.ndarray, pts: np.ndarray, spacing: np.ndarray,
                 max_edge: float = 1.5) -> tuple[np.ndarray, np.ndarray, int]:
    """Remove triangles and chain edges that bridge between separate groups of taxels.

    Groups are the connected components of the graph of short edges (no longer than
    ``max_edge`` times the local spacing, ``max(spacing[i], spacing[j])``) of ``tri`` and
    ``chain``. An edge joining two groups is long by construction and is no neighbour
    relation: two patches laid side by side with a gap, whose Delaunay fills the gap with
    triangles that peeling cannot reach once they are interior (a merged skin made of
    separately placed patches). Long edges inside one group are kept (the hole where a
    hexagon's central taxel is left out, an iCub module's thermal-pad slots), and so is a
    seam between abutting patches, which is at about the pitch and joins them into one group.
    Returns ``(triangles, chain_edges, removed)``.
    """
    tri = np.asarray(tri, dtype=np.int64).reshape(-1, 3)
    chain = np.asarray(chain, dtype=np.int64).reshape(-1, 2)
    n = len(pts)
    e = np.concatenate([_edges_of(tri), chain]) if len(tri) else chain
    if not len(e):
        return tri, chain, 0
    from scipy.sparse.csgraph import connected_components

    length = np.linalg.norm(pts[e[:, 0]] - pts[e[:, 1]], axis=1)
    short = length <= max_edge * np.maximum(spacing[e[:, 0]], spacing[e[:, 1]])
    g = sp.csr_matrix((np.ones(int(short.sum())), (e[short, 0], e[short, 1])), shape=(n, n))
    _, lab = connected_components(g, directed=False)
    lt = lab[tri] if len(tri) else np.zeros((0, 3), np.int64)
    keep_t = (lt[:, 0] == lt[:, 1]) & (lt[:, 1] == lt[:, 2])
    keep_c = lab[chain[:, 0]] == lab[chain[:, 1]] if len(chain) else np.zeros(0, bool)
    removed = int((~keep_t).sum() + (~keep_c).sum())
    return tri[keep_t], chain[keep_c], removed


def nn_spacing_oriented(pts: np.ndarray, nrm: np.ndarray, cos_limit: float = 0.5) -> np.ndarray:
    """(N,) metres: each taxel's distance to its nearest neighbour among those whose normals
    agree (cosine > ``cos_limit``), so not across a thin part. pts, nrm : (N, 3)."""
    n = len(pts)
    if n < 2:
        return np.ones(n)
    k = int(min(12, n))
    d, idx = cKDTree(pts).query(pts, k)
    ok = (np.einsum("nkj,nj->nk", nrm[idx], nrm) > cos_limit) & (d > 0)
    d = np.where(ok, d, np.inf).min(axis=1)
    fin = np.isfinite(d)
    fallback = np.median(d[fin]) if fin.any() else 1.0
    return np.where(fin, d, fallback)


def nn_spacing(pts: np.ndarray) -> np.ndarray:
    """(N,) distance from each of ``pts`` (N, d) to its nearest other point (repeated points
    take the median of the others; a lone point 1.0)."""
    if len(pts) < 2:
        return np.ones(len(pts))
    d, _ = cKDTree(pts).query(pts, 2)
    s = d[:, 1]
    pos = s[s > 0]
    return np.where(s > 0, s, np.median(pos) if len(pos) else 1.0)


# --- surface-aware triangulation of 3-D positions ---------------------------------------------------
def estimate_normals(positions: np.ndarray, k: int = 8, reference: np.ndarray | None = None) -> np.ndarray:
    """(N, 3) unit normals by PCA of the ``k`` nearest neighbours, oriented like ``reference``
    (N, 3) where given, else away from the centroid."""
    positions = np.asarray(positions, dtype=np.float64)
    n = len(positions)
    k = int(min(max(k, 3), n))
    if n < 3:
        return np.tile([0.0, 0.0, 1.0], (n, 1))
    _, idx = cKDTree(positions).query(positions, k)
    nb = positions[idx] - positions[idx].mean(axis=1, keepdims=True)
    cov = np.einsum("nki,nkj->nij", nb, nb)
    _, vec = np.linalg.eigh(cov)
    nrm = vec[:, :, 0]
    ref = reference if reference is not None else positions - positions.mean(axis=0)
    flip = np.einsum("ij,ij->i", nrm, ref) < 0
    nrm[flip] *= -1
    return nrm


def _tangent_frames(normals: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Two unit tangent vectors (n, 3) each, orthogonal to ``normals``."""
    helper = np.where(np.abs(normals[:, [0]]) < 0.9, [[1.0, 0.0, 0.0]], [[0.0, 1.0, 0.0]])
    t1 = np.cross(normals, helper)
    t1 /= np.linalg.norm(t1, axis=1, keepdims=True)
    return t1, np.cross(normals, t1)


def surface_triangulation(positions: np.ndarray, normals: np.ndarray, spacing: np.ndarray | None = None,
                          chart_radius: float = 3.0, cos_limit: float = 0.5) -> np.ndarray:
    """Triangles (F, 3) over 3-D ``positions`` (N, 3) that follow the surface.

    normals : (N, 3) unit, consistently oriented (outward). spacing : (N,) metres,
    nearest-neighbour distances. chart_radius : charts cover about this many
    spacings. cos_limit : a taxel joins a chart only if its normal is within
    ``arccos(cos_limit)`` (60 degrees) of the chart centre's.
    """
    p = np.asarray(positions, dtype=np.float64)
    nrm = np.asarray(normals, dtype=np.float64)
    n = len(p)
    if n < 3:
        return np.zeros((0, 3), np.int64)
    s = nn_spacing_oriented(p, nrm, cos_limit) if spacing is None else spacing
    centres = _chart_centres(p, nrm, float(np.median(s)) * chart_radius)
    owner, reach = _chart_owners(p, nrm, centres, cos_limit)
    members = cKDTree(p).query_ball_point(p[centres], reach + 3.0 * np.median(s))
    t1, t2 = _tangent_frames(nrm[centres])
    out = []
    # one small Delaunay per chart (about N / 20 charts), not per taxel
    for c, mem in enumerate(members):
        tri = _chart_triangles(p, nrm, centres[c], np.asarray(mem, dtype=np.int64), t1[c], t2[c], cos_limit)
        if not len(tri):
            continue
        # keep a triangle here if this chart owns two of its vertices; if all three owners
        # differ, the owner of its lowest-index vertex decides (each triangle from one chart)
        ow = owner[tri]
        count = (ow == c).sum(axis=1)
        distinct = (ow[:, 0] != ow[:, 1]) & (ow[:, 1] != ow[:, 2]) & (ow[:, 0] != ow[:, 2])
        first = ow[np.arange(len(tri)), np.argmin(tri, axis=1)]
        keep = (count >= 2) | (distinct & (first == c))
        out.append(tri[keep])
    if not out:
        return np.zeros((0, 3), np.int64)
    tri = np.concatenate(out)
    return _orient_and_unfold(np.unique(np.sort(tri, axis=1), axis=0), p, nrm)


def _chart_centres(p: np.ndarray, nrm: np.ndarray, h: float) -> np.ndarray:
    """(C,) sorted indices into ``p`` (N, 3) of the chart centres, for charts about ``h`` metres wide.

    One taxel per occupied (voxel, normal direction) cell, the one nearest the cell's mean; binning
    the normals (6 cube directions) keeps the two faces of a thin part and the two sides of a thin
    tube in different charts even when they share a voxel."""
    vox = np.floor((p - p.min(axis=0)) / h).astype(np.int64)
    nbin = np.argmax(np.concatenate([nrm, -nrm], axis=1), axis=1)
    key = np.column_stack([vox, nbin])
    _, inv = np.unique(key, axis=0, return_inverse=True)
    inv = inv.ravel()
    means = np.zeros((inv.max() + 1, 3))
    np.add.at(means, inv, p)
    means /= np.bincount(inv)[:, None]
    d_to_mean = np.linalg.norm(p - means[inv], axis=1)
    order = np.lexsort((d_to_mean, inv))
    first = np.ones(len(order), bool)
    first[1:] = inv[order][1:] != inv[order][:-1]
    return np.sort(order[first])


def _chart_owners(p: np.ndarray, nrm: np.ndarray, centres: np.ndarray,
                  cos_limit: float) -> tuple[np.ndarray, np.ndarray]:
    """Each taxel's chart: (N,) the index into ``centres`` of its nearest centre whose normal agrees
    (-1 for none), which decides where its triangles come from; and (C,) metres, each chart's reach
    (the farthest taxel it owns)."""
    n = len(p)
    ctree = cKDTree(p[centres])
    kk = min(16, len(centres))
    dc, ic = ctree.query(p, kk)
    dc, ic = dc.reshape(n, kk), ic.reshape(n, kk)
    agree = np.einsum("nkj,nj->nk", nrm[centres][ic], nrm) > cos_limit
    dc = np.where(agree, dc, np.inf)
    reach = np.zeros(len(centres))
    best = np.argmin(dc, axis=1)
    owner = np.where(np.isfinite(dc[np.arange(n), best]), ic[np.arange(n), best], -1)
    np.maximum.at(reach, owner[owner >= 0], dc[np.arange(n), best][owner >= 0])
    return owner, reach


def _chart_triangles(p: np.ndarray, nrm: np.ndarray, centre: int, mem: np.ndarray, t1: np.ndarray,
                     t2: np.ndarray, cos_limit: float) -> np.ndarray:
    """(F, 3) taxel indices: the Delaunay triangulation of one chart, its members ``mem`` whose
    normal agrees with taxel ``centre``'s projected onto the tangent plane (``t1``, ``t2`` (3,))."""
    mem = mem[nrm[mem] @ nrm[centre] > cos_limit]
    if len(mem) < 3:
        return np.zeros((0, 3), np.int64)
    d = p[mem] - p[centre]
    uv = np.column_stack([d @ t1, d @ t2])
    tri, _ = delaunay_2d(uv)
    if not len(tri):
        return np.zeros((0, 3), np.int64)
    return mem[tri]


def _orient_and_unfold(tri: np.ndarray, p: np.ndarray, nrm: np.ndarray) -> np.ndarray:
    """``tri`` (F, 3) each wound to face like the mean normal of its vertices, less the few that
    fold across a crease (a triangle must itself face like its vertices)."""
    a, b, cc = p[tri[:, 0]], p[tri[:, 1]], p[tri[:, 2]]
    fn = np.cross(b - a, cc - a)
    vn = nrm[tri].sum(axis=1)
    flip = np.einsum("ij,ij->i", fn, vn) < 0
    tri[flip] = tri[flip][:, [0, 2, 1]]
    fnu = fn / np.maximum(np.linalg.norm(fn, axis=1, keepdims=True), TINY)
    ok = np.all(np.abs(np.einsum("ij,ikj->ik", fnu, nrm[tri])) > 0.3, axis=1)
    return tri[ok]


def skin_mesh(layout: Layout, *, method: str = "auto", duplicates: str = "merge", tol: float = 1e-6,
              max_edge: float = 1.5) -> SkinMesh:
    """The skin mesh of ``layout`` (seed 002, Eqs. 1-2).

    method : ``"auto"`` (flat Delaunay when the layout has flat coordinates,
        else surface-aware), ``"flat"`` or ``"surface"``.
    duplicates : ``"merge"`` (default; warns with a :class:`LayoutWarning`) or ``"error"``.
    tol : metres, positions closer than this are duplicates.
    max_edge : boundary edges longer than this many local spacings are peeled off.
    """
    if method not in ("auto", "flat", "surface"):
        raise InputError(f"unknown method {method!r}; use auto, flat or surface", key="method")
    if duplicates not in ("merge", "error"):
        raise InputError(f"duplicates must be 'merge' or 'error', got {duplicates!r}", key="duplicates")
    pos = layout.positions
    n = len(pos)
    rep = find_duplicates(pos, tol)
    dup = np.flatnonzero(rep != np.arange(n))
    if len(dup) and duplicates == "error":
        pairs = ", ".join(f"{int(d)}={int(rep[d])}" for d in dup[:10])
        raise InputError(f"{len(dup)} taxels repeat another's position within {tol} m ({pairs}"
                         f"{', ...' if len(dup) > 10 else ''}); pass duplicates='merge' to merge them",
                         key="positions")
    if len(dup):
        warnings.warn(f"skin_mesh: {len(dup)} duplicate taxel positions merged into their first occurrence",
                      LayoutWarning, stacklevel=2)
    uniq = np.flatnonzero(rep == np.arange(n))
    use_flat = method == "flat" or (method == "auto" and layout.flat is not None)
    if method == "flat" and layout.flat is None:
        raise InputError("method='flat' needs flat coordinates; use method='surface'", key="flat")
    # the triangulation of the unique taxels: (triangles, chain edges, peeled, bridges removed, lonely linked)
    built = _triangulate_flat(layout.flat[uniq], tol, max_edge) if use_flat else None
    use_flat = built is not None
    if not use_flat:
        built = _triangulate_surface(pos[uniq], layout.normals[uniq], max_edge)
    tri, chain, peeled, bridges, n_lonely = built
    tri = uniq[tri] if len(tri) else np.zeros((0, 3), np.int64)
    chain = uniq[chain] if len(chain) else chain
    extra = [chain]
    if len(dup):
        # each duplicate inherits its representative's edges, and is joined to it
        base = mesh_from_triangles(pos, layout.normals, tri, chain)
        rows = base.adjacency[rep[dup]].tocoo()
        # (not to the representative itself: a zero distance would break D-weighted filters)
        extra.append(np.column_stack([dup[rows.row], rows.col]))
    meta = {"method": "flat" if use_flat else "surface", "peeled": int(peeled), "lonely_linked": n_lonely,
            "bridges_removed": bridges,
            "duplicates": [[int(d), int(rep[d])] for d in dup]}
    return mesh_from_triangles(pos, layout.normals, tri, np.concatenate(extra) if extra else None, meta)


def _triangulate_flat(uv: np.ndarray, tol: float, max_edge: float) -> tuple | None:
    """``(triangles (F, 3), chain (K, 2), peeled, bridges, 0)`` over the flat coordinates ``uv``
    (N, 2) of the unique taxels, peeled and without bridges; None where two taxels share a flat
    point (distinct 3-D positions cannot both be Delaunay vertices there: use the surface)."""
    frep = find_duplicates(uv, tol)
    if np.any(frep != np.arange(len(uv))):
        return None
    tri, chain = delaunay_2d(uv)
    spacing = nn_spacing(uv)
    tri, peeled = peel(tri, uv, spacing, max_edge)
    tri, chain, bridges = drop_bridges(tri, chain, uv, spacing, max_edge)
    return tri, chain, peeled, bridges, 0


def _triangulate_surface(p: np.ndarray, nrm: np.ndarray, max_edge: float) -> tuple:
    """``(triangles (F, 3), chain (K, 2), peeled, bridges, lonely linked)`` over the 3-D positions
    ``p`` (N, 3) of the unique taxels with their normals ``nrm`` (N, 3) as given: a plane is
    triangulated in its own 2-D basis, anything else by :func:`surface_triangulation`."""
    nrm = _usable_normals(p, nrm)
    chain = np.zeros((0, 2), np.int64)
    if _planar(p):
        c = p - p.mean(axis=0)
        basis = np.linalg.svd(c, full_matrices=False)[2][:2]
        tri, chain = delaunay_2d(c @ basis.T)
    else:
        tri = surface_triangulation(p, nrm)
        if not len(tri):
            chain = _chain(p)
    spacing = nn_spacing_oriented(p, nrm)
    tri, peeled = peel(tri, p, spacing, max_edge)
    tri, chain, bridges = drop_bridges(tri, chain, p, spacing, max_edge)
    chain, n_lonely = _link_lonely(tri, chain, p, nrm, spacing, max_edge)
    return tri, chain, peeled, bridges, n_lonely


def _usable_normals(p: np.ndarray, nrm: np.ndarray) -> np.ndarray:
    """(N, 3) unit normals: ``nrm`` normalised, or estimated (oriented like the given ones) where they
    are unknown, placeholders (one normal for a curved set) or not unit length."""
    norms = np.linalg.norm(nrm, axis=1)
    if np.any(np.abs(norms - 1) > 0.05) or len(np.unique(np.round(nrm, 6), axis=0)) == 1 and not _planar(p):
        return estimate_normals(p, reference=np.where(norms[:, None] > 0.5, nrm, 0) if np.any(norms > 0.5)
                                else None)
    return nrm / norms[:, None]


def _link_lonely(tri: np.ndarray, chain: np.ndarray, p: np.ndarray, nrm: np.ndarray, spacing: np.ndarray,
                 max_edge: float) -> tuple[np.ndarray, int]:
    """``chain`` with the taxels that no triangle or edge reaches joined by plain edges to their
    close (within ``max_edge`` spacings), like-facing neighbours, and how many there were.

    A safety net: such a taxel is joined to the graph rather than left out of it."""
    lonely = np.setdiff1d(np.arange(len(p)), np.concatenate([tri.ravel(), chain.ravel()]))
    if not (len(lonely) and len(p) > 1):
        return chain, 0
    k = int(min(7, len(p)))
    d, idx = cKDTree(p).query(p[lonely], k)
    d, idx = d.reshape(len(lonely), k), idx.reshape(len(lonely), k)
    ok = (d > 0) & (d <= max_edge * spacing[lonely, None]) & \
        (np.einsum("nkj,nj->nk", nrm[idx], nrm[lonely]) > 0.5)
    r, c = np.nonzero(ok)
    chain = np.concatenate([chain, np.column_stack([lonely[r], idx[r, c]])]).astype(np.int64)
    return chain, int(len(lonely))


def _planar(p: np.ndarray, rtol: float = 1e-3) -> bool:
    """True when the points lie in a plane (smallest spread below ``rtol`` of the largest)."""
    if len(p) < 4:
        return True
    s = np.linalg.svd(p - p.mean(axis=0), compute_uv=False)
    return s[2] <= rtol * s[0]
