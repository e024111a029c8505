"""*Fill* on a link object of an imported robot (issue 33): the modules go on the link's exposed
surface only, as ``vtcore layout fill ROBOT --link`` lays them, the link shows that surface as face
colours with a legend and the skin's report says what was left out; *Anywhere on the link* fills as
before; a plain mesh (not a link) is filled as it always was, with no colours and no legend.
The synthetic arm of test_robot_exposure (a wrist whose end faces mate with the elbow and the hand),
checked with trimesh on meshes built in the test, not with the code that computed the exposure.
Headless, both bpy lanes."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

bpy = pytest.importorskip("bpy")
sys.path.insert(0, str(Path(__file__).parent / "blender"))
from bl_helpers import addon_fixtures  # noqa: E402
from test_robot_exposure import MM, arm, clearance_to_others, world_meshes  # noqa: E402, F401  (arm: a fixture)

pytestmark = [pytest.mark.blender, pytest.mark.filterwarnings("ignore::UserWarning")]

addon, factory = addon_fixtures()

#: on the wrist's tube (radius 25 mm, z 0 .. 60 mm; the link frame is the world at the zero pose)
SIDE = (0.0, -0.025, 0.030)


def fill(ob, radius=0.2, anywhere=False):
    """Fill round the wrist's side (Radius round cursor) on ``ob``; the skin object made."""
    s = bpy.context.scene.vtskin
    s.fill_region, s.fill_radius, s.fill_anywhere = "RADIUS", radius, anywhere
    bpy.context.scene.cursor.location = SIDE
    bpy.context.view_layer.objects.active = ob
    assert bpy.ops.vtskin.lay_patch(fill=True) == {"FINISHED"}
    return next(o for o in bpy.data.objects if o.vtskin.role == "TAXELS" and o.vtskin.end_effector == ob)


def import_wrist(arm):
    s = bpy.context.scene.vtskin
    s.robot_file, s.robot_joints = str(arm), ""
    assert bpy.ops.vtskin.import_robot() == {"FINISHED"}
    return bpy.data.objects["wrist"]


def face_colours(ob) -> np.ndarray | None:
    me = ob.data
    if "vtskin_exposure" not in me.attributes:
        return None
    got = np.empty(4 * len(me.polygons), np.float32)
    me.attributes["vtskin_exposure"].data.foreach_get("color", got)
    return got.reshape(-1, 4).astype(np.float64)


def face_normals(ob) -> np.ndarray:
    n = np.empty(3 * len(ob.data.polygons), np.float32)
    ob.data.polygons.foreach_get("normal", n)
    return n.reshape(-1, 3)


def test_fill_on_a_link_keeps_to_its_exposed_surface_and_shows_it(arm):
    from vtcore.robot.exposure import ALWAYS_COVERED, COLOURS, COVERED, EXPOSED

    from addon import skin

    wrist = import_wrist(arm)
    ob = fill(wrist)
    lay = skin.read_layout(ob)
    assert len(lay) >= 30 and clearance_to_others("wrist", lay, world_meshes()).min() > 2 * MM
    assert "exposure of 'wrist': left out" in ob.vtskin.report and "elbow" in ob.vtskin.report
    # the wrist rolls on the elbow (continuous joint): its bottom covered at every pose; the top under
    # the hand; the tube exposed; the legend says so, with the every-pose colour Import Robot (zero pose) had not
    got, n = face_colours(wrist), face_normals(wrist)
    colour = {k: np.array(c) for k, (c, _) in COLOURS.items()}
    np.testing.assert_allclose(got[n[:, 2] < -0.9], np.broadcast_to(colour[ALWAYS_COVERED], got[n[:, 2] < -0.9].shape),
                               atol=1e-6)
    top = got[n[:, 2] > 0.9]
    assert all(np.allclose(c, colour[COVERED]) or np.allclose(c, colour[ALWAYS_COVERED]) for c in top)
    side = got[np.abs(n[:, 2]) < 0.1]
    assert np.mean([np.allclose(c, colour[EXPOSED]) for c in side]) > 0.9
    legend = wrist.vtskin.exposure_legend.splitlines()
    assert legend[0].startswith("green: exposed, ")
    assert any(line.startswith("dark red: covered by another link at every sampled pose") for line in legend)
    # the panels, the link active: the Robot panel's legend box, the Fill box's Anywhere on the link
    from addon import panel

    bpy.context.view_layer.objects.active = wrist
    s = bpy.context.scene.vtskin
    log = []
    panel.VTSKIN_PT_robot.draw_more(None, Recorder(log), s, bpy.context)
    labels = [k.get("text") for name, _, k in log if name == "label"]
    assert labels[0] == "Link wrist (visual)" and labels[1:1 + len(legend)] == legend
    log.clear()
    panel.VTSKIN_PT_layout.draw_more(None, Recorder(log), s, bpy.context)
    assert ("prop", (s, "fill_anywhere"), {}) in log


class Recorder:
    """Stands for a panel's layout: records each call (name, args, kwargs) and returns another."""

    def __init__(self, log):
        self.log = log

    def __getattr__(self, name):
        def call(*args, **kwargs):
            self.log.append((name, args, kwargs))
            return Recorder(self.log)
        return call


def test_fill_anywhere_on_a_link_and_on_a_plain_mesh_lays_over_the_mating_faces(arm):
    """Anywhere on the link: the fill of before issue 33 (taxels on the end faces, against the
    neighbours). The same cylinder as a plain mesh object: vtcore's plain fill, no colours, no legend."""
    from vtcore.scene import interactive

    from addon import bridge, opbase, skin

    world = world_meshes()
    wrist = import_wrist(arm)
    before = face_colours(wrist)
    lay = skin.read_layout(fill(wrist, anywhere=True))
    assert clearance_to_others("wrist", lay, world).min() < 2 * MM  # on the faces that mate with the neighbours
    np.testing.assert_array_equal(face_colours(wrist), before)  # nothing judged: Import Robot's colours stay
    me = bpy.data.meshes.new("plain")
    bridge.write_mesh(me, world["wrist"].vertices, world["wrist"].faces)
    plain = bpy.data.objects.new("plain", me)
    bpy.context.scene.collection.objects.link(plain)
    ob = fill(plain)
    verts, tri = opbase.mesh_in_frame(plain, opbase.skin_frame(plain))
    s = bpy.context.scene.vtskin
    ref = interactive.lay_patch(verts, tri, np.array(SIDE), direction=[1.0, 0, 0], radius=0.2,
                                max_faces=s.solve_faces, crease_angle=float(np.degrees(s.crease_angle)),
                                islands=s.islands)
    np.testing.assert_allclose(skin.read_layout(ob).positions, ref.layout.positions, atol=1e-6)
    assert ref.exposure is None and face_colours(plain) is None and plain.vtskin.exposure_legend == ""
    assert "exposure" not in ob.vtskin.report
