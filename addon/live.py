"""Live touch: the skin follows the indenter while it moves (Contact panel, *Live touch*).

A ``depsgraph_update_post`` handler notices the indenter's new pose (a drag, a keyframe, a script
moving it and updating the view layer) and hands it to ``vtcore.scene.interactive.LiveWorker``, which
solves it on a background thread; a timer on the main thread writes the newest finished frame into the
skin's ``pressure``, ``response``, ``edge_response`` and ``edge`` attributes. Poses that arrive while a
solve runs replace each other: the skin shows the newest pose as soon as it can, the interface never
waits. In background mode (``blender -b``, the bpy wheel) there is no event loop for a timer, so the
handler solves and writes at once: moving the indenter and updating the view layer updates the skin.
"""

from __future__ import annotations

import bpy
import numpy as np
from bpy.app.handlers import persistent

from . import bridge, display, skin

#: seconds between the timer's looks at the worker (60 Hz)
POLL_S = 1.0 / 60.0

_STATE: dict = {"live": None, "worker": None, "key": None, "skin": None, "pose": None}


def toggle(scene, on: bool) -> None:
    """Start or stop live touch for ``scene`` (the ``live_touch`` property's update)."""
    if on:
        sk = skin.skin_of(bpy.context)
        _STATE["skin"] = sk.name if sk is not None else None
        if on_depsgraph not in bpy.app.handlers.depsgraph_update_post:
            bpy.app.handlers.depsgraph_update_post.append(on_depsgraph)
        if not bpy.app.background and not bpy.app.timers.is_registered(poll):
            bpy.app.timers.register(poll, first_interval=POLL_S)
        on_depsgraph(scene)
    else:
        stop()


def stop() -> None:
    if on_depsgraph in bpy.app.handlers.depsgraph_update_post:
        bpy.app.handlers.depsgraph_update_post.remove(on_depsgraph)
    if bpy.app.timers.is_registered(poll):
        bpy.app.timers.unregister(poll)
    if _STATE["worker"] is not None:
        _STATE["worker"].close()
    _STATE.update(live=None, worker=None, key=None, pose=None)


def _skin_object(scene):
    ob = scene.objects.get(_STATE["skin"] or "")
    if skin.is_taxels(ob):
        return ob
    return next((o for o in scene.objects if skin.is_taxels(o) and len(o.data.vertices)), None)


def _settings_key(s, ob, ind):
    return (ob.name, len(ob.data.vertices), ind.name, ind.data.name, len(ind.data.vertices), s.thickness, s.material,
            s.live_model, s.use_force, s.force, s.sensor_gain(), s.edge_fraction, s.geometry)


def _live_for(scene, ob, ind):
    """The LiveTouch of the current skin, indenter and settings (rebuilt when any of them changes)."""
    from vtcore.scene import interactive

    s = scene.vtskin
    key = _settings_key(s, ob, ind)
    if key != _STATE["key"]:
        if _STATE["worker"] is not None:
            _STATE["worker"].close()
        world, tri = bridge.read_mesh(ind)
        inv = np.linalg.inv(bridge.rigid(bridge.matrix(ind)))
        verts = world @ inv[:3, :3].T + inv[:3, 3]
        live = interactive.LiveTouch(skin.read_layout(ob), skin.triangles(ob), verts, tri, thickness=s.thickness,
                                     material=s.material, model=s.live_model,
                                     force=s.force if s.use_force else None, counts_per_pa=s.sensor_gain(),
                                     edge_fraction=s.edge_fraction, geometry=s.geometry)
        _STATE.update(live=live, key=key, pose=None,
                      worker=None if bpy.app.background else interactive.LiveWorker(live))
    return _STATE["live"]


def on_depsgraph(scene, depsgraph=None):
    """Hand the indenter's pose to the solver when it moved (see the module docstring)."""
    from vtcore.errors import VtError

    s = scene.vtskin
    if not s.live_touch:
        return
    ob, ind = _skin_object(scene), s.indenter
    if ob is None or ind is None or ind.type != "MESH" or s.thickness <= 0:
        s.live_note = "Live touch needs a skin, an indenter mesh and a layer thickness > 0"
        return
    pose = np.linalg.inv(bridge.matrix(ob)) @ bridge.rigid(bridge.matrix(ind))
    key = _settings_key(s, ob, ind)
    if key == _STATE["key"] and _STATE["pose"] is not None and np.allclose(pose, _STATE["pose"], atol=1e-9):
        return  # nothing moved (our own attribute writes land here too)
    try:
        live = _live_for(scene, ob, ind)
        _STATE["pose"] = pose
        if _STATE["worker"] is None:
            write(ob, live.update(pose), s)
        else:
            _STATE["worker"].request(pose)
    except (VtError, ValueError) as exc:
        s.live_note = str(exc)


def poll():
    """Timer: write the worker's newest frame; keeps running while live touch is on."""
    from vtcore.errors import VtError

    scene = bpy.context.scene
    s = getattr(scene, "vtskin", None)
    if s is None or not s.live_touch:
        return None
    w = _STATE["worker"]
    if w is not None:
        try:
            frame = w.take()
        except (VtError, ValueError) as exc:
            s.live_note = str(exc)
            frame = None
        ob = _skin_object(scene)
        if frame is not None and ob is not None:
            write(ob, frame, s)
    return POLL_S


def write(ob, frame, s) -> None:
    """The frame's quantities into the skin's attributes (main thread only)."""
    c = frame.contact
    me = ob.data
    if len(me.vertices) != len(c.pressure):
        return  # the skin was edited since the solve: the next pose rebuilds
    bridge.set_attribute(me, "pressure", c.pressure)
    bridge.set_attribute(me, "response", c.response)
    bridge.set_attribute(me, "edge_response", c.edge_response, "FLOAT")
    bridge.set_attribute(me, "edge", c.edge)
    ob.vtskin.force = c.force
    if s.live_note != frame.note:
        s.live_note = frame.note
    if ob.modifiers.get(display.MODIFIER) is None:
        display.ensure_display(ob)


@persistent
def on_load_post(*_args):
    """A file saved with live touch on opens with it on (and a file opened over a live session stops it)."""
    stop()
    scene = bpy.context.scene
    s = getattr(scene, "vtskin", None) if scene is not None else None
    if s is not None and s.live_touch:
        toggle(scene, True)


def register() -> None:
    if on_load_post not in bpy.app.handlers.load_post:
        bpy.app.handlers.load_post.append(on_load_post)


def unregister() -> None:
    if on_load_post in bpy.app.handlers.load_post:
        bpy.app.handlers.load_post.remove(on_load_post)
    stop()
