"""Rendering a skin's replay to images or a video (headless too: ``blender -b``, the bpy wheel).

Blender-side only: a camera framed on the skin, a light, the engine and output settings of
a scene's ``[output]`` (``video = "frames"|"mp4"``, ``engine``, ``resolution``,
``samples``), then Blender's own animation render over the replay's frame range. The
playback handler shows each frame's cached values, so every rendered frame is the
recording at that time.

What renders headless (checked with the bpy 4.5.15 and 5.2.3 wheels on a machine without a
GPU): Cycles on the CPU, and Workbench through Mesa's software EGL (Blender prints
``EGL_BAD_MATCH`` lines first and then renders). Workbench draws the discs in their
material's viewport colour only, not the per-taxel colour the shader reads from the
instancer (its attribute colour mode reads a mesh's active colour attribute; realising the
instances did not carry the colour there in a quick try), so the recording shows in
Cycles; Workbench renders the skin and its mesh, as a quick framing preview.
"""

from __future__ import annotations

from pathlib import Path

import bpy
import numpy as np

from . import bridge, display

CAMERA = "vtskin replay camera"
LIGHT = "vtskin replay light"


def frame_camera(context, ob, lens: float = 50.0):
    """A camera (made once) looking at taxel object ``ob`` along its mean normal, tilted 30
    degrees, far enough that every taxel is in view; and a sun. Returns the camera object."""
    from mathutils import Vector

    me = ob.data
    m = bridge.matrix(ob)
    world = bridge.vertex_positions(me, m)
    centre = world.mean(axis=0)
    radius = max(float(np.linalg.norm(world - centre, axis=1).max()), 5e-3)
    nrm = bridge.get_attribute(me, "normal").astype(np.float64) if "normal" in me.attributes else None
    up = nrm.mean(axis=0) @ m[:3, :3].T if nrm is not None and len(nrm) else np.array([0.0, 0.0, 1.0])
    up = up / max(np.linalg.norm(up), 1e-12)
    side = np.cross(up, [1.0, 0.0, 0.0] if abs(up[0]) < 0.9 else [0.0, 1.0, 0.0])
    side /= np.linalg.norm(side)
    view = np.cos(np.radians(30)) * up + np.sin(np.radians(30)) * side
    half_fov = np.arctan(18.0 / lens)  # 36 mm sensor width
    dist = 1.25 * radius / np.tan(half_fov)

    cam = bpy.data.objects.get(CAMERA)
    if cam is None:
        cam = bpy.data.objects.new(CAMERA, bpy.data.cameras.new(CAMERA))
        context.scene.collection.objects.link(cam)
    cam.data.lens = lens
    cam.data.clip_start, cam.data.clip_end = dist / 100, dist * 10
    cam.location = Vector(centre + dist * view)
    cam.rotation_euler = Vector(-view).to_track_quat("-Z", "Y").to_euler()
    context.scene.camera = cam
    sun = bpy.data.objects.get(LIGHT)
    if sun is None:
        sun = bpy.data.objects.new(LIGHT, bpy.data.lights.new(LIGHT, "SUN"))
        sun.data.energy = 2.5
        context.scene.collection.objects.link(sun)
    sun.rotation_euler = cam.rotation_euler
    if context.scene.world is None:  # a light grey sky, so the dark skin-mesh edges read
        world = bpy.data.worlds.new(CAMERA)
        bg = display.shader_nodes(world).nodes.get("Background")
        if bg is not None:
            bg.inputs["Color"].default_value = (0.78, 0.8, 0.83, 1.0)
            bg.inputs["Strength"].default_value = 0.6
        world.color = (0.78, 0.8, 0.83)
        context.scene.world = world
    return cam


def _engine(scene, output):
    r = scene.render
    if output["engine"] == "cycles":
        r.engine = "CYCLES"
        scene.cycles.device = "CPU"
        scene.cycles.samples = int(output["samples"])
        scene.cycles.use_denoising = False
    else:
        r.engine = "BLENDER_WORKBENCH"
        scene.display.shading.light = "STUDIO"
        scene.display.shading.color_type = "MATERIAL"
    r.resolution_x, r.resolution_y = (int(v) for v in output["resolution"])
    r.resolution_percentage = 100
    scene.view_settings.view_transform = "Standard"


def _video_format(scene):
    """MP4 (H.264) output. 5.x asks for the media type before a video file format."""
    im = scene.render.image_settings
    if hasattr(im, "media_type"):
        im.media_type = "VIDEO"
    im.file_format = "FFMPEG"
    ff = scene.render.ffmpeg
    ff.format = "MPEG4"
    ff.codec = "H264"


def _image_format(scene):
    im = scene.render.image_settings
    if hasattr(im, "media_type"):
        im.media_type = "IMAGE"
    im.file_format = "PNG"


def render_replay(context, ob, out_dir, output: dict) -> Path:
    """Render the cached frames of taxel object ``ob`` as ``out_dir/replay_####.png`` (``video =
    "frames"``) or ``out_dir/replay.mp4``. ``output``: a scene's ``[output]`` table. Returns the
    video file or the folder of frames."""
    scene = context.scene
    s = ob.vtskin
    if s.cache is None or s.bake_end < s.bake_start:
        raise ValueError(f"{ob.name!r} has no replay to render")
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    display.ensure_display(ob)
    frame_camera(context, ob)
    _engine(scene, output)
    scene.frame_start, scene.frame_end = s.bake_start, s.bake_end
    fps = float(output["fps"])
    scene.render.fps = max(1, round(fps))
    scene.render.fps_base = scene.render.fps / fps  # 29.97 fps: 30 / 1.001
    if output["video"] == "mp4":
        _video_format(scene)
        target = out_dir / "replay.mp4"
        scene.render.filepath = str(target)
    else:
        _image_format(scene)
        target = out_dir
        scene.render.filepath = str(out_dir / "replay_")
    bpy.ops.render.render(animation=True)
    return target
