"""What every operator shares: the report-and-cancel pattern and reading a mesh in a frame.

Each operator gathers its input from the scene, calls ONE vtcore function and writes the
result; on bad input it reports ``{'ERROR'}``, returns ``{'CANCELLED'}`` and has changed
nothing (all computation happens before the first write).
"""

from __future__ import annotations

import tempfile
from contextlib import contextmanager
from pathlib import Path

import bpy
import numpy as np

from . import bridge, skin

def fail(op, message: str, details=()):
    op.report({"ERROR"}, message)
    for line in details:  # vtcore's detail lines (why no module fits, island by island): the Info log
        op.report({"INFO"}, line)
    return {"CANCELLED"}


class Cancel(Exception):
    """Bad input: the message tells the user what to do; the operator changes nothing.
    ``details``: lines that say more (reported as INFO after the error)."""

    def __init__(self, message: str, details=()):
        super().__init__(message)
        self.details = [str(d) for d in details]


class Op:
    """Operator base: ``run()`` does the work and raises ``Cancel`` on bad input, which
    ``execute()`` turns into an ``{'ERROR'}`` report and ``{'CANCELLED'}`` (one place for
    the report-and-cancel pattern every operator follows)."""

    bl_options = {"REGISTER", "UNDO"}

    def execute(self, context):
        try:
            return self.run(context)
        except Cancel as exc:
            return fail(self, str(exc), exc.details)


@contextmanager
def failing(what: str):
    """vtcore's input errors inside the block cancel the operator as ``"<what>: <error>"``.

    Only the computation goes inside the block, never a write, so a cancel leaves the
    scene as it was.
    """
    try:
        yield
    except vt_errors() as exc:
        raise Cancel(f"{what}: {exc}", getattr(exc, "details", None) or ()) from exc


def need_skin(context, message: str, *, taxels: bool = False, attribute: str | None = None):
    """The skin the user means (see ``skin.skin_of``), or cancel with ``message`` when there is
    none, it has no taxels (``taxels``) or lacks ``attribute``."""
    ob = skin.skin_of(context)
    if (ob is None or (taxels and len(ob.data.vertices) == 0)
            or (attribute is not None and attribute not in ob.data.attributes)):
        raise Cancel(message)
    return ob


def file_path(op, fallback: str, what: str) -> str:
    """The operator's ``filepath`` (or the panel's ``fallback``) as an absolute path, or cancel
    with "No <what> given" when both are empty."""
    path = bpy.path.abspath(op.filepath or fallback)
    if not path:
        raise Cancel(f"No {what} given")
    return path


def out_dir(settings) -> Path:
    if settings.out_dir:
        return Path(bpy.path.abspath(settings.out_dir))
    return Path(tempfile.mkdtemp(prefix="vtskin_"))


def vt_errors():
    from vtcore.errors import VtError

    # ImportError: an optional library a vtcore path needs is missing from this Blender.
    return (VtError, ValueError, OSError, ImportError)


def skin_frame(ob):
    """The frame a skin laid on ``ob`` lives in, as ``ob``'s (4, 4) world matrix.

    A robot link object (Import Robot: ``ob.vtskin.link`` set) holds the link's geometry in link
    coordinates as its mesh data: its frame is its whole matrix, scale included, so a skin laid on
    it is in the link's frame wherever the object is moved, turned or scaled (the scale only shows
    it bigger). A taxel object's frame is its matrix (it was created with the frame as matrix). Any
    other object: its world matrix without scale (the object's scale is part of its geometry, e.g.
    a millimetre mesh scaled 0.001).
    """
    if ob.vtskin.link or skin.is_taxels(ob):
        return bridge.matrix(ob)
    return bridge.rigid(bridge.matrix(ob))


def mesh_in_frame(ee, frame):
    """End-effector vertices in ``frame`` (metres), triangles and triangle -> face index."""
    if ee.mode == "EDIT":
        ee.update_from_editmode()
    world, tri = bridge.read_mesh(ee)
    inv = np.linalg.inv(frame)
    verts = world @ inv[:3, :3].T + inv[:3, 3]
    return verts, tri


def triangle_faces(ee):
    me = ee.data
    me.calc_loop_triangles()
    idx = np.empty(len(me.loop_triangles), np.int32)
    me.loop_triangles.foreach_get("polygon_index", idx)
    return idx


def selection_anchor(ee, frame):
    """Anchor (skin frame, vtcore.scene.interactive.selection_anchor) and (F,) polygon
    selection of the selected faces of ``ee``."""
    from vtcore.scene import interactive

    if ee.mode == "EDIT":
        ee.update_from_editmode()
    me = ee.data
    sel = bridge.selected_faces(me)
    if len(sel) == 0:
        return None, sel
    centres = np.empty(3 * len(me.polygons), np.float32)
    me.polygons.foreach_get("center", centres)
    areas = np.empty(len(me.polygons), np.float32)
    me.polygons.foreach_get("area", areas)
    local = interactive.selection_anchor(centres.reshape(-1, 3), areas, sel)
    m = bridge.matrix(ee)
    world = m[:3, :3] @ local + m[:3, 3]
    inv = np.linalg.inv(frame)
    return inv[:3, :3] @ world + inv[:3, 3], sel


def to_frame(frame, world_point):
    inv = np.linalg.inv(frame)
    return inv[:3, :3] @ np.asarray(world_point, float) + inv[:3, 3]


def patch_direction(rotation):
    # In-plane x axis of the patch: world x turned about the skin frame's z. vtcore
    # projects it onto the tangent plane at the placement point.
    return np.array([np.cos(rotation), np.sin(rotation), 0.0])
