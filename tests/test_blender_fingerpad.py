"""The add-on's finger pad (issue 27): Add Finger Pad makes the vtcore capsule the indenter, Simulate
presses it, and a press that compresses the layer past 30 % says so. Headless, both bpy lanes."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

bpy = pytest.importorskip("bpy")
sys.path.insert(0, str(Path(__file__).parent / "blender"))
from bl_helpers import addon_fixtures, build_scene  # noqa: E402

pytestmark = [pytest.mark.blender, pytest.mark.filterwarnings("ignore::UserWarning")]

addon, factory = addon_fixtures()


def test_add_fingerpad_simulate_and_the_large_compression_warning():
    from addon import bridge, skin
    from vtcore.scene import interactive

    ee, ind, centre = build_scene()
    bpy.context.scene.cursor.location = tuple(centre)    # build_scene's centre is already in world
    bpy.context.view_layer.objects.active = ee
    assert bpy.ops.vtskin.lay_patch() == {"FINISHED"}
    ob = next(o for o in bpy.data.objects if o.vtskin.role == "TAXELS")
    # the pad above the sphere indenter's place, which sits just above the skin's middle
    bpy.context.scene.cursor.location = tuple(bridge.matrix(ind)[:3, 3])
    assert bpy.ops.vtskin.add_fingerpad(radius=0.008, length=0.04) == {"FINISHED"}
    s = bpy.context.scene.vtskin
    pad = s.indenter
    assert pad is not None and pad.name.startswith("FingerPad")
    verts, faces = interactive.indenter_mesh("fingerpad", radius=0.008, length=0.04)
    got, tri = bridge.read_mesh(pad, world=False)
    assert len(got) == len(verts) and len(tri) == len(faces)
    assert np.ptp(got[:, 0]) == pytest.approx(0.04, abs=1e-6) and np.ptp(got[:, 1]) == pytest.approx(0.016, abs=1e-6)
    assert got[:, 2].max() == pytest.approx(0.0, abs=1e-6)    # pressed face down, top at the cursor
    # lay it on the skin: its back 16 mm + 3 mm layer + 2 mm gap out along the skin's mean normal, turned to face it
    from vtcore.geometry import tangent_basis

    layout = skin.read_layout(ob)
    m_ob = bridge.matrix(ob)
    n = m_ob[:3, :3] @ layout.normals.mean(axis=0)
    n /= np.linalg.norm(n)
    c = m_ob[:3, :3] @ layout.positions.mean(axis=0) + m_ob[:3, 3]
    t1, t2 = tangent_basis(n)
    m = np.eye(4)
    m[:3, :3] = np.column_stack([t1, t2, n])
    m[:3, 3] = c + (0.016 + 0.003 + 0.002) * n
    pad.matrix_world = bridge.to_matrix(m)
    bpy.context.view_layer.update()
    s.thickness, s.force, s.use_force = 0.003, 0.3, True
    bpy.context.view_layer.objects.active = ob
    assert bpy.ops.vtskin.simulate() == {"FINISHED"}
    assert bridge.get_attribute(ob.data, "pressure").max() > 0
    # the same press, from vtcore, with the compression it reports; a firm press through 1 mm warns
    m_pad = bridge.rigid(bridge.matrix(pad))
    world, ftri = bridge.read_mesh(pad)
    inv = np.linalg.inv(m_pad)
    local = world @ inv[:3, :3].T + inv[:3, 3]
    pose = np.linalg.inv(bridge.matrix(ob)) @ m_pad
    tri = skin.triangles(ob)
    soft = interactive.simulate(layout, tri, local, ftri, pose, thickness=0.003, force=0.3)
    firm = interactive.simulate(layout, tri, local, ftri, pose, thickness=0.0015, force=2.5)
    assert soft.compression < 0.3 and soft.warning == ""
    assert 0.3 < firm.compression < 1.0 and "outside linear elasticity" in firm.warning
    s.thickness, s.force = 0.0015, 2.5
    assert bpy.ops.vtskin.simulate() == {"FINISHED"}    # a warning, not a failure
