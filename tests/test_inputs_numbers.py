"""Issue 13: every numeric command-line option, and every mesh entering vtcore, given nasty numbers.

Each option is run through ``vtcore.cli.main`` in-process with 0, -1, nan, inf, 1e300 and 1e-300
(RuntimeWarnings are errors): the run must end in exit 0 with a finite, re-readable output, or in
exit 2 with one ``vtcore: error:`` line naming the option, and no output file.
"""

from __future__ import annotations

import re
import warnings

import numpy as np
import pytest
import trimesh

from test_inputs import LAYOUT, cli, one_error_line
from vtcore.errors import InputError
from vtcore.layout import load
from vtcore.layout.meshinput import SURFACE_SIZE_M, checked_mesh, load_mesh

NASTY = ["0", "-1", "nan", "inf", "1e300", "1e-300"]
BOX = (0.06, 0.06, 0.02)  # metres: a 12-triangle box, the cheapest surface a module is placed on


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    d = tmp_path_factory.mktemp("numbers")
    trimesh.creation.box(BOX).export(d / "box.stl")
    np.savez(d / "f.npz", timestamps=np.arange(3) * 0.05, frames=np.full((3, 2), 10.0), taxel_ids=np.array([17, 18]))
    rc, _, err = cli("can", "encode", d / "f.npz", "--codec", "icub", "--out", d / "x.log")
    assert rc == 0, err
    return d


def _place(d, *extra, at=("0", "0", "0.01"), patch="triangle"):
    return ["layout", "place", d / "box.stl", "--at", *at, "--patch", patch, "--out", d / "o.json", *extra]


# option -> (argv for the value v, output file written on success, the values that must be refused);
# a refusal names the option (NAMES: or what else it names)
OPTIONS = {
    "--scale": (lambda d, v: _place(d, "--scale", v), "o.json", set(NASTY)),
    "--offset": (lambda d, v: _place(d, "--offset", v), "o.json", {"-1", "nan", "inf", "1e300"}),
    "--subdivide": (lambda d, v: _place(d, "--subdivide", v), "o.json", set(NASTY)),
    # -1: a metre off a 60 mm box, refused as a placement nobody meant (issue 26)
    "--at": (lambda d, v: _place(d, at=(v, "0", "0.01")), "o.json", {"nan", "inf", "1e300", "-1"}),
    "--direction": (lambda d, v: _place(d, "--direction", v, v, "0"), "o.json", {"0", "nan", "inf"}),
    "--radius": (lambda d, v: _place(d, "--radius", v, patch="fill"), "o.json", {"0", "-1", "nan", "inf", "1e-300"}),
    "--site-radius": (lambda d, v: ["layout", "export", LAYOUT, "--format", "mjcf", "--out", d / "o.xml",
                                    "--site-radius", v], "o.xml", set(NASTY)),
    "--pad-thickness": (lambda d, v: ["layout", "export", LAYOUT, "--format", "mjcf", "--out", d / "o.xml",
                                      "--pad-thickness", v], "o.xml", set(NASTY)),
    "--transform": (lambda d, v: ["layout", "export", LAYOUT, "--format", "json", "--out", d / "t.json",
                                  "--transform", *f"{v} 0 0 0 0 1 0 0 0 0 1 0 0 0 0 1".split()],
                    "t.json", set(NASTY)),
    "--transform(t)": (lambda d, v: ["layout", "export", LAYOUT, "--format", "json", "--out", d / "t.json",
                                     "--transform", *f"1 0 0 {v} 0 1 0 0 0 0 1 0 0 0 0 1".split()],
                       "t.json", {"nan", "inf", "1e300"}),
    "--period": (lambda d, v: ["can", "decode", d / "x.log", "--codec", "icub", "--out", d / "d.npz",
                               "--period", v], "d.npz", set(NASTY)),
    "--window": (lambda d, v: ["can", "decode", d / "x.log", "--codec", "icub", "--out", d / "d.npz",
                               "--window", v], "d.npz", set(NASTY)),
    "--speed": (lambda d, v: ["can", "replay", d / "x.log", "--speed", v], None, {"-1", "nan", "1e-300"}),
    "--workers": (lambda d, v: ["sweep", LAYOUT, "--out", d / "sw", "--workers", v], None, set(NASTY)),
    "--retries": (lambda d, v: ["sweep", LAYOUT, "--out", d / "sw", "--retries", v], None,
                  set(NASTY) - {"0"}),
}


NAMES = {"--at": "--at|'at' is [0-9.]+ mm off the surface", "--radius": "--radius|region: (no whole .*module fits|the widest part)", "--transform": "transform", "--transform(t)": "transform"}


def _finite(path):
    if path.suffix == ".npz":
        with np.load(path) as z:
            return all(np.isfinite(z[k]).all() for k in z.files if z[k].dtype.kind == "f" and k != "frames")
    if path.suffix == ".json":
        lay = load(path)
        return np.isfinite(lay.positions).all() and np.isfinite(lay.normals).all()
    return not re.search(r"\b(nan|inf|infinity)\b", path.read_text(encoding="utf-8"), re.I)


@pytest.mark.parametrize("option", sorted(OPTIONS))
def test_numeric_options_finite_or_one_error_line(files, option):
    argv, out_name, refused = OPTIONS[option]
    for v in NASTY:
        out = files / out_name if out_name else None
        if out is not None and out.exists():
            out.unlink()
        with warnings.catch_warnings():
            warnings.simplefilter("error", RuntimeWarning)
            rc, _, err = cli(*argv(files, v))
        assert "Traceback" not in err and "encountered" not in err, (v, err)
        if v in refused:
            one_error_line(rc, err)
            assert re.search(NAMES.get(option, option), err), (v, err)
            assert out is None or not out.exists(), v
        elif option in ("--workers", "--retries"):
            # the number passed its check; the run stops at the next one (a layout file is no scene)
            one_error_line(rc, err)
            assert option not in err, (v, err)
        else:
            assert rc == 0, (v, err)
            assert out is None or _finite(out), v


def test_scale_errors_state_the_accepted_range(files):
    rc, _, err = cli(*_place(files, "--scale", "1e-6"))
    one_error_line(rc, err, "box.stl: the mesh is 6e-08 m across", "accepted sizes are 0.001 m .. 100 m",
                   "check --scale")
    rc, _, err = cli(*_place(files, "--scale", "-1"))
    one_error_line(rc, err, "--scale: must be a finite number > 0", "mirror")


def test_nan_and_huge_vertices_are_refused_before_any_computation(tmp_path):
    """--scale nan printed numpy's det RuntimeWarning before the error; a file with NaN or 1e308
    vertices made trimesh's vertex merge overflow. The vertices are checked before anything."""
    (tmp_path / "nan.obj").write_text("v 0 0 0\nv nan 0 0\nv 0 1 0\nf 1 2 3\n")
    (tmp_path / "big.obj").write_text("v 0 0 0\nv 1e308 0 0\nv -1e308 1 0\nf 1 2 3\n")
    (tmp_path / "far.obj").write_text("v 5000 0 0\nv 5000.1 0 0\nv 5000 0.1 0\nf 1 2 3\n")
    (tmp_path / "idx.obj").write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")
    cases = [("nan.obj", "1", "non-finite vertices (vertex 1"), ("big.obj", "1", "inf m across"),
             ("far.obj", "1", "vertex coordinates reach 5e+03 m"), ("idx.obj", "nan", "--scale: must be a finite")]
    for name, scale, needle in cases:
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            rc, _, err = cli("layout", "place", tmp_path / name, "--scale", scale, "--at", "0", "0", "0",
                             "--out", tmp_path / "o.json")
        one_error_line(rc, err, needle)
        assert not (tmp_path / "o.json").exists()


def test_the_size_range_edges():
    tri = np.array([[0, 1, 2]])
    lo, hi = SURFACE_SIZE_M
    for size in (lo, hi):
        m = checked_mesh(np.array([[0, 0, 0], [size, 0, 0], [0, size / 2, 0]]), tri)
        assert np.ptp(m.vertices, axis=0).max() == pytest.approx(size)
    for size in (lo * 0.999, hi * 1.001):
        with pytest.raises(InputError, match="accepted sizes are 0.001 m .. 100 m"):
            checked_mesh(np.array([[0, 0, 0], [size, 0, 0], [0, size / 2, 0]]), tri)
    with pytest.raises(InputError, match="faces: must be in 0..2"):
        checked_mesh(np.eye(3), np.array([[0, 1, 3]]))
    # millimetres: a 60 mm box given in mm with scale 0.001 is the metre box
    m = checked_mesh(np.array([[0, 0, 0], [60, 0, 0], [0, 60, 0]]), tri, 0.001)
    assert np.ptp(m.vertices, axis=0).max() == pytest.approx(0.06)


def test_a_placement_at_the_lower_size_edge_is_finite(files):
    s = SURFACE_SIZE_M[0] / max(BOX)  # the box scaled to exactly 1 mm across
    with warnings.catch_warnings():
        warnings.simplefilter("error", RuntimeWarning)
        # a 22 mm module on a 1 mm part: refused (its taxels fall off, issue 26), then forced
        rc, _, err = cli(*_place(files, "--scale", repr(s), at=("0", "0", repr(0.01 * s))))
        one_error_line(rc, err, "taxels fall off the surface")
        rc, _, err = cli(*_place(files, "--scale", repr(s), "--force", at=("0", "0", repr(0.01 * s))))
    assert rc == 0 and "encountered" not in err, err
    assert _finite(files / "o.json")


def test_scene_meshes_take_the_same_checks(tmp_path, files):
    from vtcore.scene import load_scene
    from vtcore.scene.sections.layout import build_end_effector
    from vtcore.scene.sections.objects import object_mesh

    (tmp_path / "s.toml").write_text(
        f'[scene]\ntask = "press"\n[end_effector]\nshape = "mesh"\nmesh = "{files / "box.stl"}"\nscale = 1e4\n'
        f'[[objects]]\nkind = "mesh"\nmesh = "{files / "box.stl"}"\nscale = 1e-300\n', encoding="utf-8")
    scene = load_scene(tmp_path / "s.toml")
    with pytest.raises(InputError, match=r"end_effector\.mesh: .*600 m across.*check end_effector\.scale"):
        build_end_effector(scene)
    with pytest.raises(InputError, match=r"objects\[0\]\.mesh: .*accepted sizes are 1e-06 m .. 1000 m"):
        object_mesh(scene, 0)
    assert load_mesh(files / "box.stl").is_watertight  # the default: metres, merged vertices


def test_the_addon_path_checks_its_meshes():
    from vtcore.scene import interactive

    box = trimesh.creation.box(BOX)
    with pytest.raises(InputError, match="mesh: the mesh is 6e-08 m across"):
        interactive.lay_patch(box.vertices * 1e-6, box.faces, (0, 0, 1e-8))
    with pytest.raises(InputError, match="non-finite"):
        interactive.lay_patch(np.full((8, 3), np.nan), box.faces, (0, 0, 0))


def test_argparse_errors_are_one_line(files):
    rc, _, err = cli(*_place(files, patch="strip:100000"))  # was a MemoryError in the overlap check
    one_error_line(rc, err, "argument --patch: a strip of 100000 modules is longer than the 1000 accepted")
    rc, _, err = cli("can", "decode", "x.log", "--codec", "icub", "--out", "y.npz", "--window", "nan")
    one_error_line(rc, err, "vtcore can decode: argument --window: invalid int value: 'nan'")
    rc, _, err = cli("can", "decode", files / "x.log", "--codec", "icub", "--out", files / "d.npz",
                     "--layout", LAYOUT.parent / "icub_two_triangles.txt", "--boards", str(2 ** 70))
    one_error_line(rc, err, "argument --boards: board addresses are 4 bits (0..15)")  # was an OverflowError
    rc, out, _ = cli("--version")
    assert rc == 0 and out.startswith("vtcore ")
    rc, _, err = cli("run", "--set")
    one_error_line(rc, err, "expected one argument")
