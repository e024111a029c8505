"""Install the built extension zip into a fresh Blender profile and use it (run in a subprocess).

Usage: python install_check.py ZIP SCENE OUT_JSON

HOME must point to an empty temporary folder (the fresh profile). The repo's
editable vtcore is removed from the import system first, so every vtcore import
below must come from the wheel bundled in the zip. Writes a JSON summary to
OUT_JSON and exits non-zero on any failure.
"""

import json
import os
import sys
from pathlib import Path

# Only the bundled wheel may provide vtcore: drop the editable-install finder
# and the repository from the import path.
sys.meta_path[:] = [f for f in sys.meta_path
                    if not getattr(f, "__module__", "").startswith("__editable__")]
sys.path[:] = [p for p in sys.path if p and Path(p).resolve() != Path(__file__).resolve().parents[2]]
assert "vtcore" not in sys.modules

import bpy  # noqa: E402
import numpy as np  # noqa: E402

zip_path, scene_path, out_json = sys.argv[1:4]
home = Path(os.environ["HOME"]).resolve()
summary = {}

bpy.ops.wm.read_factory_settings(use_empty=True)
res = bpy.ops.extensions.package_install_files(filepath=zip_path, repo="user_default",
                                               enable_on_install=True)
summary["install"] = sorted(res)
assert res == {"FINISHED"}, res
summary["addon_enabled"] = "bl_ext.user_default.vtskin" in bpy.context.preferences.addons.keys()
assert summary["addon_enabled"], list(bpy.context.preferences.addons.keys())
assert hasattr(bpy.ops.vtskin, "run_scene")

import vtcore  # noqa: E402

summary["vtcore_file"] = vtcore.__file__
assert Path(vtcore.__file__).resolve().is_relative_to(home), vtcore.__file__
summary["blender"] = bpy.app.version_string
summary["numpy"] = np.__version__

# Lay Patch, Simulate and Detect Edges through the installed operators, each checked
# against the bundled vtcore called directly with the same input.
from bl_ext.user_default.vtskin import bridge, skin  # noqa: E402
from vtcore.scene import interactive  # noqa: E402

bpy.ops.mesh.primitive_uv_sphere_add(radius=0.06, segments=64, ring_count=32, location=(0, 0, 0))
ee = bpy.context.active_object
bpy.context.scene.cursor.location = (0.0, 0.0, 0.06)
res = bpy.ops.vtskin.lay_patch()
summary["lay_patch"] = sorted(res)
assert res == {"FINISHED"}, res
skin_ob = next(o for o in bpy.data.objects if o.vtskin.role == "TAXELS")
summary["patch_taxels"] = len(skin_ob.data.vertices)
assert summary["patch_taxels"] > 0 and summary["patch_taxels"] % 10 == 0, summary["patch_taxels"]

bpy.ops.mesh.primitive_ico_sphere_add(radius=0.015, subdivisions=4, location=(0, 0, 0.06 + 0.003 + 0.015 + 0.002))
ind = bpy.context.active_object
s = bpy.context.scene.vtskin
s.indenter, s.thickness, s.force = ind, 0.003, 1.0
bpy.context.view_layer.objects.active = skin_ob
res = bpy.ops.vtskin.simulate()
summary["simulate"] = sorted(res)
assert res == {"FINISHED"}, res
layout, tri = skin.read_layout(skin_ob), skin.triangles(skin_ob)
m_ind = bridge.rigid(bridge.matrix(ind))
world, ftri = bridge.read_mesh(ind)
inv = np.linalg.inv(m_ind)
ref = interactive.simulate(layout, tri, world @ inv[:3, :3].T + inv[:3, 3], ftri,
                           np.linalg.inv(bridge.matrix(skin_ob)) @ m_ind, thickness=0.003, force=1.0)
assert abs(ref.force - 1.0) < 1e-3 and ref.edge.any(), (ref.force, ref.edge.sum())
got = bridge.get_attribute(skin_ob.data, "response")
np.testing.assert_allclose(got, ref.response, rtol=1e-5, atol=1e-3, err_msg="simulate response")
summary["contact_taxels"] = int((got > 0).sum())

s.edge_fraction = 0.6
res = bpy.ops.vtskin.edges()
summary["edges"] = sorted(res)
assert res == {"FINISHED"}, res
_, edge = interactive.edges(layout, tri, got.astype(float), 0.6)
np.testing.assert_array_equal(bridge.get_attribute(skin_ob.data, "edge"), edge, err_msg="edges")
summary["edge_taxels"] = int(edge.sum())
# The disc display follows (the modifier input is set differently in 4.x and 5.2).
mod = skin_ob.modifiers["vtskin discs"]
ident = next(i.identifier for i in mod.node_group.interface.items_tree
             if i.item_type == "SOCKET" and i.in_out == "INPUT" and i.name == "Attribute")
shown = getattr(mod.properties.inputs, ident).value if hasattr(mod, "properties") else mod[ident]
assert shown == "edge", shown

res = bpy.ops.vtskin.run_scene(filepath=scene_path)
summary["run_scene"] = sorted(res)
assert res == {"FINISHED"}, res
ob = bpy.context.view_layer.objects.active


def attrs(ob):
    me = ob.data
    out = {}
    for name, key, comps, dtype in (("response", "value", 1, np.float32), ("pressure", "value", 1, np.float32),
                                    ("taxel_id", "value", 1, np.int32), ("normal", "vector", 3, np.float32)):
        a = np.empty(len(me.vertices) * comps, dtype)
        me.attributes[name].data.foreach_get(key, a)
        out[name] = a.reshape(-1, comps) if comps > 1 else a
    co = np.empty(3 * len(me.vertices), np.float32)
    me.vertices.foreach_get("co", co)
    out["positions"] = co.reshape(-1, 3)
    return out


from vtcore.scene.interactive import run_scene_file  # noqa: E402

ref = run_scene_file(scene_path, home / "ref_out")
got = attrs(ob)
for name, want in (("response", ref.response), ("pressure", ref.pressure), ("taxel_id", ref.layout.taxel_ids),
                   ("normal", ref.layout.normals), ("positions", ref.layout.positions)):
    np.testing.assert_allclose(got[name], want, rtol=1e-5, atol=1e-6, err_msg=name)
summary["taxels"] = int(len(got["response"]))

blend = str(home / "installed.blend")
bpy.ops.wm.save_as_mainfile(filepath=blend)
name = ob.name
# Reopen (not factory-reset: that would also reset the preferences that enable the add-on).
bpy.ops.wm.open_mainfile(filepath=blend)
ob = bpy.data.objects[name]
again = attrs(ob)
for k in got:
    np.testing.assert_array_equal(again[k], got[k], err_msg=f"{k} after reload")
summary["reload_ok"] = True
summary["role_after_reload"] = ob.vtskin.role
with open(out_json, "w") as fh:
    json.dump(summary, fh)
print("INSTALL_CHECK_OK", json.dumps(summary))
sys.stdout.flush()
os._exit(0)  # skip bpy's slow teardown
