"""Mesh repair (vtcore.layout.repair) against plain reference computations on messy meshes:
the shared edge table must give the same splits, counts and Euler characteristic as sorting
each check's own keys did, and a cleaned mesh must say which input face each face came from."""

import numpy as np
import pytest
import trimesh

from vtcore.layout import repair


def messy_mesh(seed: int):
    """A grid sheet with duplicated and degenerate faces, a fin on a shared edge (non-manifold),
    a flipped neighbour and two cones touching at one vertex (a bowtie)."""
    rng = np.random.default_rng(seed)
    n = 8
    x, y = np.meshgrid(np.linspace(0, 0.07, n), np.linspace(0, 0.07, n))
    v = np.column_stack([x.ravel(), y.ravel(), 0.002 * rng.normal(size=n * n)])
    faces = []
    for i in range(n - 1):
        for j in range(n - 1):
            a, b, c, d = i * n + j, i * n + j + 1, (i + 1) * n + j, (i + 1) * n + j + 1
            faces += [[a, b, d], [a, d, c]]
    f = np.array(faces)
    extra_v = [[0.03, 0.03, 0.02], [0.2, 0.2, 0.0], [0.21, 0.2, 0.01], [0.2, 0.21, 0.01],
               [0.19, 0.2, -0.01], [0.2, 0.19, -0.01]]
    base = len(v)
    v = np.vstack([v, extra_v])
    fin = [[f[10, 0], f[10, 1], base]]  # a third face on face 10's first edge
    flip = [f[40][::-1]]  # face 40 again, wound the other way (a duplicate once sorted)
    apex = base + 1  # two fans of two faces each meeting only at 'apex'
    bow = [[apex, base + 2, base + 3], [apex, base + 4, base + 5]]
    degenerate = [[3, 3, 4], [5, 6, 5]]
    dup = f[rng.choice(len(f), 3, replace=False)]
    f = np.vstack([f, fin, flip, bow, degenerate, dup])
    return trimesh.Trimesh(v, f[rng.permutation(len(f))], process=False, validate=False)


def reference_fans(f: np.ndarray, nv: int) -> np.ndarray:
    """Fans per vertex by a plain union-find over the faces round each vertex."""
    fans = np.zeros(nv, int)
    for vert in range(nv):
        around = np.flatnonzero((f == vert).any(axis=1))
        parent = {int(a): int(a) for a in around}

        def root(a):
            while parent[a] != a:
                a = parent[a]
            return a

        for i, a in enumerate(around):
            for b in around[i + 1:]:
                shared = set(f[a]) & set(f[b])
                if vert in shared and len(shared) >= 2:
                    parent[root(int(a))] = root(int(b))
        fans[vert] = len({root(int(a)) for a in around})
    return fans


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_repairs_match_plain_computations(seed):
    mesh = messy_mesh(seed)
    clean, notes = repair.clean_mesh(mesh)
    assert any("degenerate" in n for n in notes) and any("duplicate" in n for n in notes)
    # each clean face is the input face it says it came from (same corner positions)
    src = repair.source_faces(clean, mesh)
    assert len(src) == len(clean.faces) and np.all(np.diff(src) > 0)
    np.testing.assert_allclose(np.asarray(clean.triangles), np.asarray(mesh.triangles)[src], atol=1e-12)
    f = np.asarray(clean.faces)
    # non-manifold: an edge in more than two faces or twice in one direction, counted plainly
    und = np.sort(np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]]), axis=1)
    dire = np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]])
    _, ui, uc = np.unique(und, axis=0, return_inverse=True, return_counts=True)
    _, di, dc = np.unique(dire, axis=0, return_inverse=True, return_counts=True)
    bad = (uc[ui.ravel()] > 2) | (dc[di.ravel()] > 1)
    want = np.zeros(len(f), bool)
    want[np.arange(3 * len(f))[bad] % len(f)] = True
    split, nsplit = repair.split_nonmanifold(clean)
    assert nsplit == int(want.sum()) > 0
    assert repair.nonmanifold_edge_count(np.asarray(split.faces)) == 0
    # bowties: as many split vertices as the plain union-find finds, and none left after
    fans = reference_fans(np.asarray(split.faces), len(split.vertices))
    out, nbow = repair.split_bowties(split)
    assert nbow == int((fans > 1).sum()) >= 1
    assert (reference_fans(np.asarray(out.faces), len(out.vertices)) <= 1).all()
    # Euler characteristic and boundary faces from the shared table
    g = np.asarray(out.faces)
    e = np.unique(np.sort(np.concatenate([g[:, [0, 1]], g[:, [1, 2]], g[:, [2, 0]]]), axis=1), axis=0)
    assert repair.euler_characteristic(out) == len(np.unique(g)) - len(e) + len(g)
    ek = np.sort(np.concatenate([g[:, [0, 1]], g[:, [1, 2]], g[:, [2, 0]]]), axis=1)
    _, ei, ec = np.unique(ek, axis=0, return_inverse=True, return_counts=True)
    on = ec[ei.ravel()] == 1
    want_b = np.zeros(len(g), bool)
    want_b[np.arange(3 * len(g))[on] % len(g)] = True
    np.testing.assert_array_equal(repair.boundary_faces(out), want_b)


def test_edge_table_follows_a_changed_mesh():
    """The table is cached on the mesh with its data's hash: changing the faces rebuilds it."""
    m = trimesh.creation.icosphere(1)
    assert repair.euler_characteristic(m) == 2
    assert not repair.boundary_faces(m).any()
    m.faces = m.faces[1:]  # a hole: one face fewer, three boundary edges
    assert repair.euler_characteristic(m) == 1
    assert repair.boundary_faces(m).sum() == 3


def test_face_keys_wide_indices_group_like_narrow():
    """Past 2**21 vertices the keys are rows of bytes; they must group faces the same way."""
    rng = np.random.default_rng(3)
    rows = np.sort(rng.integers(0, 50, size=(400, 3)), axis=1)
    rows = rows[(rows[:, 0] < rows[:, 1]) & (rows[:, 1] < rows[:, 2])]
    narrow = np.unique(repair.face_keys(*rows.T, 50), return_index=True, return_inverse=True)
    wide = np.unique(repair.face_keys(*(rows.T * 10 ** 6), 50 * 10 ** 6), return_index=True, return_inverse=True)
    np.testing.assert_array_equal(narrow[1], wide[1])
    np.testing.assert_array_equal(narrow[2], wide[2])


def test_source_faces_of_another_mesh_fall_back_to_nearest_centres():
    m = trimesh.creation.icosphere(2)
    other = trimesh.Trimesh(m.vertices, m.faces[::-1], process=False)  # no record of where it came from
    np.testing.assert_array_equal(repair.source_faces(other, m), np.arange(len(m.faces))[::-1])
    # a clean mesh asked about a mesh it was not made from answers by centres, not by its record
    big = trimesh.creation.icosphere(3)
    clean = repair.clean_mesh(trimesh.Trimesh(m.vertices, np.vstack([m.faces[:1], m.faces]), process=False))[0]
    shifted = trimesh.Trimesh(big.vertices, big.faces, process=False)
    np.testing.assert_array_equal(repair.source_faces(clean, shifted),
                                  repair.source_faces(trimesh.Trimesh(clean.vertices, clean.faces), shifted))


def test_face_submesh_is_trimesh_submesh():
    """The same vertices and faces as trimesh's submesh(append=True), so a fill solves on the
    same mesh."""
    m = messy_mesh(4)
    pick = np.flatnonzero(np.random.default_rng(5).random(len(m.faces)) < 0.4)
    ours = repair.face_submesh(m, pick)
    theirs = m.submesh([pick], append=True, repair=False)
    np.testing.assert_array_equal(np.asarray(ours.vertices), np.asarray(theirs.vertices))
    np.testing.assert_array_equal(np.asarray(ours.faces), np.asarray(theirs.faces))


def test_clean_mesh_of_a_clean_mesh_drops_nothing():
    m = trimesh.creation.icosphere(2)
    clean, notes = repair.clean_mesh(m)
    assert notes == []
    np.testing.assert_array_equal(np.asarray(clean.faces), np.asarray(m.faces))
    np.testing.assert_array_equal(repair.source_faces(clean, m), np.arange(len(m.faces)))
    extra = trimesh.Trimesh(np.vstack([m.vertices, [[5.0, 5.0, 5.0]]]), m.faces, process=False)
    assert len(repair.clean_mesh(extra)[0].vertices) == len(m.vertices)  # the unused vertex is dropped


def test_corner_normals_follow_a_mesh_changed_in_place():
    """The crease-aware corner normals are cached with the mesh's data hash: moving the vertices
    of a mesh after a query gives the moved mesh's normals, not the old ones."""
    from vtcore.layout.surface import corner_normals

    m = trimesh.creation.box()
    before = corner_normals(m).copy()
    m.vertices = m.vertices @ np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])  # 90 deg about z
    after = corner_normals(m)
    np.testing.assert_allclose(after, before @ np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]]),
                               atol=1e-12)
    assert not np.allclose(after, before)
