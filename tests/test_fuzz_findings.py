"""Regression tests of the inputs the long fuzz run (issue 13, ``--fuzz-long``) found.

Each test rebuilds the offending input from the fuzz seed and the mutation hypothesis
reported, and checks the fuzz contract on it: exit 2 with exactly one ``vtcore: error:``
line naming the file and key or line (no warning before it), or exit 0 with finite output.
"""

from __future__ import annotations

import contextlib
import io
import json
import re
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[1]
LAYOUTS = ROOT / "scenes" / "layouts"


def run(*argv) -> tuple[int, str, str]:
    from vtcore.cli import main

    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        rc = main([str(a) for a in argv])
    return rc, out.getvalue(), err.getvalue()


def one_error(rc, err, *names):
    assert rc == 2, err
    assert err.startswith("vtcore: error: ") and len(err.rstrip("\n").split("\n")) == 1, err
    assert "Warning" not in err and "warning" not in err
    for nm in names:  # (tmp_path holds the test's name: look after the file name too)
        assert nm in err and (nm == names[0] or nm in err.split(names[0])[-1]), err


@pytest.fixture(scope="module")
def seed_files(tmp_path_factory):
    """The fuzz seeds of tests/fuzz/test_fuzz_layout.py: the two iCub triangles in our JSON and PLY."""
    from vtcore.layout import load, save

    d = tmp_path_factory.mktemp("seeds")
    small = load(LAYOUTS / "icub_two_triangles.txt")
    save(small, d / "s.json", "json")
    save(small, d / "s.ply", "ply")
    return d


# --------------------------------------------------------------------- 1. non-finite transform, huge normal
def test_json_nan_transform_is_one_error(seed_files, tmp_path):
    """Found: ``"transform": [[NaN, ...`` got through the reader and failed at the writer (two lines)."""
    doc = json.loads((seed_files / "s.json").read_text())
    doc["transform"][0][0] = float("nan")
    src = tmp_path / "in.json"
    src.write_text(json.dumps(doc, indent=1))  # the token NaN, as the mutated file had
    rc, _, err = run("layout", "import", src, "--format", "json", "--out", tmp_path / "o.json")
    one_error(rc, err, f"{src}: transform: number 0 is nan")
    assert not (tmp_path / "o.json").exists()


def test_ply_nan_transform_comment_is_one_error(seed_files, tmp_path):
    text = (seed_files / "s.ply").read_text()
    src = tmp_path / "in.ply"
    src.write_text(text.replace("comment transform 1 ", "comment transform nan ", 1))
    rc, _, err = run("layout", "import", src, "--format", "ply", "--out", tmp_path / "o.json")
    one_error(rc, err, f"{src}:5: transform: 'nan' is not a finite number")


@pytest.mark.parametrize("fmt", ["json", "ply"])
def test_normal_of_1e308_is_a_direction(seed_files, tmp_path, fmt):
    """Found: a normal (0, 1e308, 1) has a norm that overflows to inf; dividing by it made a zero
    (then NaN) normal. It is a direction: read as the unit vector along it, with the usual warning."""
    from vtcore.layout import load

    src = tmp_path / f"in.{fmt}"
    if fmt == "json":
        doc = json.loads((seed_files / "s.json").read_text())
        doc["taxels"]["normals"][3] = [0.0, 1e308, 1.0]
        src.write_text(json.dumps(doc))
    else:
        lines = (seed_files / "s.ply").read_text().split("\n")
        k = lines.index("end_header") + 1 + 3
        tok = lines[k].split()
        tok[3:6] = ["0", "1e308", "1"]
        lines[k] = " ".join(tok)
        src.write_text("\n".join(lines))
    out = tmp_path / "o.json"
    rc, _, err = run("layout", "import", src, "--format", fmt, "--out", out)
    assert rc == 0, err
    assert "not unit length (norm above 1.8e308" not in err  # 1e308 * sqrt(1 + 1e-616) is finite
    assert "norm 1e+308-1e+308" in err, err
    back = load(out)
    assert np.isfinite(back.normals).all()
    np.testing.assert_allclose(back.normals[3], [0, 1, 0], atol=1e-12)
    np.testing.assert_allclose(np.linalg.norm(back.normals, axis=1), 1, atol=1e-12)


def test_normal_beyond_float_range_norm(tmp_path):
    """(1.5e308, 1.5e308, 1.5e308) has a norm above the largest float64; still a direction."""
    from vtcore.layout import load

    src = tmp_path / "a.csv"
    src.write_text("x,y,z,nx,ny,nz\n0,0,0,0,0,1\n0.01,0,0,1.5e308,1.5e308,1.5e308\n0,0.01,0,0,0,1\n")
    out = tmp_path / "o.json"
    rc, _, err = run("layout", "import", src, "--format", "csv", "--out", out)
    assert rc == 0, err
    assert "above 1.8e308" in err
    np.testing.assert_allclose(load(out).normals[1], np.full(3, 3 ** -0.5), atol=1e-15)


def test_binary_ply_nan_normal_is_one_error(tmp_path):
    """NaN is a valid float in a binary PLY; refused naming the property, not written out."""
    import struct

    head = ("ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty double x\nproperty double y\n"
            "property double z\nproperty double nx\nproperty double ny\nproperty double nz\nend_header\n").encode()
    rows = [(0, 0, 0, 0, 0, 1), (0.01, 0, 0, 0, float("nan"), 1), (0, 0.01, 0, 0, 0, 1)]
    src = tmp_path / "b.ply"
    src.write_bytes(head + b"".join(struct.pack("<6d", *r) for r in rows))
    rc, _, err = run("layout", "import", src, "--format", "ply", "--out", tmp_path / "o.json")
    one_error(rc, err, str(src), "vertex.ny", "vertex 1")


def test_json_nan_flat_is_one_error(seed_files, tmp_path):
    from vtcore.layout import load, save

    lay = load(seed_files / "s.json")
    lay.flat = np.zeros((len(lay), 2))
    save(lay, tmp_path / "f.json")
    doc = json.loads((tmp_path / "f.json").read_text())
    doc["taxels"]["flat"][2][1] = float("inf")
    src = tmp_path / "in.json"
    src.write_text(json.dumps(doc))  # writes the non-JSON token Infinity, as a mutated file would
    rc, _, err = run("layout", "import", src, "--format", "json", "--out", tmp_path / "o.json")
    one_error(rc, err, str(src), "taxels.flat", "row 2")


# --------------------------------------------------------------------- 2. CySkin tf_matrix with NaN
def test_cyskin_nan_tf_matrix_is_one_error(tmp_path):
    """Found: a NaN in ``tf_matrix`` gave the row-major warning, then a writer error (two lines)."""
    doc = json.loads((LAYOUTS / "seed001_hexagon.cyskin.json").read_text())
    tf = doc["skin"]["parent_frames"][0]["tf_matrix"]
    assert len(tf) == 16
    tf[7] = float("nan")
    src = tmp_path / "in.json"
    src.write_text(json.dumps(doc))
    rc, _, err = run("layout", "import", src, "--format", "cyskin", "--out", tmp_path / "o.json")
    one_error(rc, err, str(src), "skin.parent_frames[0].tf_matrix", "number 7")
    assert "row-major" not in err
    assert re.search(r"\bnan\b", err)
