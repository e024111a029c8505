"""Render the design-map pictures of docs/evaluate.md headless, with the add-on's own operators.

    .venv/bin/python scripts/render_evaluate.py [--out docs/img] [--samples 16]

Two robot links, each skinned with a CySkin fill (vtcore.layout.fill, as the add-on's *Fill* lays it),
evaluated with *Evaluate Skin* (finger pad along the link, 5 N, 2 mm), the map's *Legend* beside it,
rendered with Cycles on the CPU:
- the UR5 forearm's collision mesh from example-robot-data (1,050 faces; its long faces are split to
  3 mm first, as a user subdivides a coarse mesh: the map lives on the mesh's own vertices);
- a CAD-style link (vtcore.layout.cadmeshes.cad_link: a 72 mm tube with flange and boss, sliver
  triangles, non-manifold fins, duplicated faces).
"""

from __future__ import annotations

import argparse
import os
import sys
import sysconfig
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "scripts"))


def ur5_forearm():
    import trimesh

    path = (Path(sysconfig.get_paths()["purelib"]) / "cmeel.prefix" / "share" / "example-robot-data" / "robots"
            / "ur_description" / "meshes" / "ur5" / "collision" / "forearm.stl")
    return trimesh.load(path, force="mesh"), np.array([0.2, 0.0, 0.2])


def cad():
    from vtcore.layout.cadmeshes import cad_link

    return cad_link(), np.array([0.0, 0.2, 0.02])


def scene_for(context, mesh, towards, name):
    """The link as a Blender object, its skin filled round ``towards``, and the skin object."""
    import bpy

    from addon import bridge, skin
    from vtcore.layout import fill
    from vtcore.layout.repair import refine
    from vtcore.layout.surface import closest_points

    cp, _, _ = closest_points(mesh, towards[None])
    lay, _ = fill(mesh, cp[0], (0, 0, 1), radius=0.07)
    shown = refine(mesh, 0.003, max_faces=400_000)  # the map lives on the mesh's vertices: split long faces
    me = bpy.data.meshes.new(name)
    bridge.write_mesh(me, shown.vertices, shown.faces)
    ee = bpy.data.objects.new(name, me)
    context.scene.collection.objects.link(ee)
    sk = skin.new_object(context, f"{name} skin")
    skin.write_layout(sk, lay, None)
    sk.vtskin.end_effector = ee
    return ee, sk, lay


def camera(context, ee, sk, lay, mapped):
    """A camera looking at the skin's middle from outside, far enough to show the margin and the legend."""
    import bpy
    from mathutils import Vector

    from addon import display

    centre = lay.positions.mean(axis=0)
    out = lay.normals.mean(axis=0)
    out /= np.linalg.norm(out)
    side = np.cross(out, [0.0, 0.0, 1.0])
    side /= max(np.linalg.norm(side), 1e-9)
    cam = bpy.data.objects.new("camera", bpy.data.cameras.new("camera"))
    cam.data.lens = 40
    context.scene.collection.objects.link(cam)
    eye = centre + 0.42 * out + 0.10 * side + 0.06 * np.array([0, 0, 1.0])
    cam.location = Vector(eye)
    view = centre - eye
    right = np.cross(view, [0.0, 0.0, 1.0])
    right /= np.linalg.norm(right)
    half_w = np.linalg.norm(view) * 18.0 / cam.data.lens
    # aim right of the skin: the link sits left of the frame, the legend (right edge) beside it
    look = Vector(centre + 0.45 * half_w * right) - cam.location
    cam.rotation_euler = look.to_track_quat("-Z", "Y").to_euler()
    context.scene.camera = cam
    sun = bpy.data.objects.new("sun", bpy.data.lights.new("sun", "SUN"))
    sun.data.energy = 2.0
    sun.rotation_euler = cam.rotation_euler
    context.scene.collection.objects.link(sun)
    world = bpy.data.worlds.new("world")
    bg = display.shader_nodes(world).nodes["Background"]
    bg.inputs["Color"].default_value = (0.85, 0.86, 0.88, 1)
    bg.inputs["Strength"].default_value = 0.7
    context.scene.world = world


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--out", default=str(ROOT / "docs" / "img"))
    ap.add_argument("--samples", type=int, default=16)
    ap.add_argument("--only", choices=("ur5", "cad"), default=None)
    args = ap.parse_args()
    import bpy
    from render_docs import render  # the docs' own Cycles settings (CPU, Standard view)

    from tests.blender.bl_helpers import register_addon

    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    addon = register_addon()
    cases = {"ur5": ("ur5_forearm", ur5_forearm, ("threshold", "localisation")),
             "cad": ("cad_link", cad, ("threshold", "two_point"))}
    for key, (name, make, maps) in cases.items():
        if args.only and key != args.only:
            continue
        bpy.ops.wm.read_factory_settings(use_empty=True)
        ctx = bpy.context
        mesh, towards = make()
        ee, sk, lay = scene_for(ctx, mesh, towards, name)
        s = ctx.scene.vtskin
        s.thickness, s.map_reference_force, s.map_spacing, s.map_margin = 0.003, 5.0, 0.002, 0.01
        ctx.view_layer.objects.active = sk
        assert bpy.ops.vtskin.evaluate_skin() == {"FINISHED"}
        print(name, ee.vtskin.map_legend.replace("\n", " | "))
        camera(ctx, ee, sk, lay, maps[0])
        sk.hide_render = True  # the discs would hide the map under them
        for m in maps:
            s.map_show = m
            assert bpy.ops.vtskin.map_legend() == {"FINISHED"}
            render(ctx, out / f"evaluate_{name}_{m}.png", args.samples, size=(900, 640))
    addon.unregister()
    sys.stdout.flush()
    os._exit(0)


if __name__ == "__main__":
    main()
