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
