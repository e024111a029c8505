"""The package: importable without bpy, CLI basics, atomic and reproducible output."""

from __future__ import annotations

import subprocess
import sys
import zipfile

import numpy as np
import pytest

from vtcore._io import atomic_write, save_npz


def test_no_vtcore_module_imports_bpy(root):
    code = (
        "import importlib, pkgutil, sys, vtcore\n"
        "mods = [m.name for m in pkgutil.walk_packages(vtcore.__path__, 'vtcore.')]\n"
        "for m in mods:\n"
        "    if m != 'vtcore.__main__':\n"
        "        importlib.import_module(m)\n"
        "assert 'bpy' not in sys.modules, 'bpy was imported'\n"
        # open3d only inside functions: loaded before bpy it breaks bpy 5.2 (docs/blender.md)
        "assert 'open3d' not in sys.modules, 'open3d was imported'\n"
        "print(len(mods))\n"
    )
    res = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=root)
    assert res.returncode == 0, res.stderr
    assert int(res.stdout.strip()) > 10  # walked the real package tree


def test_import_vtcore_is_light(root):
    code = "import sys, vtcore, vtcore.layout, vtcore.scene; print(' '.join(sorted(m for m in ('open3d','bpy','can','cantools','potpourri3d','torch','skimage') if m in sys.modules)))"
    res = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=root)
    assert res.returncode == 0, res.stderr
    assert res.stdout.strip() == ""


def test_version_and_scenes(cli):
    res = cli("--version")
    assert res.returncode == 0 and res.stdout.startswith("vtcore ")
    res = cli("scenes")
    assert res.returncode == 0, res.stderr
    names = [line.split()[0] for line in res.stdout.splitlines()]
    assert "demo" in names
    assert len(names) == len(set(names))


def test_unknown_command_exits_2(cli):
    res = cli("frobnicate")
    assert res.returncode == 2


def test_atomic_write_keeps_old_content_on_failure(tmp_path):
    target = tmp_path / "x.txt"
    target.write_text("old")
    with pytest.raises(RuntimeError):
        with atomic_write(target) as fh:
            fh.write("half")
            raise RuntimeError("boom")
    assert target.read_text() == "old"
    assert [p.name for p in tmp_path.iterdir()] == ["x.txt"]


def test_save_npz_is_byte_reproducible_and_loadable(tmp_path):
    arrays = {"b": np.arange(5.0), "a": np.eye(3, dtype=np.float32)}
    save_npz(tmp_path / "1.npz", arrays)
    save_npz(tmp_path / "2.npz", dict(reversed(list(arrays.items()))))
    assert (tmp_path / "1.npz").read_bytes() == (tmp_path / "2.npz").read_bytes()
    with np.load(tmp_path / "1.npz") as z:
        assert z["a"].dtype == np.float32
        np.testing.assert_array_equal(z["b"], arrays["b"])
    with zipfile.ZipFile(tmp_path / "1.npz") as zf:
        assert all(i.date_time == (1980, 1, 1, 0, 0, 0) for i in zf.infolist())


def test_atomic_write_gives_ordinary_file_mode(tmp_path):
    import os

    with atomic_write(tmp_path / "y.txt") as fh:
        fh.write("x")
    mask = os.umask(0)
    os.umask(mask)
    assert (tmp_path / "y.txt").stat().st_mode & 0o777 == 0o666 & ~mask
