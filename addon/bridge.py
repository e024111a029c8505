"""numpy <-> Blender data: meshes and attributes through foreach_get/foreach_set.

Every transfer is one ``foreach_*`` call on a flat, contiguous numpy array of the
dtype Blender stores (float32 / int32 / bool), never a per-vertex Python loop.
Positions are metres in the object's local frame (the skin frame).
"""

from __future__ import annotations

import bpy
import numpy as np

# attribute type -> (numpy dtype, components, foreach key)
_TYPES = {
    "FLOAT": (np.float32, 1, "value"),
    "INT": (np.int32, 1, "value"),
    "BOOLEAN": (bool, 1, "value"),
    "FLOAT2": (np.float32, 2, "vector"),
    "FLOAT_VECTOR": (np.float32, 3, "vector"),
    "FLOAT_COLOR": (np.float32, 4, "color"),
}

#: The taxel attributes of DESIGN.md and their Blender types.
TAXEL_ATTRIBUTES = {
    "taxel_id": "INT",
    "module_id": "INT",
    "normal": "FLOAT_VECTOR",
    "flat": "FLOAT2",
    "can_id": "INT",
    "pressure": "FLOAT",
    "response": "FLOAT",
    "edge": "BOOLEAN",
    "tactile_color": "FLOAT_COLOR",
}


def set_attribute(mesh, name: str, values, type: str | None = None, domain: str = "POINT"):
    """Write ``values`` ((n,) or (n, k)) into the attribute ``name`` of ``mesh``.

    The attribute is created (or re-created if its type or domain differ).
    Colours given as (n, 3) get alpha 1. Returns the attribute.
    """
    type = type or TAXEL_ATTRIBUTES.get(name, "FLOAT")
    dtype, comps, key = _TYPES[type]
    arr = np.asarray(values)
    if type == "FLOAT_COLOR" and arr.ndim == 2 and arr.shape[1] == 3:
        arr = np.column_stack([arr, np.ones(len(arr))])
    arr = np.ascontiguousarray(arr, dtype=dtype).reshape(-1)
    attr = mesh.attributes.get(name)
    if attr is not None and (attr.data_type != type or attr.domain != domain):
        mesh.attributes.remove(attr)
        attr = None
    if attr is None:
        attr = mesh.attributes.new(name, type, domain)
    if arr.size != len(attr.data) * comps:
        raise ValueError(f"attribute {name!r}: {arr.size // comps} values for {len(attr.data)} elements")
    attr.data.foreach_set(key, arr)
    mesh.update()
    return attr


def get_attribute(mesh, name: str) -> np.ndarray:
    """Read attribute ``name`` as (n,) or (n, k) numpy array of its stored dtype."""
    attr = mesh.attributes[name]
    dtype, comps, key = _TYPES[attr.data_type]
    out = np.empty(len(attr.data) * comps, dtype=dtype)
    attr.data.foreach_get(key, out)
    return out.reshape(-1, comps) if comps > 1 else out


def write_mesh(mesh, positions, triangles=None, edges=None):
    """Replace the geometry of ``mesh``: vertices (n, 3) metres, triangles (f, 3), edges (m, 2)."""
    positions = np.ascontiguousarray(positions, dtype=np.float32).reshape(-1, 3)
    tri = np.zeros((0, 3), np.int32) if triangles is None else np.asarray(triangles, np.int32).reshape(-1, 3)
    mesh.clear_geometry()
    mesh.vertices.add(len(positions))
    mesh.vertices.foreach_set("co", positions.ravel())
    if edges is not None and len(edges):
        e = np.ascontiguousarray(edges, dtype=np.int32).reshape(-1, 2)
        mesh.edges.add(len(e))
        mesh.edges.foreach_set("vertices", e.ravel())
    if len(tri):
        mesh.loops.add(3 * len(tri))
        mesh.polygons.add(len(tri))
        mesh.loops.foreach_set("vertex_index", np.ascontiguousarray(tri, np.int32).ravel())
        mesh.polygons.foreach_set("loop_start", np.arange(0, 3 * len(tri), 3, dtype=np.int32))
    # calc_edges derives the face edges (and keeps explicit loose ones).
    mesh.update(calc_edges=True)
    mesh.validate(clean_customdata=False)
    return mesh


def vertex_positions(me, m=None) -> np.ndarray:
    """(n, 3) float64 vertex coordinates of mesh data ``me`` (local frame), or transformed by the
    4x4 matrix ``m`` (e.g. ``matrix(ob)`` for world space)."""
    co = np.empty(3 * len(me.vertices), np.float32)
    me.vertices.foreach_get("co", co)
    co = co.reshape(-1, 3).astype(np.float64)
    return co if m is None else co @ np.asarray(m)[:3, :3].T + np.asarray(m)[:3, 3]


def read_mesh(ob, depsgraph=None, world=True):
    """Evaluated geometry of object ``ob``: vertices (n, 3) and triangles (f, 3) int.

    Vertices are in world space (metres) when ``world``, else in the object's
    local space. Returns (vertices, triangles); triangles is (0, 3) for a
    mesh without faces.
    """
    if depsgraph is None:
        depsgraph = bpy.context.evaluated_depsgraph_get()
    ev = ob.evaluated_get(depsgraph)
    me = ev.to_mesh()
    try:
        co = vertex_positions(me)
        me.calc_loop_triangles()
        tri = np.empty(3 * len(me.loop_triangles), np.int32)
        me.loop_triangles.foreach_get("vertices", tri)
        tri = tri.reshape(-1, 3).astype(np.int64)
    finally:
        ev.to_mesh_clear()
    if world:
        m = matrix(ob)
        co = co @ m[:3, :3].T + m[:3, 3]
    return co, tri


def selected_vertices(mesh) -> np.ndarray:
    """Indices of the selected vertices of ``mesh`` (object mode data)."""
    sel = np.empty(len(mesh.vertices), dtype=bool)
    mesh.vertices.foreach_get("select", sel)
    return np.flatnonzero(sel)


def selected_faces(mesh) -> np.ndarray:
    """Indices of the selected faces of ``mesh`` (object mode data)."""
    sel = np.empty(len(mesh.polygons), dtype=bool)
    mesh.polygons.foreach_get("select", sel)
    return np.flatnonzero(sel)


def matrix(ob) -> np.ndarray:
    """``ob.matrix_world`` as a (4, 4) float64 array (row-major: ``m[:3, 3]`` is the translation).

    Not ``np.array(matrix)``: a mathutils Matrix exposes its column-major buffer, so
    that gives the transpose.
    """
    return np.array([tuple(row) for row in ob.matrix_world], dtype=np.float64)


def to_matrix(m):
    """A (4, 4) row-major array as a ``mathutils.Matrix`` (assigning a nested list to
    ``matrix_world`` would be read column-major)."""
    from mathutils import Matrix

    return Matrix([tuple(float(v) for v in row) for row in np.asarray(m, dtype=np.float64).reshape(4, 4)])


def rigid(m) -> np.ndarray:
    """The rotation + translation part of a 4x4 matrix (scale and shear removed)."""
    m = np.asarray(m, dtype=np.float64)
    u, _, vt = np.linalg.svd(m[:3, :3])
    r = u @ vt
    if np.linalg.det(r) < 0:
        u[:, -1] *= -1
        r = u @ vt
    out = np.eye(4)
    out[:3, :3] = r
    out[:3, 3] = m[:3, 3]
    return out
