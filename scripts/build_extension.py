"""Build the Blender extension zip into ``dist/`` and validate it (``make extension``).

Steps:
1. stage ``addon/*`` and ``blender_manifest.toml`` into ``build/extension/``;
2. build the ``vtcore`` wheel from this repository (``pip wheel --no-deps``) and
   download the wheels of the dependencies the add-on's code paths import that
   Blender does not ship (Blender ships numpy, requests, zstandard, Cython);
   versions come from the generation's lock (``requirements.lock`` for Python 3.11,
   ``requirements-py313.lock`` for 3.13); binary wheels for each platform
   requested (default: this machine's), cached in ``build/wheelcache``;
3. write the ``wheels`` (and ``platforms``) lists and the generation's Blender range
   (``blender_version_min``/``max``) into the STAGED manifest;
4. check the bundle is complete: import every vtcore module the add-on uses in an
   isolated interpreter that sees only the bundled wheels and numpy (as Blender
   would), and run a scene with it;
5. ``blender_ext.py build`` then ``blender_ext.py validate`` (Blender's own tool,
   taken from the installed ``bpy`` wheel, or ``--blender BLENDER`` to use
   ``blender --command extension ...``).

Usage::

    python scripts/build_extension.py [--platforms linux-x64 windows-x64 ...] [--python 3.11]

Blender generations: 4.2 LTS .. 5.0 run Python 3.11 with numpy < 2; 5.1 and
5.2 LTS run Python 3.13 with numpy 2. One zip holds one Python version's
wheels (``GENERATIONS``). Run this script with that generation's interpreter
(``make extension`` runs it with ``.venv`` and ``.venv313``): the bundle check
runs in the running interpreter and the zip is validated with the running
interpreter's ``bpy`` tool. ``--python`` for another version skips the check
with a warning.
"""

from __future__ import annotations

import argparse
import os
import re
import shutil
import subprocess
import sys
import tempfile
import zipfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
STAGE = ROOT / "build" / "extension"  # --build-dir moves STAGE and CACHE (tests use a tmp dir)
CACHE = ROOT / "build" / "wheelcache"
DIST = ROOT / "dist"

#: What the add-on imports that Blender does not ship, and why (scikit-learn is not
#: here: the add-on's augment path, cluster/smooth propagation, uses scipy's KD-tree only;
#: the isolated check in step 4 proves it). Only these are
#: bundled (plus their own dependencies listed here); ``numpy`` comes with Blender.
BUNDLE = {
    "scipy": "vtcore.layout (sparse skin mesh, Delaunay), vtcore.contact (solvers), filters",
    "tqdm": "vtcore._progress (scene runs)",
    "threadpoolctl": "vtcore.scene.runner: one BLAS thread per scene run (the same bytes on any machine)",
    "potpourri3d": "vtcore.layout log-map placement (heat-method log map): Lay Patch, Fill, Move",
    "trimesh": "vtcore.contact objects and proximity, vtcore.layout placement on meshes",
    "pycollada": "Import Robot: COLLADA (.dae) link meshes through trimesh (the UR and Panda visual meshes); pure "
                 "Python, on the standard library's ElementTree without lxml",
    # Only two operators need it: Run Scene ([output] plots = true) and Augment Point Cloud.
    "matplotlib": "Run Scene: PNG plots (vtcore.plots); Augment Point Cloud: vtcore.augment.colour_map's colormap",
    "contourpy": "dependency of matplotlib",
    "cycler": "dependency of matplotlib",
    "fonttools": "dependency of matplotlib",
    "kiwisolver": "dependency of matplotlib",
    "packaging": "dependency of matplotlib",
    "pillow": "dependency of matplotlib",
    "pyparsing": "dependency of matplotlib",
    "python-dateutil": "dependency of matplotlib",
    "six": "dependency of python-dateutil (when it needs it)",
}

#: Blender platform name -> pip --platform tags (newest first is not needed: pip
#: accepts any listed tag; older glibc/macOS baselines cover newer systems).
PLATFORMS = {
    "linux-x64": ["manylinux2014_x86_64", "manylinux_2_17_x86_64", "manylinux_2_28_x86_64"],
    "windows-x64": ["win_amd64"],
    "macos-arm64": ["macosx_11_0_arm64", "macosx_12_0_arm64", "macosx_14_0_arm64"],
    "macos-x64": ["macosx_10_13_x86_64", "macosx_10_14_x86_64", "macosx_11_0_x86_64"],
}

#: The vtcore modules the add-on's operators reach (checked importable in step 4).
ADDON_MODULES = ["vtcore", "vtcore.layout", "vtcore.contact", "vtcore.robot", "vtcore.scene",
                 "vtcore.scene.interactive", "collada"]
OPTIONAL_MODULES = ["vtcore.filters", "vtcore.augment"]  # checked when present in the repo

#: Python version -> (lock file, blender_version_min, blender_version_max or None). Blender's
#: maximum is exclusive; 5.1 is the first release on Python 3.13.
GENERATIONS = {
    "3.11": ("requirements.lock", "4.2.0", "5.1.0"),
    "3.13": ("requirements-py313.lock", "5.1.0", None),
}

TOOL_REL = Path("bpy") / "{ver}" / "scripts" / "addons_core" / "bl_pkg" / "cli" / "blender_ext.py"


def log(msg):
    print(f"[build_extension] {msg}", flush=True)


def this_platform() -> str:
    import platform

    m = platform.machine().lower()
    if sys.platform.startswith("linux") and m in ("x86_64", "amd64"):
        return "linux-x64"
    if sys.platform == "win32":
        return "windows-x64"
    if sys.platform == "darwin":
        return "macos-arm64" if m == "arm64" else "macos-x64"
    raise SystemExit(f"unsupported build platform {sys.platform}/{m}; pass --platforms")


def pinned(python: str) -> dict[str, str]:
    pins = {}
    for line in (ROOT / GENERATIONS[python][0]).read_text().splitlines():
        if "==" in line and not line.startswith("#"):
            name, ver = line.strip().split("==", 1)
            pins[canon(name)] = ver
    return pins


def canon(name: str) -> str:
    return re.sub(r"[-_.]+", "-", name).lower()


def find_tool() -> Path:
    import importlib.util

    spec = importlib.util.find_spec("bpy")
    if spec is None or spec.origin is None:
        raise SystemExit("bpy is not installed in this Python; pass --blender /path/to/blender")
    base = Path(spec.origin).parent
    for ver in sorted(p.name for p in base.iterdir() if re.fullmatch(r"\d+\.\d+", p.name)):
        tool = base.parent / TOOL_REL.as_posix().format(ver=ver)
        if tool.is_file():
            return tool
    raise SystemExit(f"Blender's extension tool not found under {base}")


def run(cmd, **kw):
    log("$ " + " ".join(str(c) for c in cmd))
    return subprocess.run([str(c) for c in cmd], check=True, **kw)


def stage_sources():
    if STAGE.exists():
        shutil.rmtree(STAGE)
    STAGE.mkdir(parents=True)
    for src in sorted((ROOT / "addon").rglob("*")):
        if "__pycache__" in src.parts or src.suffix == ".pyc" or src.is_dir():
            continue
        dst = STAGE / src.relative_to(ROOT / "addon")
        dst.parent.mkdir(parents=True, exist_ok=True)
        shutil.copy2(src, dst)
    for extra in ("blender_manifest.toml",):
        shutil.copy2(ROOT / extra, STAGE / extra)
    lic = ROOT / "LICENSE"
    if lic.is_file():
        shutil.copy2(lic, STAGE / "LICENSE")


def build_wheels(platforms: list[str], python: str) -> list[Path]:
    wheels_dir = STAGE / "wheels"
    wheels_dir.mkdir()
    CACHE.mkdir(parents=True, exist_ok=True)
    # vtcore itself, from this checkout (pure Python: py3-none-any).
    with tempfile.TemporaryDirectory() as tmp:
        # Build from a copy: setuptools writes build/lib, build/bdist.* and *.egg-info next to
        # the sources it builds, and the checkout should stay as it is.
        src = Path(tmp) / "src"
        shutil.copytree(ROOT / "vtcore", src / "vtcore",
                        ignore=shutil.ignore_patterns("__pycache__", "*.pyc"))
        for name in ("pyproject.toml", "README.md", "LICENSE"):
            if (ROOT / name).is_file():
                shutil.copy2(ROOT / name, src / name)
        run([sys.executable, "-m", "pip", "wheel", "--no-deps", "--no-build-isolation", "-q",
             "-w", tmp, src])
        for whl in Path(tmp).glob("vtcore-*.whl"):
            shutil.copy2(whl, wheels_dir / whl.name)
    pins = pinned(python)
    reqs = []
    for name in BUNDLE:
        ver = pins.get(canon(name))
        if ver is None:
            if name == "six":
                continue  # not pinned: the pinned python-dateutil does not need it
            raise SystemExit(f"{name} is not pinned in {GENERATIONS[python][0]}")
        reqs.append(f"{name}=={ver}")
    pyver = python.replace(".", "")
    for plat in platforms:
        dest = CACHE / f"cp{pyver}-{plat}"
        dest.mkdir(exist_ok=True)
        cmd = [sys.executable, "-m", "pip", "download", "-q", "--no-deps", "--only-binary=:all:",
               "--python-version", python, "--implementation", "cp", "--abi", f"cp{pyver}",
               "--abi", "abi3", "--abi", "none", "-d", dest]
        for tag in PLATFORMS[plat]:
            cmd += ["--platform", tag]
        run(cmd + reqs, env={**os.environ, "PIP_FIND_LINKS": ""})
        for whl in dest.glob("*.whl"):
            if canon(whl.name.split("-")[0]) in {canon(r.split("==")[0]) for r in reqs}:
                shutil.copy2(whl, wheels_dir / whl.name)
    return sorted(wheels_dir.glob("*.whl"))


def write_manifest(wheels: list[Path], platforms: list[str], python: str):
    path = STAGE / "blender_manifest.toml"
    text = path.read_text()
    _, vmin, vmax = GENERATIONS[python]
    # This zip's wheels serve one Python: Blender outside the range refuses it by version
    # instead of failing on the wheels.
    text, n = re.subn(r'(?m)^blender_version_min = ".*"$', f'blender_version_min = "{vmin}"', text)
    if n != 1:
        raise SystemExit("blender_manifest.toml: expected one blender_version_min line")
    if vmax is not None:
        text = text.replace(f'blender_version_min = "{vmin}"',
                            f'blender_version_min = "{vmin}"\nblender_version_max = "{vmax}"')
    listing = "wheels = [\n" + "".join(f'  "./wheels/{w.name}",\n' for w in wheels) + "]\n"
    plats = "platforms = [" + ", ".join(f'"{p}"' for p in platforms) + "]\n"
    # Top-level keys must come before the first [table].
    head, sep, tail = text.partition("\n[")
    path.write_text(head.rstrip("\n") + "\n\n" + plats + listing + sep + tail)


def check_bundle(wheels: list[Path], python: str):
    """Import the add-on's vtcore modules and run the demo scene with ONLY the bundled
    wheels and numpy on sys.path, like Blender's Python with the extension installed."""
    if python != f"{sys.version_info.major}.{sys.version_info.minor}":
        log(f"WARNING: cannot check a Python {python} bundle from Python "
            f"{sys.version_info.major}.{sys.version_info.minor}; skipped")
        return
    import numpy

    with tempfile.TemporaryDirectory() as tmp:
        site = Path(tmp) / "site"
        for whl in wheels:
            if platform_ok(whl.name):
                with zipfile.ZipFile(whl) as zf:
                    zf.extractall(site)
        npdir = Path(numpy.__file__).parent
        os.symlink(npdir, site / "numpy")
        libs = npdir.parent / "numpy.libs"
        if libs.is_dir():
            os.symlink(libs, site / "numpy.libs")
        mods = ADDON_MODULES + [m for m in OPTIONAL_MODULES
                                if (ROOT / m.replace(".", "/") / "__init__.py").is_file()]
        code = (
            "import sys, importlib\n"
            f"sys.path[:] = [{str(site)!r}] + [p for p in sys.path if 'site-packages' not in p and p]\n"
            f"for m in {mods!r}: importlib.import_module(m)\n"
            "import vtcore\n"
            f"assert vtcore.__file__.startswith({str(site)!r}), vtcore.__file__\n"
            "from vtcore.scene.interactive import run_scene_file\n"
            f"r = run_scene_file({str(ROOT / 'scenes' / 'demo.toml')!r}, {str(Path(tmp) / 'out')!r})\n"
            "import trimesh\n"
            "from vtcore.scene.interactive import lay_patch\n"
            "ball = trimesh.creation.icosphere(subdivisions=5, radius=0.06)\n"
            "e = lay_patch(ball.vertices, ball.faces, [0, 0, 0.06])\n"
            "assert len(e.layout) == 60, len(e.layout)\n"
            "from vtcore.contact import make_object, placement_pose\n"
            "from vtcore.scene.interactive import augment, simulate\n"
            "s = make_object('sphere', radius=0.015)\n"
            "pose = placement_pose(s, xy=[0.0, 0.0], top=0.063, gap=0.001)\n"
            "c = simulate(e.layout, e.triangles, s.vertices, s.faces, pose, thickness=0.003, force=1.0)\n"
            "assert abs(c.force - 1.0) < 1e-3 and c.edge.any(), (c.force, c.edge.sum())\n"
            "v, rgb = augment(e.layout.positions, e.layout.positions[:5], [1.0, 2, 3, 4, 5])\n"
            + (f"from vtcore.scene.interactive import import_robot\n"
               f"rob = import_robot({str(_ur10())!r})\n"  # Import Robot: the UR10's COLLADA visual meshes
               "assert sum(len(p.faces) for p in rob.links) > 100_000, [p.note for p in rob.links]\n"
               if _ur10() else "")
            + 
            "print('bundle ok:', len(r.layout), 'taxels,', sorted(sys.modules.keys() & "
            "{'scipy', 'trimesh', 'sklearn', 'matplotlib', 'tqdm'}))\n")
        env = {k: v for k, v in os.environ.items() if not k.startswith("PYTHON")}
        run([sys.executable, "-I", "-S", "-c", code], cwd=tmp, env=env)


def _ur10():
    """The UR10's URDF of example-robot-data, where the building interpreter has it (the bundle check
    then imports it as Import Robot does: COLLADA visual meshes through the bundled pycollada)."""
    try:
        sys.path.insert(0, str(ROOT))
        from vtcore.robot.samples import example_robot_data

        p = example_robot_data() / "ur_description" / "urdf" / "ur10_robot.urdf"
        return p if p.is_file() else None
    except Exception:  # noqa: BLE001  (not installed: the check runs without it)
        return None
    finally:
        sys.path.remove(str(ROOT))


def platform_ok(name: str) -> bool:
    tag = name[:-4].split("-")[-1]
    if tag == "any":
        return True
    plat = this_platform()
    return any(t in tag for t in PLATFORMS[plat]) or (plat == "linux-x64" and "x86_64" in tag and "linux" in tag)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--platforms", nargs="+", choices=sorted(PLATFORMS),
                    help="Blender platforms to bundle wheels for (default: this machine's)")
    ap.add_argument("--python", default=f"{sys.version_info.major}.{sys.version_info.minor}",
                    help="Python of the target Blender generation: 3.11 (4.2-5.0) or 3.13 (5.1+)")
    ap.add_argument("--blender", help="a blender executable to build/validate with instead of the bpy wheel's tool")
    ap.add_argument("--skip-check", action="store_true", help="skip the isolated bundle check")
    ap.add_argument("--dist", default=str(DIST), help="output folder of the zip (default: dist/)")
    ap.add_argument("--build-dir", default=str(ROOT / "build"),
                    help="staging folder and wheel download cache (default: build/)")
    args = ap.parse_args(argv)
    global STAGE, CACHE
    STAGE, CACHE = Path(args.build_dir) / "extension", Path(args.build_dir) / "wheelcache"
    platforms = args.platforms or [this_platform()]

    stage_sources()
    if args.python not in GENERATIONS:
        raise SystemExit(f"--python {args.python}: no Blender generation runs it (known: {', '.join(GENERATIONS)})")
    wheels = build_wheels(platforms, args.python)
    write_manifest(wheels, platforms, args.python)
    log(f"staged {len(wheels)} wheels for {', '.join(platforms)} (Python {args.python})")
    if not args.skip_check:
        check_bundle(wheels, args.python)

    dist = Path(args.dist)
    dist.mkdir(parents=True, exist_ok=True)
    if args.blender:
        base = [args.blender, "--factory-startup", "--command", "extension"]
    else:
        base = [sys.executable, find_tool()]
    import tomllib

    man = tomllib.loads((STAGE / "blender_manifest.toml").read_text())
    suffix = "" if len(platforms) > 1 or args.platforms is None else "-" + "-".join(platforms)
    zip_path = dist / f"{man['id']}-{man['version']}-py{args.python.replace('.', '')}{suffix}.zip"
    if zip_path.exists():
        zip_path.unlink()
    run(base + ["build", "--source-dir", STAGE, "--output-filepath", zip_path])
    run(base + ["validate", zip_path])
    log(f"built and validated {zip_path} ({zip_path.stat().st_size / 1e6:.1f} MB)")
    return zip_path


if __name__ == "__main__":
    main()
