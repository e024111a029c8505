"""Taxel objects: a vtcore ``Layout`` <-> a mesh object with one vertex per taxel.

Vertex positions are the taxel positions in the skin frame (the object's local
frame, metres); the skin mesh is the object's faces; attributes carry
``taxel_id``, ``module_id``, ``normal``, ``pressure``, ``response`` and ``edge``,
and when the layout has them ``flat`` (2-D unrolled coordinates, metres) and ``can_id``.
"""

from __future__ import annotations

import bpy
import numpy as np

from . import bridge


def new_object(context, name: str, role: str = "TAXELS", matrix=None):
    """A new mesh object ``name`` linked to the active collection (or the scene's)."""
    me = bpy.data.meshes.new(name)
    ob = bpy.data.objects.new(name, me)
    coll = context.collection or context.scene.collection
    coll.objects.link(ob)
    if matrix is not None:
        ob.matrix_world = bridge.to_matrix(matrix)
    ob.vtskin.role = role
    return ob


def write_layout(ob, layout, triangles=None, pressure=None, response=None, edge=None):
    """Replace the geometry and taxel attributes of ``ob`` with ``layout``.

    layout : vtcore Layout (positions in ``ob``'s local frame, metres).
    triangles : (F, 3) skin mesh faces or None. pressure/response : (N,) or None
    (zeros). edge : (N,) bool or None (False).
    """
    n = len(layout)
    me = ob.data
    bridge.write_mesh(me, layout.positions, triangles)
    bridge.set_attribute(me, "taxel_id", layout.taxel_ids)
    bridge.set_attribute(me, "module_id", layout.module_ids)
    bridge.set_attribute(me, "normal", layout.normals)
    bridge.set_attribute(me, "pressure", np.zeros(n) if pressure is None else pressure)
    bridge.set_attribute(me, "response", np.zeros(n) if response is None else response)
    bridge.set_attribute(me, "edge", np.zeros(n, bool) if edge is None else edge)
    # Optional per-taxel data of the layout: written when it has them, else left out, so
    # read_layout gives back what was written (the unrolled contact solve needs ``flat``).
    for name, values in (("flat", layout.flat), ("can_id", layout.can_ids)):
        if values is not None:
            bridge.set_attribute(me, name, values)
        elif name in me.attributes:
            me.attributes.remove(me.attributes[name])
    ob.vtskin.role = "TAXELS"


def read_layout(ob):
    """The vtcore Layout stored on taxel object ``ob`` (positions in its local frame, metres)."""
    from vtcore.layout import Layout

    me = ob.data
    n = len(me.vertices)
    co = bridge.vertex_positions(me)
    names = me.attributes.keys()
    normals = bridge.get_attribute(me, "normal") if "normal" in names else np.tile([0.0, 0.0, 1.0], (n, 1))
    ids = bridge.get_attribute(me, "taxel_id") if "taxel_id" in names else np.arange(n)
    mods = bridge.get_attribute(me, "module_id") if "module_id" in names else np.zeros(n, np.int64)
    flat = bridge.get_attribute(me, "flat").astype(np.float64) if "flat" in names else None
    can = bridge.get_attribute(me, "can_id") if "can_id" in names else None
    normals = np.asarray(normals, np.float64)
    normals /= np.maximum(np.linalg.norm(normals, axis=1, keepdims=True), 1e-12)
    # The taxels are in the skin's own frame (the link it lies on, or its end-effector): that frame
    # is the layout's, with no transform. Where the object sits in the scene is Blender's business;
    # an export "in frame of" another object says so explicitly (vtcore.scene.interactive.export_layout).
    lay = Layout(co.reshape(-1, 3).astype(np.float64), normals, ids, mods, flat, frame=frame_name(ob), can_ids=can)
    ee = ob.vtskin.end_effector
    if ee is not None and ee.vtskin.link:
        lay.meta.update({"link": ee.vtskin.link, "robot": ee.vtskin.robot_file})
    return lay


def frame_name(ob) -> str:
    """The name of the frame an object's skin is in: a robot link object's link, the end-effector of a
    taxel object, else the object's own name."""
    if ob.vtskin.link:
        return ob.vtskin.link
    ee = ob.vtskin.end_effector if is_taxels(ob) else None
    return frame_name(ee) if ee is not None and ee != ob else ob.name


def follow(skin_ob, ee) -> None:
    """Parent a new skin to the robot link object it lies on, so it moves with the link (a joint
    configuration, the user dragging the robot); other end-effectors keep their skin unparented."""
    if ee is not None and ee.vtskin.link and skin_ob.parent is None:
        skin_ob.parent = ee
        skin_ob.matrix_parent_inverse.identity()
        skin_ob.matrix_basis.identity()


def triangles(ob) -> np.ndarray:
    """(F, 3) int: the skin mesh triangles stored as ``ob``'s faces."""
    me = ob.data
    me.calc_loop_triangles()
    tri = np.empty(3 * len(me.loop_triangles), np.int32)
    me.loop_triangles.foreach_get("vertices", tri)
    return tri.reshape(-1, 3).astype(np.int64)


def is_taxels(ob) -> bool:
    return ob is not None and ob.type == "MESH" and ob.vtskin.role == "TAXELS"


def skin_of(context):
    """The taxel object the user means: the active one, or the skin on the active end-effector
    (None when there is neither). Operators and panels ask this one question the same way."""
    ob = context.active_object
    if is_taxels(ob):
        return ob
    if ob is not None:
        for other in context.scene.objects:
            if is_taxels(other) and other.vtskin.end_effector == ob:
                return other
    return None
