"""Operators. Each gathers its input from the scene, calls ONE vtcore function and
writes the result; on bad input it reports ``{'ERROR'}``, returns ``{'CANCELLED'}``
and has changed nothing (all computation happens before the first write)."""

from __future__ import annotations

import tempfile
from contextlib import contextmanager
from pathlib import Path

import bpy
import numpy as np

from . import bake, bridge, display, skin


def _fail(op, message: str):
    op.report({"ERROR"}, message)
    return {"CANCELLED"}


class _Cancel(Exception):
    """Bad input: the message tells the user what to do; the operator changes nothing."""


class _Op:
    """Operator base: ``run()`` does the work and raises ``_Cancel`` on bad input, which
    ``execute()`` turns into an ``{'ERROR'}`` report and ``{'CANCELLED'}`` (one place for
    the report-and-cancel pattern every operator follows)."""

    bl_options = {"REGISTER", "UNDO"}

    def execute(self, context):
        try:
            return self.run(context)
        except _Cancel as exc:
            return _fail(self, str(exc))


@contextmanager
def _failing(what: str):
    """vtcore's input errors inside the block cancel the operator as ``"<what>: <error>"``.

    Only the computation goes inside the block, never a write, so a cancel leaves the
    scene as it was.
    """
    try:
        yield
    except _errors() as exc:
        raise _Cancel(f"{what}: {exc}") from exc


def _need_skin(context, message: str, *, taxels: bool = False, attribute: str | None = None):
    """The skin the user means (see ``skin.skin_of``), or cancel with ``message`` when there is
    none, it has no taxels (``taxels``) or lacks ``attribute``."""
    ob = skin.skin_of(context)
    if (ob is None or (taxels and len(ob.data.vertices) == 0)
            or (attribute is not None and attribute not in ob.data.attributes)):
        raise _Cancel(message)
    return ob


def _out_dir(settings) -> Path:
    if settings.out_dir:
        return Path(bpy.path.abspath(settings.out_dir))
    return Path(tempfile.mkdtemp(prefix="vtskin_"))


class VTSKIN_OT_run_scene(_Op, bpy.types.Operator):
    """Run a vtcore scene file and show its taxel responses on a taxel object"""

    bl_idname = "vtskin.run_scene"
    bl_label = "Run Scene"

    filepath: bpy.props.StringProperty(name="Scene file", subtype="FILE_PATH",
                                       description="Scene TOML (empty: the scene setting)")

    def run(self, context):
        from vtcore.scene.interactive import run_scene_file

        settings = context.scene.vtskin
        path = bpy.path.abspath(self.filepath or settings.scene_file)
        if not path:
            raise _Cancel("No scene file given")
        if not Path(path).is_file():  # before _out_dir, which may create a temporary folder
            raise _Cancel(f"{path}: not a readable scene file")
        with _failing("Scene run failed"):
            # a replay scene also comes back prepared for the timeline, at its [output] fps
            res = run_scene_file(path, _out_dir(settings))
        name = res.result.get("name") or Path(path).stem
        ob = skin.new_object(context, f"{name} taxels")
        skin.write_layout(ob, res.layout, res.triangles, pressure=res.pressure, response=res.response)
        ob.vtskin.source = str(path)
        display.ensure_display(ob)
        for other in context.view_layer.objects:
            other.select_set(False)
        ob.select_set(True)
        context.view_layer.objects.active = ob
        rendered = ""
        if res.replay is not None:
            _store_replay(context.scene, ob, res.replay, res.replay.meta.get("path", path))
            if res.output.get("video"):
                from . import render

                try:
                    rendered = f", rendered {render.render_replay(context, ob, res.out, res.output)}"
                except RuntimeError as exc:  # Blender's render failed (no GPU context, codec missing)
                    self.report({"WARNING"}, f"The skin and replay are loaded; rendering failed: {exc}")
        metrics = res.result.get("metrics", {})
        force = metrics.get("force_n")
        self.report({"INFO"}, f"{name}: {len(res.layout)} taxels"
                    + (f", {force:.3g} N" if isinstance(force, (int, float)) else "")
                    + f", results in {res.out}" + rendered)
        return {"FINISHED"}


# ---------------------------------------------------------------------------
# helpers: gather input (no writes)


def _errors():
    from vtcore.errors import VtError

    # ImportError: an optional library a vtcore path needs is missing from this Blender.
    return (VtError, ValueError, OSError, ImportError)


def _frame(ob):
    """Skin frame of an end-effector object: its world matrix without scale."""
    return bridge.rigid(bridge.matrix(ob))


def _ee_input(ee, frame):
    """End-effector vertices in ``frame`` (metres), triangles and triangle -> face index."""
    if ee.mode == "EDIT":
        ee.update_from_editmode()
    world, tri = bridge.read_mesh(ee)
    inv = np.linalg.inv(frame)
    verts = world @ inv[:3, :3].T + inv[:3, 3]
    return verts, tri


def _tri_faces(ee):
    me = ee.data
    me.calc_loop_triangles()
    idx = np.empty(len(me.loop_triangles), np.int32)
    me.loop_triangles.foreach_get("polygon_index", idx)
    return idx


def _selected_face_centre(ee, frame):
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


def _to_frame(frame, world_point):
    inv = np.linalg.inv(frame)
    return inv[:3, :3] @ np.asarray(world_point, float) + inv[:3, 3]


def _direction(rotation):
    # In-plane x axis of the patch: world x turned about the skin frame's z. vtcore
    # projects it onto the tangent plane at the placement point.
    return np.array([np.cos(rotation), np.sin(rotation), 0.0])


def _apply_report(ob, report):
    from vtcore.layout.summary import report_lines

    s = ob.vtskin
    s.strain_max = 100.0 * float(report.get("strain_max") or 0.0)
    s.strain_mean = 100.0 * float(report.get("strain_mean") or 0.0)
    s.overlaps = int(report.get("overlaps") or 0)
    cov = report.get("coverage")
    s.coverage = -1.0 if cov is None else 100.0 * float(cov)
    s.report = "\n".join(report_lines(report))


def _write_edit(context, ee, skin_ob, frame, edit, module):
    """Write a LayoutEdit to ``skin_ob`` (created on ``ee`` if None). Returns the object."""
    if skin_ob is None:
        skin_ob = skin.new_object(context, f"{ee.name} skin", matrix=frame)
        skin_ob.vtskin.end_effector = ee
        skin_ob.vtskin.module_type = module
    skin.write_layout(skin_ob, edit.layout, edit.triangles)
    if skin_ob.vtskin.cache is not None:
        bake.clear(skin_ob)  # the baked frames belong to the old taxels
    _apply_report(skin_ob, edit.report)
    display.ensure_display(skin_ob)
    return skin_ob


# ---------------------------------------------------------------------------
# Skin layout


class VTSKIN_OT_lay_patch(_Op, bpy.types.Operator):
    """Conform a patch of modules onto the active mesh at the 3D cursor or the selected faces"""

    bl_idname = "vtskin.lay_patch"
    bl_label = "Lay Patch"

    fill: bpy.props.BoolProperty(name="Fill region", default=False,
                                 description="Tile the selected faces with whole modules")

    def _gather(self, context):
        """Everything the placement needs, read from the scene (no writes): the end-effector,
        the skin already on it (or None), the skin frame and lay_patch's arguments."""
        from vtcore.layout import get_module

        s = context.scene.vtskin
        ee = context.active_object
        if ee is None or ee.type != "MESH" or skin.is_taxels(ee):
            raise _Cancel("Select the end-effector mesh to lay the skin on (the active object)")
        existing = skin.skin_of(context)
        frame = _frame(existing) if existing is not None else _frame(ee)
        verts, tri = _ee_input(ee, frame)
        if len(tri) == 0:
            raise _Cancel(f"{ee.name!r} has no faces: a skin needs a surface")
        region = None
        if self.fill or s.place_at == "SELECTED":
            at, sel = _selected_face_centre(ee, frame)
            if at is None:
                raise _Cancel(f"No faces of {ee.name!r} are selected")
            if self.fill:
                region = np.isin(_tri_faces(ee), sel)
        else:
            at = _to_frame(frame, context.scene.cursor.location)
        patch = f"strip:{s.strip_modules}" if s.patch == "strip" else s.patch
        base = skin.read_layout(existing) if existing is not None and len(existing.data.vertices) else None
        with _failing("Cannot lay the patch"):
            module = get_module(s.module, mirror=s.mirror)
        args = dict(vertices=verts, triangles=tri, at=at, existing=base, patch=patch, module=module,
                    direction=_direction(s.rotation), offset=s.offset, method=s.method, fill_region=region,
                    max_faces=s.solve_faces or None)
        return ee, existing, frame, args

    def _write(self, context, ee, existing, frame, edit):
        ob = _write_edit(context, ee, existing, frame, edit, context.scene.vtskin.module)
        self.report({"INFO"}, f"{ob.name}: {len(edit.layout)} taxels, max strain "
                    f"{ob.vtskin.strain_max:.1f} %, {ob.vtskin.overlaps} overlaps")
        return {"FINISHED"}

    def run(self, context):
        from vtcore.scene import interactive

        ee, existing, frame, args = self._gather(context)
        with _failing("Cannot lay the patch"):
            edit = interactive.lay_patch(**args)
        return self._write(context, ee, existing, frame, edit)

    # A fill from the UI runs as a modal operator: vtcore fills in a worker thread (vtcore's Job)
    # while a timer shows its progress on the cursor and in the status bar, and Esc cancels it
    # (the fill stops at its next progress call; the scene is left as it was). In background
    # mode (the bpy wheel, scripts: no event loop) and from execute() it runs to completion.

    def invoke(self, context, event):
        if not self.fill or bpy.app.background or context.window is None:
            return self.execute(context)
        try:
            self._start(context)
        except _Cancel as exc:
            return _fail(self, str(exc))
        context.window_manager.modal_handler_add(self)
        return {"RUNNING_MODAL"}

    def _start(self, context):
        """Gather the input, start the fill in a Job, the timer and the progress display."""
        from vtcore.scene import interactive

        self._input = self._gather(context)
        self._job = interactive.Job(interactive.lay_patch, **self._input[3])
        wm = context.window_manager
        self._timer = wm.event_timer_add(0.1, window=context.window)
        wm.progress_begin(0, 100)
        self._status(context)

    def _status(self, context, text=None):
        if text is None:
            text = f"Filling selected faces: {100 * self._job.fraction:.0f} % (Esc to cancel)"
        context.window_manager.progress_update(int(100 * self._job.fraction))
        if context.workspace is not None:
            context.workspace.status_text_set(text)

    def _end(self, context):
        wm = context.window_manager
        wm.event_timer_remove(self._timer)
        wm.progress_end()
        if context.workspace is not None:
            context.workspace.status_text_set(None)

    def modal(self, context, event):
        if event.type == "ESC":
            # the worker stops at its next progress call and its result is dropped: no need to wait
            self._job.cancel()
            self._end(context)
            self.report({"WARNING"}, "Fill cancelled: the skin is unchanged")
            return {"CANCELLED"}
        if event.type != "TIMER" or not self._job.done:
            if event.type == "TIMER":
                self._status(context)
            return {"RUNNING_MODAL"}  # other input waits until the fill is done or cancelled
        self._end(context)
        try:
            with _failing("Cannot lay the patch"):
                edit = self._job.result()
        except _Cancel as exc:
            return _fail(self, str(exc))
        ee, existing, frame, _ = self._input
        return self._write(context, ee, existing, frame, edit)


def _selected_modules(ob):
    if ob.mode == "EDIT":
        ob.update_from_editmode()
    sel = bridge.selected_vertices(ob.data)
    if not len(sel) or "module_id" not in ob.data.attributes:
        return np.zeros(0, np.int64)
    return np.unique(bridge.get_attribute(ob.data, "module_id")[sel])


class VTSKIN_OT_remove_module(_Op, bpy.types.Operator):
    """Remove the modules of the selected taxels (or the given module) from the skin"""

    bl_idname = "vtskin.remove_module"
    bl_label = "Remove Module"

    module: bpy.props.IntProperty(name="Module", default=-1, min=-1,
                                  description="Module id to remove (-1: those of the selected taxels)")

    def run(self, context):
        from vtcore.scene import interactive

        ob = _need_skin(context, "Select a skin (taxel object)")
        mods = [self.module] if self.module >= 0 else _selected_modules(ob)
        with _failing("Cannot remove"):
            edit = interactive.remove_modules(skin.read_layout(ob), mods)
        edit.layout.meta.clear()
        _write_edit(context, ob.vtskin.end_effector, ob, None, edit, ob.vtskin.module_type)
        return {"FINISHED"}


class VTSKIN_OT_move_module(_Op, bpy.types.Operator):
    """Move a module of the skin to the 3D cursor (re-conformed to the surface there)"""

    bl_idname = "vtskin.move_module"
    bl_label = "Move Module to Cursor"

    module: bpy.props.IntProperty(name="Module", default=-1, min=-1,
                                  description="Module id to move (-1: the one of the selected taxels)")

    def run(self, context):
        from vtcore.scene import interactive

        ob = _need_skin(context, "Select a skin (taxel object)")
        ee = ob.vtskin.end_effector
        if ee is None or ee.type != "MESH":
            raise _Cancel(f"{ob.name!r} has no end-effector mesh to move on")
        mods = [self.module] if self.module >= 0 else _selected_modules(ob)
        if len(mods) != 1:
            raise _Cancel(f"Select the taxels of exactly one module (got {len(mods)} modules)")
        frame = bridge.matrix(ob)
        verts, tri = _ee_input(ee, frame)
        layout = skin.read_layout(ob)
        layout.meta["module"] = ob.vtskin.module_type
        s = context.scene.vtskin
        with _failing("Cannot move"):
            edit = interactive.move_module(layout, int(mods[0]), verts, tri,
                                           _to_frame(frame, context.scene.cursor.location),
                                           _direction(s.rotation), s.offset)
        _write_edit(context, ee, ob, frame, edit, ob.vtskin.module_type)
        return {"FINISHED"}


# ---------------------------------------------------------------------------
# Contact


def _contact_input(op, context):
    """(skin object, layout, triangles, indenter verts (own frame), faces, pose in skin frame) or an error string."""
    s = context.scene.vtskin
    ob = skin.skin_of(context)
    if ob is None or len(ob.data.vertices) == 0:
        return "Select a skin with taxels (lay a patch first)"
    ind = s.indenter
    if ind is None or ind.type != "MESH":
        return "Choose an indenter mesh object in the Contact panel"
    if s.thickness <= 0:
        return "The soft layer has zero thickness: set a thickness > 0 in the Soft layer panel"
    world, tri = bridge.read_mesh(ind)
    if len(tri) == 0:
        return f"The indenter {ind.name!r} has no faces"
    m_ind = bridge.rigid(bridge.matrix(ind))
    inv_ind = np.linalg.inv(m_ind)
    verts = world @ inv_ind[:3, :3].T + inv_ind[:3, 3]
    pose = np.linalg.inv(bridge.matrix(ob)) @ m_ind
    return ob, skin.read_layout(ob), skin.triangles(ob), verts, tri, pose


class VTSKIN_OT_simulate(_Op, bpy.types.Operator):
    """Press the indenter onto the skin at the target force (current frame) and show the response"""

    bl_idname = "vtskin.simulate"
    bl_label = "Simulate Frame"

    def run(self, context):
        from vtcore.scene import interactive

        s = context.scene.vtskin
        got = _contact_input(self, context)
        if isinstance(got, str):
            raise _Cancel(got)
        ob, layout, tri, verts, faces, pose = got
        with _failing("Contact failed"):
            c = interactive.simulate(layout, tri, verts, faces, pose, thickness=s.thickness, material=s.material,
                                     force=s.force if s.use_force else None, counts_per_pa=s.counts_per_pa,
                                     edge_fraction=s.edge_fraction, geometry=s.geometry)
        me = ob.data
        bridge.set_attribute(me, "pressure", c.pressure)
        bridge.set_attribute(me, "response", c.response)
        bridge.set_attribute(me, "edge_response", c.edge_response, "FLOAT")
        bridge.set_attribute(me, "edge", c.edge)
        ob.vtskin.force = c.force
        display.ensure_display(ob)
        self.report({"INFO"}, f"{c.force:.3g} N, indentation {c.indentation * 1e3:.2f} mm, "
                    f"{int(c.edge.sum())} edge taxels")
        return {"FINISHED"}


class VTSKIN_OT_bake(_Op, bpy.types.Operator):
    """Simulate every frame of the range (indenter animation, animated force) and store it for playback"""

    bl_idname = "vtskin.bake"
    bl_label = "Bake Contact"

    def run(self, context):
        from vtcore.scene import interactive

        scene = context.scene
        s = scene.vtskin
        if s.frame_end < s.frame_start:
            raise _Cancel(f"Empty frame range {s.frame_start}..{s.frame_end}")
        frames = np.arange(s.frame_start, s.frame_end + 1)
        current = scene.frame_current
        poses, forces = [], []
        got = None
        try:
            # Gather the animated input (poses, forces): frame_set evaluates the animation.
            for f in frames:
                scene.frame_set(int(f))
                got = _contact_input(self, context)
                if isinstance(got, str):
                    break
                poses.append(got[5])
                forces.append(s.force)
        finally:
            scene.frame_set(current)
        if isinstance(got, str):
            raise _Cancel(got)
        ob, layout, tri, verts, faces, _ = got
        wm = context.window_manager
        wm.progress_begin(0, len(frames))
        try:
            with _failing("Bake failed"):
                res = interactive.bake(layout, tri, verts, faces, np.stack(poses), thickness=s.thickness,
                                       material=s.material, forces=np.array(forces) if s.use_force else None,
                                       counts_per_pa=s.counts_per_pa, edge_fraction=s.edge_fraction,
                                       callback=lambda i, t: wm.progress_update(i + 1), geometry=s.geometry)
        finally:
            wm.progress_end()
        if "edge" not in ob.data.attributes:
            bridge.set_attribute(ob.data, "edge", np.zeros(len(layout), bool))
        bake.store(ob, frames, pressure=res["pressure"], response=res["response"], edge=res["edge"])
        display.ensure_display(ob)
        bake.apply(ob, current)
        self.report({"INFO"}, f"Baked {len(frames)} frames on {ob.name}")
        return {"FINISHED"}


class VTSKIN_OT_clear_bake(_Op, bpy.types.Operator):
    """Remove the baked contact of the skin"""

    bl_idname = "vtskin.clear_bake"
    bl_label = "Clear Bake"

    def run(self, context):
        ob = skin.skin_of(context)
        if ob is None or ob.vtskin.cache is None:
            raise _Cancel("The selected skin has no baked contact")
        bake.clear(ob)
        return {"FINISHED"}


# ---------------------------------------------------------------------------
# Replay


def _boards(text: str):
    """iCub board addresses typed as ``3`` or ``14,13`` (None when empty)."""
    text = text.replace(" ", "")
    if not text:
        return None
    try:
        return [int(x, 0) for x in text.split(",") if x]
    except ValueError:
        raise _Cancel(f"Boards: expected board addresses like 3 or 14,13, got {text!r}") from None


def _store_replay(scene, ob, rep, path):
    """Write a vtcore ``Replay`` into the bake cache of taxel object ``ob`` from the scene's
    first frame on, the panel's numbers, and show the current frame."""
    me = ob.data
    n = len(me.vertices)
    for name in ("response", "response_compensated", "edge", "held"):
        if name not in me.attributes:  # playback writes into existing attributes only
            flag = name in ("edge", "held")
            bridge.set_attribute(me, name, np.zeros(n, bool if flag else np.float32), "BOOLEAN" if flag else "FLOAT")
    frames = scene.frame_start + np.arange(len(rep.rows))
    bake.store(ob, frames, rows=rep.rows, response=rep.counts, response_compensated=rep.response, edge=rep.edge,
               held=rep.held)
    scene.frame_end = int(frames[-1])
    v = ob.vtskin
    v.replay_source = str(path)
    v.replay_rows = len(rep.timestamps)
    v.recording_hz = rep.rate_hz
    v.lost_rows, v.lost_samples, v.lost_frames = rep.lost_rows, rep.lost_samples, rep.lost_frames
    v.replay_report = "\n".join(rep.mismatch() + rep.summary.splitlines())
    v.color_by = "response_compensated"
    display.ensure_display(ob)
    bake.apply(ob, scene.frame_current)


class VTSKIN_OT_load_recording(_Op, bpy.types.Operator):
    """Load a recording (CAN log or CySkin text) onto the skin's taxels for playback on the timeline"""

    bl_idname = "vtskin.load_recording"
    bl_label = "Load Recording"

    filepath: bpy.props.StringProperty(name="Recording", subtype="FILE_PATH",
                                       description="CAN log or CySkin text recording (empty: the panel's)")
    codec: bpy.props.StringProperty(name="Codec", default="",
                                    description="cyskin16, icub or cyskin-txt (empty: the panel's)")
    boards: bpy.props.StringProperty(name="Boards", default="",
                                     description="iCub board addresses, e.g. 3 or 14,13 (empty: the panel's)")

    def run(self, context):
        from vtcore.can.timeline import KINDS, load_recording

        scene = context.scene
        s = scene.vtskin
        ob = _need_skin(context, "Select a skin with taxels to load the recording onto", taxels=True)
        if "taxel_id" not in ob.data.attributes:
            raise _Cancel(f"{ob.name!r} has no taxel_id attribute: a recording is joined to the taxels by "
                          "UID / CAN address (lay the skin with the add-on, or run a scene)")
        path = bpy.path.abspath(self.filepath or s.recording_file)
        if not path:
            raise _Cancel("No recording file given")
        kind = self.codec or s.recording_codec
        if kind not in KINDS:
            raise _Cancel(f"Unknown codec {kind!r}; valid: {', '.join(KINDS)}")
        boards = _boards(self.boards or s.recording_boards)
        fps = scene.render.fps / scene.render.fps_base if s.replay_rate == "SCENE" else None
        with _failing("Cannot load the recording"):
            rep = load_recording(path, skin.read_layout(ob), skin.triangles(ob), kind=kind, boards=boards, fps=fps,
                                 baseline=s.baseline, baseline_rows=s.baseline_rows,
                                 edge_fraction=s.edge_fraction, min_response=s.min_response)
        _store_replay(scene, ob, rep, path)
        self.report({"INFO"}, f"{Path(path).name}: {len(rep.rows)} frames ({len(rep.timestamps)} rows) on "
                    f"{ob.name}, {rep.lost_frames} frames with lost samples; " + "; ".join(rep.mismatch()))
        return {"FINISHED"}


# ---------------------------------------------------------------------------
# Filters


class VTSKIN_OT_edges(_Op, bpy.types.Operator):
    """Run the edge filter on the skin's response and show the edge taxels"""

    bl_idname = "vtskin.edges"
    bl_label = "Detect Edges"

    show: bpy.props.BoolProperty(name="Show edges", default=True, description="Colour the taxels by edge")

    def run(self, context):
        from vtcore.scene import interactive

        ob = _need_skin(context, "Select a skin with a response (simulate a contact first)", taxels=True,
                        attribute="response")
        response = bridge.get_attribute(ob.data, "response").astype(np.float64)
        with _failing("Edge filter failed"):
            er, edge = interactive.edges(skin.read_layout(ob), skin.triangles(ob), response,
                                         context.scene.vtskin.edge_fraction)
        bridge.set_attribute(ob.data, "edge_response", er, "FLOAT")
        bridge.set_attribute(ob.data, "edge", edge)
        if self.show:
            ob.vtskin.color_by = "edge"
        display.ensure_display(ob)
        self.report({"INFO"}, f"{int(edge.sum())} edge taxels")
        return {"FINISHED"}


# ---------------------------------------------------------------------------
# Augmented point cloud


class VTSKIN_OT_augment(_Op, bpy.types.Operator):
    """Propagate probe values over the point cloud (cluster or smooth) and colour it"""

    bl_idname = "vtskin.augment"
    bl_label = "Augment Point Cloud"

    def run(self, context):
        from vtcore.scene import interactive

        s = context.scene.vtskin
        cloud = s.cloud
        if cloud is None or cloud.type != "MESH" or len(cloud.data.vertices) == 0:
            raise _Cancel("Choose a point-cloud object (a mesh with vertices) in the panel")
        if cloud.mode == "EDIT":
            cloud.update_from_editmode()
        me = cloud.data
        pts = bridge.vertex_positions(me, bridge.matrix(cloud))
        n = len(pts)
        with _failing("Augmentation failed"):
            if s.probe_source == "FILE":
                probes, values = interactive.probes_from_file(bpy.path.abspath(s.probe_file))
            else:
                sel = bridge.selected_vertices(me)
                if len(sel) == 0:
                    raise _Cancel(f"No vertices of {cloud.name!r} are selected as probes")
                if s.probe_attribute not in me.attributes:
                    raise _Cancel(f"{cloud.name!r} has no attribute {s.probe_attribute!r} with probe values")
                probes = pts[sel]
                values = bridge.get_attribute(me, s.probe_attribute).astype(np.float64)
                if values.ndim != 1:
                    raise _Cancel(f"Attribute {s.probe_attribute!r} must be a float attribute")
                values = values[sel]
            vals, rgb = interactive.augment(pts, probes, values, method=s.propagation, beta=s.beta)
        bridge.set_attribute(me, "tactile_value", vals, "FLOAT")
        bridge.set_attribute(me, "tactile_color", rgb, "FLOAT_COLOR")
        me.color_attributes.active_color_name = "tactile_color"
        cloud.vtskin.role = "CLOUD"
        cloud.vtskin.color_by = "tactile_color"
        display.ensure_display(cloud)
        self.report({"INFO"}, f"Coloured {n} points from {len(probes)} probes")
        return {"FINISHED"}


# ---------------------------------------------------------------------------
# Export


class VTSKIN_OT_export(_Op, bpy.types.Operator):
    """Write the skin layout in a calibrated layout format"""

    bl_idname = "vtskin.export"
    bl_label = "Export Layout"
    bl_options = {"REGISTER"}

    filepath: bpy.props.StringProperty(name="File", subtype="FILE_PATH")

    def run(self, context):
        from vtcore.scene import interactive

        s = context.scene.vtskin
        ob = _need_skin(context, "Select a skin with taxels to export", taxels=True)
        path = bpy.path.abspath(self.filepath or s.export_path)
        if not path:
            raise _Cancel("No export file given")
        transform = None
        if s.export_frame is not None and s.export_frame != ob:
            transform = np.linalg.inv(bridge.rigid(bridge.matrix(s.export_frame))) @ bridge.matrix(ob)
        with _failing("Export failed"):
            out = interactive.export_layout(skin.read_layout(ob), skin.triangles(ob), path, s.export_format,
                                            transform)
        self.report({"INFO"}, f"Wrote {out}")
        return {"FINISHED"}


CLASSES = (VTSKIN_OT_run_scene, VTSKIN_OT_lay_patch, VTSKIN_OT_remove_module, VTSKIN_OT_move_module,
           VTSKIN_OT_simulate, VTSKIN_OT_bake, VTSKIN_OT_clear_bake, VTSKIN_OT_load_recording, VTSKIN_OT_edges, VTSKIN_OT_augment,
           VTSKIN_OT_export)
