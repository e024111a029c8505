"""The contact geometry of a skinned link: convex parts that follow the surface the skin lies on.

MuJoCo collides a mesh geom through its convex hull. Over a link with pockets, mating faces or a
collision box that encloses the visual mesh, that hull (or box) lies far above the skin: a ball rests on
it and no taxel below reads (issue 33: the Allegro palm's collision box encloses a visual-mesh skin,
0 of 3 drops read). The MJCF export replaces a skinned link's colliding geoms by :func:`convex_parts`
of the geometry the skin was laid on (``layout.meta["geometry"]``): a convex decomposition with CoACD
(Wei et al., SIGGRAPH 2022), so the contact surface follows the link's concavities.

CoACD is slow on large meshes (tens of seconds on a 7,000-face G1 wrist with its defaults), so its cost
is bounded: the mesh is decimated to :data:`DECIMATE_FACES` faces first (fast-simplification), the parts
are capped at :data:`MAX_PARTS`, the tree search is kept short, and the parts are cached beside the
output by a hash of the mesh and the options (re-exporting the same skinned robot reads them back).
A link whose own colliding geometry already hugs the skin (every taxel within :data:`HUGS_M` of it,
e.g. a primitive the skin was laid on) keeps it: :func:`needs_parts`.
"""

from __future__ import annotations

import hashlib
from pathlib import Path

import numpy as np

#: faces the mesh is decimated to before CoACD (its cost grows fast with faces; the parts' hulls
#: follow the surface to about the decimation error, well under a taxel's site reach)
DECIMATE_FACES = 800
#: at most this many convex parts per link (MuJoCo collides each one; CoACD merges beyond)
MAX_PARTS = 16
#: CoACD's options: concavity threshold 0.1 (of the bounding box), a short tree search, seeded
COACD_OPTIONS = {"threshold": 0.1, "max_convex_hull": MAX_PARTS, "preprocess_resolution": 20, "resolution": 300,
                 "mcts_iterations": 10, "mcts_nodes": 4, "mcts_max_depth": 2, "max_ch_vertex": 64, "seed": 0}
#: metres: a part may stand this far over a taxel it holds (a pad's thickness); beyond, it is cut down
OVER_SKIN_M = 1e-3
#: at most this many cuts per part (each a plane under the taxel it stood highest over)
MAX_CUTS = 12
#: metres: a link's colliding geometry within this of every taxel, along its normal, already follows the skin
HUGS_M = 1.5e-3


def cache_key(mesh) -> str:
    """12 hex digits naming ``mesh`` (its vertices and faces) and the decomposition options."""
    h = hashlib.sha1()
    h.update(np.ascontiguousarray(mesh.vertices, dtype=np.float64).tobytes())
    h.update(np.ascontiguousarray(mesh.faces, dtype=np.int64).tobytes())
    h.update(repr((DECIMATE_FACES, sorted(COACD_OPTIONS.items()))).encode())
    return h.hexdigest()[:12]


def decimated(mesh, faces: int = DECIMATE_FACES):
    """``(vertices (V, 3) float64, faces (F, 3) int64)`` of ``mesh`` with at most about ``faces``
    faces (fast-simplification's quadric decimation; unchanged when already that small)."""
    v, f = np.asarray(mesh.vertices, np.float64), np.asarray(mesh.faces, np.int64)
    if len(f) <= faces:
        return v, f
    import fast_simplification

    v2, f2 = fast_simplification.simplify(v.astype(np.float32), f.astype(np.int32),
                                          target_reduction=1.0 - faces / len(f))
    return np.asarray(v2, np.float64), np.asarray(f2, np.int64)


def convex_parts(mesh, cache_dir=None) -> list:
    """Convex parts (``trimesh.Trimesh`` hulls, the mesh's frame and units) whose union follows ``mesh``.

    cache_dir : a folder where the parts are kept as ``contact_<key>_<k>.stl`` (:func:`cache_key`):
    read back when present, written after a decomposition. None: no cache."""
    import trimesh

    key = cache_key(mesh)
    if cache_dir is not None:
        files = sorted(Path(cache_dir).glob(f"contact_{key}_*.stl"))
        if files:
            return [trimesh.load(f, force="mesh").convex_hull for f in files]
    import coacd

    coacd.set_log_level("error")
    v, f = decimated(mesh)
    parts = coacd.run_coacd(coacd.Mesh(v, f), **COACD_OPTIONS)
    hulls = [trimesh.Trimesh(np.asarray(pv), np.asarray(pf), process=True).convex_hull for pv, pf in parts]
    hulls = [h for h in hulls if len(h.faces) >= 4 and h.volume > 0] or [trimesh.Trimesh(v, f).convex_hull]
    if cache_dir is not None:
        Path(cache_dir).mkdir(parents=True, exist_ok=True)
        for k, h in enumerate(hulls):
            h.export(Path(cache_dir) / f"contact_{key}_{k:02d}.stl")
    return hulls


def under_skin(parts, positions, normals, covered=None) -> list:
    """``parts`` cut so that none stands more than :data:`OVER_SKIN_M` over a taxel along its normal
    unless the link's own mesh covers that taxel there (``covered`` (N,) bool; a pocket stays a
    pocket): CoACD bridges concavities up to its threshold (14 mm over a G1 elbow's skin), where a
    ball would rest on the part beyond the taxel's site. Each cut is the
    plane :data:`OVER_SKIN_M` over the taxel the part stands highest over, along its normal (a convex
    part cut by a plane stays convex); a part cut away entirely is dropped. positions, normals :
    (N, 3), the parts' frame, metres."""
    from trimesh.intersections import slice_mesh_plane

    from .reach import crossing

    p = np.asarray(positions, dtype=np.float64).reshape(-1, 3)
    u = np.asarray(normals, dtype=np.float64).reshape(-1, 3)
    u = u / np.linalg.norm(u, axis=1, keepdims=True)
    free = np.ones(len(p), bool) if covered is None else ~np.asarray(covered, bool)
    out = []
    for part in parts:
        for _ in range(MAX_CUTS):
            t_out = crossing(part, p, u)[1]
            over = np.where(free & (t_out > OVER_SKIN_M), t_out, -np.inf)  # nan compares False
            k = int(np.argmax(over))
            if not np.isfinite(over[k]):
                break
            part = slice_mesh_plane(part, -u[k], p[k] + OVER_SKIN_M * u[k], cap=True)
            if len(part.faces) < 4:
                break
            part = part.convex_hull
        if len(part.faces) >= 4 and part.volume > 1e-12:
            out.append(part)
    return out


def part_files(mesh, cache_dir) -> list[Path]:
    """The cached part files of ``mesh`` in ``cache_dir`` (:func:`convex_parts` first), in order."""
    convex_parts(mesh, cache_dir)
    return sorted(Path(cache_dir).glob(f"contact_{cache_key(mesh)}_*.stl"))


def needs_parts(reach, inside) -> bool:
    """Whether a link's own colliding geometry misses the skin: ``reach`` (N,) metres along each
    taxel's normal to it (:func:`.reach.contact_reach`), ``inside`` (N,) bool where the normal line
    meets it at all; True unless every taxel has it within :data:`HUGS_M`."""
    reach = np.asarray(reach, dtype=np.float64)
    return not (np.all(np.asarray(inside, bool)) and np.all(np.abs(reach) <= HUGS_M))
