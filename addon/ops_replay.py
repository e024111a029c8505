"""Replay: load a recording onto the skin's taxels for playback on the timeline."""

from __future__ import annotations

from pathlib import Path

import bpy
import numpy as np

from . import bake, bridge, display, skin
from .opbase import Cancel, Op, failing, need_skin

def _boards(text: str):
    """iCub board addresses typed as ``3`` or ``14,13`` (None when empty)."""
    text = text.replace(" ", "")
    if not text:
        return None
    try:
        return [int(x, 0) for x in text.split(",") if x]
    except ValueError:
        raise Cancel(f"Boards: expected board addresses like 3 or 14,13, got {text!r}") from None


def store_replay(scene, ob, rep, path):
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


class VTSKIN_OT_load_recording(Op, bpy.types.Operator):
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
        ob = need_skin(context, "Select a skin with taxels to load the recording onto", taxels=True)
        if "taxel_id" not in ob.data.attributes:
            raise Cancel(f"{ob.name!r} has no taxel_id attribute: a recording is joined to the taxels by "
                          "UID / CAN address (lay the skin with the add-on, or run a scene)")
        path = bpy.path.abspath(self.filepath or s.recording_file)
        if not path:
            raise Cancel("No recording file given")
        kind = self.codec or s.recording_codec
        if kind not in KINDS:
            raise Cancel(f"Unknown codec {kind!r}; valid: {', '.join(KINDS)}")
        boards = _boards(self.boards or s.recording_boards)
        fps = scene.render.fps / scene.render.fps_base if s.replay_rate == "SCENE" else None
        with failing("Cannot load the recording"):
            rep = load_recording(path, skin.read_layout(ob), skin.triangles(ob), kind=kind, boards=boards, fps=fps,
                                 baseline=s.baseline, baseline_rows=s.baseline_rows,
                                 edge_fraction=s.edge_fraction, min_response=s.min_response)
        store_replay(scene, ob, rep, path)
        self.report({"INFO"}, f"{Path(path).name}: {len(rep.rows)} frames ({len(rep.timestamps)} rows) on "
                    f"{ob.name}, {rep.lost_frames} frames with lost samples; " + "; ".join(rep.mismatch()))
        return {"FINISHED"}


CLASSES = (VTSKIN_OT_load_recording,)
