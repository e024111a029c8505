"""The built extension: `scripts/build_extension.py` builds and validates the zip with
Blender's own tool; installing it into a fresh profile (HOME = a temporary folder)
enables the add-on, whose operator then runs on the BUNDLED vtcore wheel.

Installation runs in a subprocess: it needs its own HOME and must not see the
repository's editable vtcore nor the add-on registered by other tests.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import tempfile
import zipfile
from pathlib import Path

import pytest

pytest.importorskip("bpy")
pytestmark = pytest.mark.blender
HERE = Path(__file__).parent
TIMEOUT = 300  # s per subprocess; each takes well under a minute when healthy


@pytest.fixture(scope="module")
def built_zip(tmp_path_factory):
    root = Path(__file__).resolve().parents[1]
    dist = tmp_path_factory.mktemp("dist")
    # Staging and the downloaded wheels go to the system temp folder, not the checkout (the
    # wheel cache there survives between runs, so a run downloads nothing once warm).
    build = Path(tempfile.gettempdir()) / f"vtskin-test-build-py{sys.version_info.major}{sys.version_info.minor}"
    # With the isolated bundle check (an interpreter that sees only the bundled wheels and
    # numpy runs the demo scene, lays a patch, presses and propagates): the install below runs
    # in this venv's Python, which also sees every package of the lock, so only the check finds
    # a dependency the zip lacks (threadpoolctl did, after Run Scene started to import it).
    # timeout: a hung subprocess fails this test instead of hanging the suite.
    res = subprocess.run([sys.executable, str(root / "scripts" / "build_extension.py"), "--dist", str(dist),
                          "--build-dir", str(build)], capture_output=True, text=True, cwd=root,
                         timeout=TIMEOUT)
    assert res.returncode == 0, res.stdout[-3000:] + res.stderr[-3000:]
    zips = list(dist.glob("vtskin-*.zip"))
    assert len(zips) == 1
    assert "bundle ok: 60 taxels" in res.stdout, res.stdout[-3000:]
    return zips[0]


def test_zip_contents(built_zip):
    import tomllib

    with zipfile.ZipFile(built_zip) as zf:
        names = zf.namelist()
        manifest = tomllib.loads(zf.read("blender_manifest.toml").decode())
    assert "__init__.py" in names and "ops.py" in names
    assert not any("__pycache__" in n or n.startswith("tests/") for n in names)
    wheels = manifest["wheels"]
    assert all(w.startswith("./wheels/") and w[2:] in names for w in wheels)
    dists = {Path(w).name.split("-")[0].lower() for w in wheels}
    assert {"vtcore", "scipy"} <= dists
    assert "numpy" not in dists and "bpy" not in dists  # Blender ships numpy
    # This lane's generation: its zip holds only wheels for this Python, and says which Blenders run it.
    py = f"cp{sys.version_info.major}{sys.version_info.minor}"
    assert all(w.split("-")[-3] in (py, "py3", "py2.py3") for w in wheels), wheels
    want = {"cp311": ("4.2.0", "5.1.0"), "cp313": ("5.1.0", None)}[py]
    assert (manifest["blender_version_min"], manifest.get("blender_version_max")) == want
    assert len(manifest["tagline"]) <= 64 and manifest["tagline"][-1].isalnum()


def test_install_into_fresh_profile(built_zip, scenes_dir, tmp_path):
    home = tmp_path / "home"
    home.mkdir()
    out = tmp_path / "summary.json"
    env = {**os.environ, "HOME": str(home), "VTCORE_PROGRESS": "0"}
    env.pop("PYTHONPATH", None)
    res = subprocess.run([sys.executable, str(HERE / "blender" / "install_check.py"), str(built_zip),
                          str(scenes_dir / "demo.toml"), str(out)], capture_output=True, text=True,
                         cwd=tmp_path, env=env, timeout=TIMEOUT)
    assert res.returncode == 0, res.stdout[-3000:] + res.stderr[-3000:]
    assert "INSTALL_CHECK_OK" in res.stdout
    summary = json.loads(out.read_text())
    assert summary["addon_enabled"] and summary["reload_ok"]
    assert summary["vtcore_file"].startswith(str(home))  # the bundled wheel, not the repo
    assert summary["taxels"] == 60
    assert summary["lay_patch"] == summary["simulate"] == summary["edges"] == ["FINISHED"]
    assert summary["edge_taxels"] > 0
