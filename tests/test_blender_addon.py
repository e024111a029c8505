"""The add-on registered from the repository, inside the bpy 4.5 wheel (headless).

All Blender tests of this file run in one pytest-xdist worker (``--dist loadfile``);
each starts from the factory-empty scene.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

bpy = pytest.importorskip("bpy")
sys.path.insert(0, str(Path(__file__).parent / "blender"))
from bl_helpers import addon_fixtures, scene_state  # noqa: E402

pytestmark = pytest.mark.blender

addon, factory = addon_fixtures()


def attribute(ob, name):
    from addon import bridge

    return bridge.get_attribute(ob.data, name)


def test_run_scene_writes_taxel_attributes(scenes_dir, tmp_path):
    from vtcore.scene.interactive import run_scene_file

    bpy.context.scene.vtskin.out_dir = str(tmp_path / "run")
    res = bpy.ops.vtskin.run_scene(filepath=str(scenes_dir / "demo.toml"))
    assert res == {"FINISHED"}
    ob = bpy.context.view_layer.objects.active
    assert ob.vtskin.role == "TAXELS"
    ref = run_scene_file(scenes_dir / "demo.toml", tmp_path / "ref")
    n = len(ref.layout)
    assert len(ob.data.vertices) == n
    np.testing.assert_allclose(attribute(ob, "response"), ref.response, rtol=1e-6)
    np.testing.assert_allclose(attribute(ob, "pressure"), ref.pressure, rtol=1e-6)
    np.testing.assert_array_equal(attribute(ob, "taxel_id"), ref.layout.taxel_ids)
    np.testing.assert_array_equal(attribute(ob, "module_id"), ref.layout.module_ids)
    np.testing.assert_allclose(attribute(ob, "normal"), ref.layout.normals, atol=1e-6)
    assert not attribute(ob, "edge").any()
    co = np.empty(3 * n, np.float32)
    ob.data.vertices.foreach_get("co", co)
    np.testing.assert_allclose(co.reshape(-1, 3), ref.layout.positions, atol=1e-7)
    assert len(ob.data.polygons) == len(ref.triangles) > 0
    assert (tmp_path / "run" / "result.json").is_file()
    # The disc display evaluates: instances + the skin mesh, coloured attribute stored.
    from bl_helpers import display_colours

    colours = display_colours(ob)  # one disc instance per taxel, plus one tube per skin-mesh edge
    assert colours is not None and len(colours) == len(ob.data.vertices) + len(ob.data.edges)


@pytest.mark.parametrize("bad", ["missing", "not_toml", "empty"])
def test_run_scene_bad_file_leaves_scene_unchanged(tmp_path, bad):
    bpy.ops.mesh.primitive_cube_add()
    before = scene_state()
    if bad == "missing":
        path = tmp_path / "nope.toml"
    elif bad == "not_toml":
        path = tmp_path / "bad.toml"
        path.write_text("[scene\nthis is not toml")
    else:
        path = ""
    with pytest.raises(RuntimeError, match="Error"):
        bpy.ops.vtskin.run_scene(filepath=str(path))
    assert scene_state() == before
