"""Mesh repair before the solvers: merge, drop degenerate and duplicate faces, split
non-manifold edges and bowtie vertices, subdivide coarse CAD faces (simplifying big meshes
is :mod:`.simplify`).

Every function returns what it did so that the placement report can say it (repairs are
never silent). mesh : trimesh.Trimesh, metres.
"""

from __future__ import annotations

import numpy as np

from ..errors import InputError

MM_SUSPECT = 5.0  #: metres: a robot part larger than this was most likely exported in millimetres
MAX_INPUT_FACES = 2_000_000  #: faces a placement accepts (the benchmark goes to 200k within 2 GB)

def clean_mesh(mesh):
    """A copy of ``mesh`` fit for the solvers: duplicate vertices merged, degenerate and
    duplicate faces removed, unreferenced vertices dropped. Returns ``(mesh, notes)``."""
    import trimesh

    notes = []
    v = np.asarray(mesh.vertices, dtype=np.float64)
    f = np.asarray(mesh.faces, dtype=np.int64)
    if not len(f):
        raise InputError("the mesh has no faces", key="mesh")
    if len(f) > MAX_INPUT_FACES:
        raise InputError(f"the mesh has {len(f)} faces, more than the {MAX_INPUT_FACES} a placement is sized "
                         "for; simplify it (or select the part to cover) first", key="mesh")
    if not np.isfinite(v).all():
        raise InputError("the mesh has non-finite vertices", key="mesh")
    extent = float(np.ptp(v, axis=0).max()) if len(v) else 0.0
    if extent > MM_SUSPECT:
        notes.append(f"the mesh is {extent:.3g} m across: it looks like millimetres read as metres; "
                     "scale it by 0.001 (--scale 0.001)")
    m = trimesh.Trimesh(v, f, process=True, validate=False)  # merges duplicate vertices
    area = m.area_faces
    scale = max(float(np.ptp(m.vertices, axis=0).max()), 1e-12)
    good = area > 1e-14 * scale ** 2
    mf = np.asarray(m.faces, dtype=np.int64)
    # each face's corners sorted (min, middle, max) without a row sort of (F, 3)
    lo, hi = mf.min(axis=1), mf.max(axis=1)
    mid = mf.sum(axis=1) - lo - hi
    good &= (lo != mid) & (mid != hi)
    if (~good).any():
        notes.append(f"removed {int((~good).sum())} degenerate faces")
    first = np.unique(face_keys(lo, mid, hi, len(m.vertices)), return_index=True)[1]
    dup = np.ones(len(mf), bool)
    dup[first] = False
    if (dup & good).any():
        notes.append(f"removed {int((dup & good).sum())} duplicate faces")
    good &= ~dup
    if not good.any():
        raise InputError(f"the mesh has no faces left after removing {int((~good).sum())} degenerate or "
                         "duplicate ones", key="mesh")
    if not good.all():
        m = trimesh.Trimesh(m.vertices, mf[good], process=False, validate=False)
    if np.count_nonzero(np.bincount(np.asarray(m.faces).ravel(), minlength=len(m.vertices))) < len(m.vertices):
        m.remove_unreferenced_vertices()
    # else the merged mesh is already clean: it keeps the triangles and areas trimesh cached on it
    if len(good) == len(f):
        # trimesh's vertex merge keeps the faces in order, so clean face i is input face kept[i]:
        # callers map per-face data (a fill's region) through it, not by a nearest-centre search
        remember(m, "source_faces", (data_hash(mesh), np.flatnonzero(good)))
    return m, notes


def data_hash(mesh):
    """``hash(mesh)`` (trimesh: of its vertices and faces), or None for an unhashable object."""
    try:
        return hash(mesh)
    except TypeError:
        return None


def face_submesh(mesh, faces: np.ndarray):
    """The part of ``mesh`` made of ``faces`` (sorted face indices), its vertices the used ones
    in their order: the arrays trimesh's ``submesh([faces], append=True)`` makes, without the
    face normals, visuals and metadata it copies along (computing the whole mesh's normals for
    it cost 0.1 s at 200k faces)."""
    import trimesh

    f = np.asarray(mesh.faces)[np.asarray(faces)]
    used = np.flatnonzero(np.bincount(f.ravel(), minlength=len(mesh.vertices)))
    remap = np.zeros(len(mesh.vertices), np.int64)
    remap[used] = np.arange(len(used))
    return trimesh.Trimesh(np.asarray(mesh.vertices)[used], remap[f], process=False, validate=False)


def face_keys(lo: np.ndarray, mid: np.ndarray, hi: np.ndarray, n: int) -> np.ndarray:
    """(F,) keys equal for faces with the same sorted corners ``lo < mid < hi`` (F,) each, over
    ``n`` vertices, ordered like the rows (lo, mid, hi): one int64 when n**3 fits (a sort of
    24-byte void rows, as ``unique(axis=0)`` does, is ~5x slower), else the rows as void."""
    if n ** 3 < 2 ** 63:
        return (lo * n + mid) * n + hi
    rows = np.ascontiguousarray(np.column_stack([lo, mid, hi]).astype(">i8"))  # big-endian: bytes sort as numbers
    return rows.view(np.dtype((np.void, 24))).ravel()


def remember(mesh, name: str, value):
    """Keep ``value`` on ``mesh`` under ``name`` with the hash of the mesh's data, so that a
    changed mesh does not answer from it (see :func:`recall`)."""
    try:
        mesh.__dict__.setdefault("_vtcore_cache", {})[name] = (hash(mesh), value)
    except AttributeError:  # pragma: no cover - objects without a __dict__
        pass
    return value


def recall(mesh, name: str):
    """What :func:`remember` kept on ``mesh`` under ``name``, or None if the mesh changed since."""
    hit = getattr(mesh, "__dict__", {}).get("_vtcore_cache", {}).get(name)
    return hit[1] if hit is not None and hit[0] == hash(mesh) else None


def source_faces(clean, mesh) -> np.ndarray:
    """(F_clean,) int: the face of ``mesh`` each face of ``clean`` (made from ``mesh`` by
    :func:`clean_mesh`) came from; for a ``clean`` made otherwise, the face with the nearest
    centre (a k-d tree search)."""
    hit = recall(clean, "source_faces")
    if hit is not None and hit[0] is not None and hit[0] == data_hash(mesh):  # made from this very mesh
        return hit[1]
    from scipy.spatial import cKDTree

    return cKDTree(np.asarray(mesh.triangles_center)).query(np.asarray(clean.triangles_center))[1]


def edge_keys(faces: np.ndarray, directed: bool = False, n: int | None = None) -> np.ndarray:
    """(3F,) int64 key of each face's edges (edge k of face f at row k * F + f), equal for the
    same vertex pair (in the same direction if ``directed``): ``a * n + b`` for the edge a -> b
    (a < b unless ``directed``), n the vertex count (default max index + 1). One int64 per edge: numpy's
    ``unique(axis=0)`` on (3F, 2) rows sorts ~10x slower, seconds on a 200k-face mesh."""
    f = np.asarray(faces, dtype=np.int64)
    e = np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]])
    if not directed:
        e = np.sort(e, axis=1)
    if n is None:
        n = int(f.max()) + 1 if len(f) else 1
    return e[:, 0] * n + e[:, 1]


def nonmanifold_edge_count(faces: np.ndarray) -> int:
    _, c = np.unique(edge_keys(faces), return_counts=True)
    return int((c > 2).sum())


class EdgeTable:
    """The undirected edges of a mesh's faces (F, 3), sorted once.

    Half-edge h is edge h // F of face h % F (the order of :func:`edge_keys`), from vertex
    ``start(h)``. ``key`` (3F,) int64 its undirected key, ``order`` (3F,) the stable argsort of
    ``key``, ``inv`` (3F,) its edge id, ``counts`` (E,) faces per edge. Split, bowtie, Euler,
    boundary and adjacency checks of one mesh all read the same table (each sorted the 3F keys
    itself: a quarter of a 200k-face fill's preparation). About 17 bytes per half-edge.
    """

    def __init__(self, faces: np.ndarray, n_vertices: int):
        self.faces = f = np.asarray(faces, dtype=np.int64)
        self.n_faces = nf = len(f)
        n = max(int(n_vertices), int(f.max()) + 1 if nf else 1)
        a = f.T.ravel()  # start of half-edge h = k * F + face: corner k
        b = np.roll(f, -1, axis=1).T.ravel()  # its end: corner (k + 1) % 3
        self.key = np.minimum(a, b) * n + np.maximum(a, b)
        del a, b
        self.order = np.argsort(self.key, kind="stable")
        ks = self.key[self.order]
        first = np.ones(len(ks), bool)
        first[1:] = ks[1:] != ks[:-1]
        idx = np.cumsum(first) - 1
        self.inv = np.empty(len(ks), np.int64)
        self.inv[self.order] = idx
        self.counts = np.bincount(idx, minlength=int(idx[-1]) + 1 if len(idx) else 0)
        self.n_edges = len(self.counts)

    def start(self, h: np.ndarray) -> np.ndarray:
        """The vertex each half-edge of ``h`` (n,) starts at."""
        return self.faces[h % self.n_faces, h // self.n_faces]

    def pairs(self) -> tuple[np.ndarray, np.ndarray]:
        """``(a, b)`` (P,) each: the two half-edges of every edge that has exactly two."""
        ks = self.key[self.order]
        pair = np.flatnonzero(ks[1:] == ks[:-1])
        pair = pair[self.counts[self.inv[self.order[pair]]] == 2]
        return self.order[pair], self.order[pair + 1]


def edge_table(mesh) -> EdgeTable:
    """The :class:`EdgeTable` of ``mesh``, built once per mesh data (cached on the object)."""
    t = recall(mesh, "edge_table")
    if t is None:
        t = remember(mesh, "edge_table", EdgeTable(mesh.faces, len(mesh.vertices)))
    return t


def face_pairs(mesh) -> np.ndarray:
    """(P, 2) int64: the faces of ``mesh`` that share an edge no third face has, as trimesh's
    ``face_adjacency`` gives them (the same pairs, from the cached :class:`EdgeTable`: trimesh
    sorts the edges again, 0.1-0.3 s at 200k faces)."""
    t = edge_table(mesh)
    a, b = t.pairs()
    fa, fb = a % t.n_faces, b % t.n_faces
    keep = fa != fb
    return np.sort(np.column_stack([fa[keep], fb[keep]]), axis=1)


def split_nonmanifold(mesh):
    """Faces sharing an edge with more than one other face are separated along that edge
    (each face fan gets its own copy of the edge's vertices), so the result is edge-manifold."""
    import trimesh

    f = np.asarray(mesh.faces)
    t = edge_table(mesh)
    cnt = t.counts[t.inv]
    # an edge shared by more than two faces, or twice in the same direction (flipped neighbours):
    # in an edge of two half-edges (adjacent in the sorted order) both start at the same vertex
    a, b = t.pairs()
    bad_edge = cnt > 2
    same_dir = t.start(a) == t.start(b)
    bad_edge[a[same_dir]] = True
    bad_edge[b[same_dir]] = True
    if not bad_edge.any():
        return mesh, 0
    nf = len(f)
    bad_face = np.zeros(nf, bool)
    bad_face[np.arange(3 * nf)[bad_edge] % nf] = True
    # give every face touching a non-manifold edge its own vertices (cheap, local, and the
    # log map treats those faces as a separate boundary, which is what a PCB would do there)
    v = np.asarray(mesh.vertices)
    idx = np.flatnonzero(bad_face)
    newv = v[f[idx].ravel()]
    f2 = f.copy()
    f2[idx] = len(v) + np.arange(3 * len(idx)).reshape(-1, 3)
    out = trimesh.Trimesh(np.vstack([v, newv]), f2, process=False, validate=False)
    out.remove_unreferenced_vertices()
    return out, int(len(idx))


def split_bowties(mesh):
    """Give every fan of faces round a vertex its own copy of the vertex when more than one fan
    meets there (a bowtie: two fans touching at a point, with or without a boundary);
    geometry-central needs manifold vertices. Returns ``(mesh, vertices split)``.

    Fans are the connected components of the (face, corner) graph whose links are the edges two
    faces share; scipy's connected_components finds them all at once.
    """
    import scipy.sparse as sp
    import trimesh
    from scipy.sparse.csgraph import connected_components

    f = np.asarray(mesh.faces, dtype=np.int64)
    nf = len(f)
    t = edge_table(mesh)
    # corner id = 3 * face + k; faces sharing an edge link their corners at both ends of it
    corner_a = (3 * np.arange(nf)[None, :] + np.arange(3)[:, None]).ravel()
    corner_b = (3 * np.arange(nf)[None, :] + (np.arange(3)[:, None] + 1) % 3).ravel()
    nv = len(mesh.vertices)
    order = t.order
    ks = t.key[order]
    same = np.flatnonzero(ks[1:] == ks[:-1])
    a, b = order[same], order[same + 1]
    # the corners of a and b at each vertex of the shared edge
    va = np.where(t.start(a) == t.start(b), 0, 1)  # b's corner at a's first vertex
    rows = np.concatenate([corner_a[a], corner_b[a]])
    cols = np.concatenate([np.where(va == 0, corner_a[b], corner_b[b]), np.where(va == 0, corner_b[b], corner_a[b])])
    g = sp.coo_matrix((np.ones(len(rows)), (rows, cols)), shape=(3 * nf, 3 * nf))
    _, lab = connected_components(g, directed=False)
    vert = f.ravel()  # vertex of corner c = 3 * face + k
    # fans per vertex: every corner of a fan is at the fan's vertex, so a vertex's fans are the
    # labels that name it (no sort of the 3F (vertex, fan) pairs unless some vertex has two)
    nl = int(lab.max()) + 1
    fan_vertex = np.empty(nl, np.int64)
    fan_vertex[lab] = vert
    fans = np.bincount(fan_vertex, minlength=nv)
    if not (fans > 1).any():
        return mesh, 0
    pk = np.unique(vert.astype(np.int64) * nl + lab)  # (vertex, fan) pairs, sorted
    pair = np.column_stack([pk // nl, pk % nl])
    # the first fan of each vertex keeps it; every other fan gets a new vertex
    first = np.ones(len(pair), bool)
    first[1:] = pair[1:, 0] != pair[:-1, 0]
    new_id = np.full(len(pair), -1, np.int64)
    extra = np.flatnonzero(~first)
    new_id[first] = pair[first, 0]
    new_id[extra] = nv + np.arange(len(extra))
    idx = np.searchsorted(pk, vert * nl + lab)
    f2 = new_id[idx].reshape(-1, 3)
    v = np.asarray(mesh.vertices)
    v2 = np.vstack([v, v[pair[extra, 0]]])
    out = trimesh.Trimesh(v2, f2, process=False, validate=False)
    return out, int((fans > 1).sum())


def refine(mesh, resolution: float, max_faces: int = 300_000):
    """Split every edge longer than ``resolution`` metres at its midpoint until none is (the
    resolution is coarsened if the result would exceed ``max_faces``); the new faces lie on the
    old ones, so the surface does not move.

    Only the longest edge of a face is split per round (longest-edge bisection) and non-Delaunay
    edges between nearly coplanar faces are flipped between rounds: a CAD needle (3 mm x 200 mm)
    becomes triangles about 3 mm across, where uniform midpoint subdivision (trimesh's
    ``subdivide_to_size``) makes 4^k needles; the heat method and the point location are poor on
    needles, and they cost faces.
    """
    import trimesh

    v = np.asarray(mesh.vertices, dtype=np.float64)
    f = np.asarray(mesh.faces, dtype=np.int64)
    if not len(f):
        return mesh
    longest = longest_edges(v, f)
    res = float(resolution)
    if longest.max() <= res:  # nothing to split (the budget below only ever coarsens res)
        return mesh
    # a budget check before any allocation: the result has about area / (res^2 / 4) faces, plus
    # a row of faces along each long edge
    res = refine_resolution(np.asarray(mesh.area_faces), longest, res, max_faces)
    if longest.max() <= res:
        return mesh
    # only faces with an edge longer than res take part (splits and flips): an edge they share
    # with any other face is at most res long, so it is never split or flipped and the two parts
    # still fit; a big CAD mesh with a few long cap faces costs what the cap costs
    done = f[longest <= res]
    f = f[longest > res]
    for _ in range(200):
        f = delaunay_flips(v, f)
        nv = len(v)
        uk, inv = np.unique(edge_keys(f, n=nv), return_inverse=True)  # edge k of face i at k*F+i
        uniq = np.column_stack([uk // nv, uk % nv])
        inv = inv.ravel()
        length = np.linalg.norm(v[uniq[:, 0]] - v[uniq[:, 1]], axis=1)
        # only the longest edge of a face is split (longest-edge bisection, Rivara): splitting
        # both long sides of a needle would cut off a needle half as wide, again and again
        lf = length[inv].reshape(3, -1)
        longest_edge = inv.reshape(3, -1)[np.argmax(lf, axis=0), np.arange(lf.shape[1])]
        mark = np.zeros(len(uniq), bool)
        mark[longest_edge] = True
        mark &= length > res
        if not mark.any():
            break
        mid_id = np.full(len(uniq), -1, np.int64)
        mid_id[mark] = len(v) + np.arange(int(mark.sum()))
        v = np.vstack([v, (v[uniq[mark, 0]] + v[uniq[mark, 1]]) / 2])
        nf = len(f)
        m = mid_id[inv].reshape(3, nf).T  # (F, 3): midpoint of edge (0,1), (1,2), (2,0) or -1
        has = m >= 0
        cnt = has.sum(axis=1)
        out = [f[cnt == 0]]
        # one split edge: rotate it to (0, 1)
        for k in range(3):
            sel = (cnt == 1) & has[:, k]
            a, b, c = f[sel, k], f[sel, (k + 1) % 3], f[sel, (k + 2) % 3]
            mm = m[sel, k]
            out += [np.column_stack([a, mm, c]), np.column_stack([mm, b, c])]
        # two split edges: rotate the unsplit one to (1, 2); cut the quad on its shorter diagonal
        for k in range(3):
            sel = (cnt == 2) & ~has[:, (k + 1) % 3]
            a, b, c = f[sel, k], f[sel, (k + 1) % 3], f[sel, (k + 2) % 3]
            mab, mca = m[sel, k], m[sel, (k + 2) % 3]
            d1 = np.linalg.norm(v[mab] - v[c], axis=1)
            d2 = np.linalg.norm(v[b] - v[mca], axis=1)
            short = d1 <= d2
            out += [np.column_stack([a, mab, mca]),
                    np.where(short[:, None], np.column_stack([mab, b, c]), np.column_stack([mab, b, mca])),
                    np.where(short[:, None], np.column_stack([mab, c, mca]), np.column_stack([b, c, mca]))]
        sel = cnt == 3
        a, b, c = f[sel, 0], f[sel, 1], f[sel, 2]
        m01, m12, m20 = m[sel, 0], m[sel, 1], m[sel, 2]
        out += [np.column_stack([a, m01, m20]), np.column_stack([m01, b, m12]),
                np.column_stack([m20, m12, c]), np.column_stack([m01, m12, m20])]
        f = np.concatenate(out)
    return trimesh.Trimesh(v, np.concatenate([done, f]), process=False, validate=False)


def refine_faces(area: np.ndarray, longest: np.ndarray, res: float) -> float:
    """About how many faces :func:`refine` makes of faces with ``area`` (F,) square metres and
    longest edges ``longest`` (F,) metres at ``res`` metres: a face with an edge longer than
    ``res`` becomes at most about area / (res^2 / 8) faces (longest-edge bisection leaves halves
    of res^2 / 4 triangles: res^2 / 4 undercounted a 1 m face split to 2 mm by 40 %) plus a row
    along its long edge; the others stay one face each."""
    split = longest > res
    return float((area[split] / (0.125 * res ** 2) + 2 * longest[split] / res).sum() + len(area))


def refine_resolution(area: np.ndarray, longest: np.ndarray, resolution: float, max_faces: int) -> float:
    """The finest resolution (metres, ``resolution`` coarsened by factors of 1.25) at which
    :func:`refine` makes at most ``max_faces`` faces of faces with ``area`` (F,) and ``longest``
    (F,), or the longest edge itself (nothing split) when even that is over: a mesh that already
    has more faces than the budget is not refined (it was an unbounded loop that overflowed to
    inf on a 600k-face scan with the 300k budget). At most log(longest / resolution) / log(1.25)
    steps."""
    res, top = float(resolution), float(longest.max()) if len(longest) else 0.0
    if not (res > 0 and np.isfinite(res)):
        raise InputError(f"the refinement resolution must be a positive finite length, got {resolution!r}",
                         key="resolution")
    while res < top and refine_faces(area, longest, res) > max_faces:
        res = min(res * 1.25, top)
    return res


def longest_edges(v: np.ndarray, f: np.ndarray) -> np.ndarray:
    """(F,) metres: the longest edge of each face ``f`` (F, 3) over vertices ``v`` (V, 3).
    Squared lengths summed per axis (the same sums, bit for bit, as ``np.linalg.norm`` of the
    (F, 3, 3) edge vectors, without building them)."""
    v = np.asarray(v, dtype=np.float64)
    f = np.asarray(f)
    p0, p1, p2 = v[f[:, 0]], v[f[:, 1]], v[f[:, 2]]
    best = None
    for a, b in ((p0, p2), (p1, p0), (p2, p1)):
        d = a - b
        d *= d
        l2 = d[:, 0] + d[:, 1] + d[:, 2]
        best = l2 if best is None else np.maximum(best, l2)
    return np.sqrt(best)


def delaunay_flips(v: np.ndarray, f: np.ndarray, max_dihedral: float = 1.0, rounds: int = 100) -> np.ndarray:
    """Faces (F, 3) after flipping non-Delaunay edges between nearly coplanar faces.

    v : (V, 3) metres. An interior edge shared by two faces whose normals differ by less than
    ``max_dihedral`` degrees is flipped when the angles opposite it sum to more than pi (the
    Delaunay rule): needles from CAD tessellation (the strip between two rulings of a cylinder is
    flat) and from edge splitting become well-shaped triangles; with 1 degree the surface moves
    by under 1/200 of an edge. Independent flips are done together, in rounds.
    """
    f = np.asarray(f, dtype=np.int64).copy()
    cos_max = np.cos(np.radians(max_dihedral))
    nv = len(v)
    for _ in range(rounds):
        nf = len(f)
        i_all = f.T.ravel()
        j_all = np.roll(f, -1, axis=1).T.ravel()
        key = np.minimum(i_all, j_all) * nv + np.maximum(i_all, j_all)
        order = np.argsort(key, kind="stable")
        ks = key[order]
        # interior edges: a key seen exactly twice
        first = np.ones(len(ks), bool)
        first[1:] = ks[1:] != ks[:-1]
        start = np.flatnonzero(first)
        cnt = np.diff(np.append(start, len(ks)))
        pair = start[cnt == 2]
        ha, hb = order[pair], order[pair + 1]  # half-edge ids k*F + face
        fa, ka, fb, kb = ha % nf, ha // nf, hb % nf, hb // nf
        i, j = f[fa, ka], f[fa, (ka + 1) % 3]
        ok = (f[fb, kb] == j) & (f[fb, (kb + 1) % 3] == i)  # consistently oriented neighbours only
        p, q = f[fa, (ka + 2) % 3], f[fb, (kb + 2) % 3]
        ok &= p != q

        def angle(at, x, y):
            a, b = v[x] - v[at], v[y] - v[at]
            return np.arctan2(np.linalg.norm(np.cross(a, b), axis=1), np.einsum("ij,ij->i", a, b))

        na = np.cross(v[j] - v[i], v[p] - v[i])
        nb = np.cross(v[i] - v[j], v[q] - v[j])
        la, lb = np.linalg.norm(na, axis=1), np.linalg.norm(nb, axis=1)
        cosd = np.einsum("ij,ij->i", na, nb) / np.maximum(la * lb, 1e-300)
        excess = angle(p, i, j) + angle(q, j, i) - np.pi
        ok &= (cosd > cos_max) & (excess > 1e-9)
        # the flipped faces keep their orientation and are not degenerate
        n1 = np.cross(v[i] - v[p], v[q] - v[p])
        n2 = np.cross(v[j] - v[q], v[p] - v[q])
        ref = na + nb
        ok &= (np.einsum("ij,ij->i", n1, ref) > 0) & (np.einsum("ij,ij->i", n2, ref) > 0)
        # the new edge must not exist already
        newkey = np.minimum(p, q) * nv + np.maximum(p, q)
        ok &= ~np.isin(newkey, ks)
        idx = np.flatnonzero(ok)
        if not len(idx):
            break
        # an independent set: each face flips with its most non-Delaunay edge only
        prio = excess[idx] + 1e-12 * np.arange(len(idx)) / max(len(idx), 1)
        best = np.full(nf, -np.inf)
        np.maximum.at(best, fa[idx], prio)
        np.maximum.at(best, fb[idx], prio)
        win = idx[(best[fa[idx]] == prio) & (best[fb[idx]] == prio)]
        f[fa[win]] = np.column_stack([p[win], i[win], q[win]])
        f[fb[win]] = np.column_stack([q[win], j[win], p[win]])
    return f


def euler_characteristic(mesh) -> int:
    """V - E + F of ``mesh``, counting only the vertices its faces use."""
    f = np.asarray(mesh.faces)
    used = int(np.count_nonzero(np.bincount(f.ravel(), minlength=1))) if len(f) else 0
    return int(used - edge_table(mesh).n_edges + len(f))


def boundary_faces(mesh) -> np.ndarray:
    """(F,) bool: faces with an edge no other face shares."""
    f = np.asarray(mesh.faces)
    t = edge_table(mesh)
    on = t.counts[t.inv] == 1
    out = np.zeros(len(f), bool)
    out[np.arange(3 * len(f))[on] % len(f)] = True
    return out
