"""The region a fill covers: what the designer selected, in the mesh's faces.

A region is an (F,) bool mask of a mesh's faces. The designer gives it as a face selection
(the add-on), a face-index file (:func:`read_face_indices`), a normal cone
(:func:`facing_region`: the faces whose normal is within some degrees of a direction) or a
geodesic radius round ``at`` (:func:`crop_mask` bounds it in 3-D first). Its connected parts
(:func:`face_islands`) are filled one by one or together (``fill(islands=...)``).

What fits in a region is sized here too: :func:`free_width` is how wide the region is between
the edges no module may straddle (its open edges, sharp creases and its own border), measured
along the surface; :func:`module_width` is how wide a strip a module needs (the narrowest width
of the hull of its taxels). A part narrower than every module is said in one line
(:func:`too_narrow_message`) with the modules that would fit.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..errors import InputError
from ..geometry import closest_point_on_triangles


def crop_mask(mesh, point: np.ndarray, face: int, radius: float) -> np.ndarray:
    """(F,) bool: faces of ``mesh`` with a point within ``radius`` metres of ``point`` (3,)."""
    tri = np.asarray(mesh.triangles)
    near = closest_point_on_triangles(tri, np.broadcast_to(point, (len(tri), 3)).copy())
    keep = np.linalg.norm(near - point, axis=1) <= radius
    keep[face] = True
    return keep


def face_islands(mesh, mask: np.ndarray) -> list:
    """Connected parts (by shared edges) of the faces where ``mask`` (F,) is true, largest first
    (by face count; ties: the lowest face index first)."""
    import trimesh

    from .repair import face_pairs

    idx = np.flatnonzero(mask)
    adj = face_pairs(mesh)
    both = mask[adj].all(axis=1) if len(adj) else np.zeros(0, bool)
    comps = trimesh.graph.connected_components(adj[both], nodes=idx, min_len=1)
    return sorted((np.sort(np.asarray(c, np.int64)) for c in comps), key=lambda c: (-len(c), int(c[0])))


def central_point(mesh) -> np.ndarray:
    """A start for an island: the face centre nearest the island's area-weighted centre (3,)."""
    c = np.asarray(mesh.triangles_center)
    w = np.asarray(mesh.area_faces)
    g = (c * w[:, None]).sum(axis=0) / max(w.sum(), 1e-300)
    return c[int(np.argmin(np.linalg.norm(c - g, axis=1)))]


def facing_region(mesh, direction, within_deg: float) -> np.ndarray:
    """(F,) bool: the faces of ``mesh`` whose normal is within ``within_deg`` degrees of
    ``direction`` (3,), e.g. one side of a link (``--facing 0 0 1 --within 45``)."""
    d = np.asarray(direction, dtype=np.float64).reshape(-1)
    if d.shape != (3,) or not np.isfinite(d).all() or not np.linalg.norm(d) > 0:
        raise InputError(f"must be 3 finite numbers, not all zero, got {d.tolist()}", key="facing")
    within = float(within_deg)
    if not (0.0 < within <= 180.0):
        raise InputError(f"must be in (0, 180] degrees, got {within:g}", key="within")
    cos = np.asarray(mesh.face_normals) @ (d / np.linalg.norm(d))
    return cos >= np.cos(np.radians(within)) - 1e-12


def read_face_indices(path, n_faces: int) -> np.ndarray:
    """(F,) bool mask from a face-index file: integers (0-based face indices of the mesh as read)
    separated by spaces, commas or new lines, ``#`` starts a comment; or a JSON list.
    Raises InputError naming the file and line of a bad entry."""
    import json

    from ..inputs import check_input

    p = check_input(path, "face-index file")
    text = Path(p).read_text(encoding="utf-8", errors="replace")
    mask = np.zeros(int(n_faces), bool)
    if text.lstrip().startswith("["):
        try:
            items = [(1, v) for v in json.loads(text)]
        except ValueError as exc:
            raise InputError(f"not a JSON list of face indices ({exc})", file=p) from None
    else:
        items = [(ln, tok) for ln, line in enumerate(text.splitlines(), 1)
                 for tok in line.split("#", 1)[0].replace(",", " ").split()]
    for ln, tok in items:
        try:
            i = int(tok)
            if isinstance(tok, float) or str(tok).strip() != str(i):
                raise ValueError
        except (TypeError, ValueError):
            raise InputError(f"{str(tok)[:40]!r} is not a face index (an integer)", file=p, line=ln) from None
        if not 0 <= i < n_faces:
            raise InputError(f"face {i} does not exist: the mesh has {n_faces} faces (0..{n_faces - 1})",
                             file=p, line=ln)
        mask[i] = True
    if not mask.any():
        raise InputError("lists no face", file=p)
    return mask


def module_width(mod) -> float:
    """Metres: the narrowest width of the convex hull of a module's taxels (how wide a strip of
    smooth surface the module needs; a triangle of side s needs s * sqrt(3) / 2)."""
    from scipy.spatial import ConvexHull

    pts = np.asarray(mod.taxels, float)
    hull = pts[ConvexHull(pts).vertices]
    edge = np.roll(hull, -1, axis=0) - hull
    n = np.column_stack([-edge[:, 1], edge[:, 0]]) / np.linalg.norm(edge, axis=1, keepdims=True)
    proj = hull @ n.T  # (h, e): the width across each edge's normal
    return float((proj.max(axis=0) - proj.min(axis=0)).min())


def feature_distance(graph, feature_vertices: np.ndarray) -> np.ndarray:
    """(V,) metres along the surface (``graph``: a mesh's path graph, CSR V x V) from each vertex
    to the nearest of ``feature_vertices`` (the ends of the edges no module may straddle: open
    edges, sharp creases, the region's border); inf everywhere when there are none."""
    from scipy.sparse.csgraph import dijkstra

    feature_vertices = np.unique(np.asarray(feature_vertices, np.int64))
    if not len(feature_vertices):
        return np.full(graph.shape[0], np.inf)
    return dijkstra(graph, directed=False, indices=feature_vertices, min_only=True)


def free_width(faces_vertices: np.ndarray, distance: np.ndarray) -> float:
    """Metres: twice the largest of ``distance`` (:func:`feature_distance`) over the vertices
    ``faces_vertices`` of a region: the width of its widest part free of the edges no module may
    straddle (inf without such edges: a closed smooth part)."""
    d = np.asarray(distance)[np.unique(np.asarray(faces_vertices, np.int64))]
    d = d[np.isfinite(d)]
    return 2.0 * float(d.max()) if len(d) else float("inf")


def too_narrow_message(width: float, mod, what: str = "the region") -> str | None:
    """One line saying that ``what`` is ``width`` metres across (between edges no module may
    straddle) and narrower than ``mod`` needs, naming the registered modules that would fit;
    None when ``mod`` is not too wide for it."""
    from .modules import MODULES

    need = module_width(mod)
    if not np.isfinite(width) or width >= need:
        return None
    widths = sorted((module_width(m), name) for name, m in MODULES.items())
    fit = [f"{name} ({1e3 * w:.1f} mm)" for w, name in widths if w <= width]
    smallest_w, smallest = widths[0]
    tail = (f"modules that fit: {', '.join(fit)}" if fit else
            f"the smallest module, {smallest}, needs {1e3 * smallest_w:.1f} mm: no registered module fits")
    return (f"{what} is {1e3 * width:.1f} mm across between its edges, sharp creases and border; "
            f"a {mod.name} module needs {1e3 * need:.1f} mm; {tail}")


__all__ = ["crop_mask", "face_islands", "central_point", "facing_region", "read_face_indices", "module_width",
           "feature_distance", "free_width", "too_narrow_message"]
