"""Issue 28: what still crashed downstream of a reader that accepted a file, and scenes at the extremes.

Each test rebuilds one failure the issue lists (layout JSON fields the reader passed through and a
writer then choked on; ``layout info`` on extreme coordinates; scene values whose size reached numpy
or a solver unchecked; multi-line errors and raw Python warnings) and checks the contract of
docs/inputs.md: exit 2 with exactly one ``vtcore: error:`` line naming the file and key, or exit 0
with output its consumers read.
"""

from __future__ import annotations

import contextlib
import io
import json
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
SCENES = ROOT / "scenes"
LAYOUTS = SCENES / "layouts"


def run(*argv) -> tuple[int, str, str]:
    from helpers import wall_clock_limit
    from vtcore.cli import main

    out, err = io.StringIO(), io.StringIO()
    with wall_clock_limit(120), contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        rc = main([str(a) for a in argv])
    return rc, out.getvalue(), err.getvalue()


def one_error(rc, err, *needles):
    assert rc == 2, err
    assert err.startswith("vtcore: error: ") and len(err.rstrip("\n").split("\n")) == 1, err
    assert "Warning" not in err and "Traceback" not in err, err
    for n in needles:
        assert n in err, err


@pytest.fixture(scope="module")
def icub_json(tmp_path_factory):
    """The iCub two triangles as our JSON: the seed whose ``meta`` carries every iCub field."""
    from vtcore.layout import load, save

    d = tmp_path_factory.mktemp("seed")
    save(load(LAYOUTS / "icub_two_triangles.txt"), d / "icub.json", "json")
    return json.loads((d / "icub.json").read_text())


def _write(tmp_path, doc, name="in.json") -> Path:
    p = tmp_path / name
    p.write_text(json.dumps(doc, indent=1))
    return p


def _export(src, tmp_path, fmt):
    out = tmp_path / f"out.{fmt}"
    return run("layout", "export", src, "--format", fmt, "--out", out), out


# ----------------------------------------------------------------------------- layout JSON fields
@pytest.mark.parametrize("transform, reason", [
    ([[1e308, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]], "rigid"),
    ([[1e-320] * 4] * 4, "rigid"),
    ([[1, 0, 0, 5e3], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]], "translation"),
    ([[-1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]], "determinant"),
])
def test_json_transform_that_is_not_rigid_is_refused_by_the_reader(icub_json, tmp_path, transform, reason):
    """Found: a transform with an entry of 1e308 (or every entry 1e-320) was read, and the MJCF
    writer's quaternion (scipy's Rotation.from_matrix) raised ValueError."""
    doc = dict(icub_json, transform=transform)
    src = _write(tmp_path, doc)
    (rc, _, err), out = _export(src, tmp_path, "mjcf")
    one_error(rc, err, f"{src}: transform:", reason)
    assert not out.exists()


def test_json_frame_null_is_the_default_frame(icub_json, tmp_path):
    """Found: ``"frame": null`` was kept as None and the MJCF writer raised TypeError. null is
    JSON's "not given": the default frame, as for ``"transform": null``."""
    mujoco = pytest.importorskip("mujoco")
    src = _write(tmp_path, dict(icub_json, frame=None))
    (rc, _, err), out = _export(src, tmp_path, "mjcf")
    assert rc == 0, err
    model = mujoco.MjModel.from_xml_path(str(out))
    assert model.nsensor == 24


@pytest.mark.parametrize("frame, reason", [
    (5, "must be a string"),
    ("", "must not be empty"),
    ("link\x01one", "control character"),
    ("a" * 300, "at most"),
])
def test_json_frame_must_be_a_name_every_writer_can_write(icub_json, tmp_path, frame, reason):
    src = _write(tmp_path, dict(icub_json, frame=frame))
    (rc, _, err), _ = _export(src, tmp_path, "urdf")
    one_error(rc, err, f"{src}: frame:", reason)


@pytest.mark.parametrize("faces, reason", [
    ([[0, 1]], "shape"),
    ([[0, 1, -10 ** 30]], "must be in"),
    ([[0, 1, "2"]], "integers"),
    ([[0, 1, 2.5]], "integers"),
])
def test_json_meta_faces_are_checked_by_the_reader(icub_json, tmp_path, faces, reason):
    """Found: ``meta.faces`` with 2 indices (ValueError) or an index of -10**30 (OverflowError)
    reached io/common.py default_faces on PLY export."""
    doc = json.loads(json.dumps(icub_json))
    doc["meta"]["faces"] = faces
    src = _write(tmp_path, doc)
    (rc, _, err), out = _export(src, tmp_path, "ply")
    one_error(rc, err, f"{src}: meta.faces", reason)
    assert not out.exists()


def test_json_meta_faces_out_of_range_fall_back_to_the_skin_mesh(icub_json, tmp_path):
    """Faces naming taxels a layout no longer has (a subset keeps its meta) are not a reason to
    refuse the file: the writers use the skin mesh instead, as they always did."""
    from vtcore.layout import load

    doc = json.loads(json.dumps(icub_json))
    doc["meta"]["faces"] = [[0, 1, 99]]
    src = _write(tmp_path, doc)
    (rc, _, err), out = _export(src, tmp_path, "ply")
    assert rc == 0, err
    assert len(load(out)) == 24


@pytest.mark.parametrize("edit, key, reason", [
    (lambda m: m["taxel2Repr"].__setitem__(0, 10 ** 30), "meta.taxel2Repr", "must be in"),
    (lambda m: m["taxel2Repr"].__setitem__(0, "x"), "meta.taxel2Repr", "integers"),
    (lambda m: m["icub_row_text"].__setitem__(7, "0x1F 0 0 0 0 0"), "meta.icub_row_text[7]", "not a number"),
    (lambda m: m["icub_row_text"].__setitem__(7, "1 2 3"), "meta.icub_row_text[7]", "6 numbers"),
    (lambda m: m["icub_row_text"].__setitem__(7, "0 0 0 0 0 0\n[calibration]"), "meta.icub_row_text[7]",
     "line break"),
    (lambda m: m["icub_header_lines"].__setitem__(0, {"a": 1}), "meta.icub_header_lines[0]", "must be a string"),
    (lambda m: m["icub_header_lines"].__setitem__(0, "name a\nb"), "meta.icub_header_lines[0]", "line break"),
    (lambda m: m.__setitem__("icub_rows", 10 ** 12), "meta.icub_rows", "must be in"),
    (lambda m: m.__setitem__("icub_rows", 36), "meta.icub_rows", "icub_row_text has 24"),
    (lambda m: m.__setitem__("icub_units", "km"), "meta.icub_units", "must be one of"),
    (lambda m: m.__setitem__("name", ["x"]), "meta.name", "must be a string"),
])
def test_json_meta_icub_fields_are_checked_by_the_reader(icub_json, tmp_path, edit, key, reason):
    """Found: a huge ``meta.taxel2Repr`` value (OverflowError), a ``meta.icub_row_text`` row holding
    0x1F (ValueError) and a ``meta.icub_header_lines`` entry that is an object (AttributeError) in
    io/icub.py."""
    doc = json.loads(json.dumps(icub_json))
    edit(doc["meta"])
    src = _write(tmp_path, doc)
    (rc, _, err), out = _export(src, tmp_path, "icub")
    one_error(rc, err, f"{src}: {key}", reason)
    assert not out.exists()


@pytest.mark.parametrize("value", [2 ** 63 - 1, -(2 ** 63)])
def test_taxel2repr_at_the_ends_of_int64_round_trips(icub_json, tmp_path, value):
    """Found by the --fuzz-long export driver: ``meta.taxel2Repr`` of 2**63-1 (accepted: int64) was
    written, then the iCub reader parsed it through a float (2**63: OverflowError). A writer's
    output reads back with the same values."""
    from vtcore.layout import load

    doc = json.loads(json.dumps(icub_json))
    doc["meta"]["taxel2Repr"][0] = value
    (rc, _, err), out = _export(_write(tmp_path, doc), tmp_path, "icub")
    assert rc == 0, err
    assert load(out, "icub").meta["taxel2Repr"] == doc["meta"]["taxel2Repr"]


def test_icub_taxel2repr_past_int64_is_ignored_with_a_warning(tmp_path):
    from vtcore.layout import LayoutWarning, load

    src = tmp_path / "a.txt"
    src.write_text("name a\nspatial_sampling taxel\ntaxel2Repr ( 0 99999999999999999999 )\n\n[calibration]\n"
                   "0 0 0 0 0 1\n0.005 0 0 0 0 1\n")
    with pytest.warns(LayoutWarning, match="not 64-bit integers"):
        lay = load(src)
    assert lay.meta["taxel2Repr"] == [0] and len(lay) == 2


# ----------------------------------------------------------------------------- layout info
@pytest.mark.parametrize("value", [1e308, "1e308", 5e3])
def test_info_flat_coordinate_far_out_is_one_error(icub_json, tmp_path, value):
    """Found: one flat coordinate of 1e308 (a number or a string) overflowed cKDTree.query_pairs in
    ``layout info``."""
    doc = json.loads(json.dumps(icub_json))
    doc["taxels"]["flat"] = [[0.001 * k, 0.0] for k in range(24)]
    doc["taxels"]["flat"][3][0] = value
    src = _write(tmp_path, doc)
    rc, _, err = run("layout", "info", src)
    one_error(rc, err, f"{src}: taxels.flat")


@pytest.mark.parametrize("value, reason", [(1e308, "positions: must be within +-1000 m, got 1e+308 m"),
                                           ("1e308", "taxels.positions: must be numbers")])
def test_info_position_far_out_is_one_error(icub_json, tmp_path, value, reason):
    """A taxel position of 1e308 (a number or a string) in ``layout info`` and ``--json``: one error
    naming the key once (it said "positions: positions must be ...")."""
    doc = json.loads(json.dumps(icub_json))
    doc["taxels"]["positions"][0][0] = value
    src = _write(tmp_path, doc)
    for extra in ([], ["--json"]):
        rc, _, err = run("layout", "info", src, *extra)
        one_error(rc, err, f"{src}: {reason}")


@pytest.mark.parametrize("roles, reason", [
    ([[1]] + ["pressure"] * 23, "must be a string"),
    (["pressure"] * 23, "24"),
    (["a,b"] + ["pressure"] * 23, "letters"),
])
def test_info_roles_must_be_names(icub_json, tmp_path, roles, reason):
    """Found: a ``roles`` entry ``[1]`` instead of a string raised ValueError in ``layout info``."""
    doc = json.loads(json.dumps(icub_json))
    doc["taxels"]["roles"] = roles
    src = _write(tmp_path, doc)
    rc, _, err = run("layout", "info", src)
    one_error(rc, err, f"{src}: taxels.roles", reason)


@pytest.mark.parametrize("placement", [
    {"off_boundary": 3, "coverage": "x", "strain_max": "big"},
    {"coverage": 1e308, "strain_max": [1], "strain_mean": {"a": 1}},
])
def test_info_reads_only_the_placement_numbers_it_understands(icub_json, tmp_path, placement):
    """A placement report from an older or edited file: ``layout info`` shows what it can read."""
    doc = json.loads(json.dumps(icub_json))
    doc["meta"]["placement"] = placement
    src = _write(tmp_path, doc)
    rc, out, err = run("layout", "info", src, "--json")
    assert rc == 0, err
    info = json.loads(out)
    assert info["taxels"] == 24


def test_info_pitch_from_the_file_cannot_ask_for_every_pair(icub_json, tmp_path):
    """``meta.pitch_m`` sizes the overlap search: a pitch of 1e308 (or a kilometre) would pair every
    taxel with every other."""
    doc = json.loads(json.dumps(icub_json))
    doc["meta"]["pitch_m"] = 1e308
    src = _write(tmp_path, doc)
    rc, _, err = run("layout", "info", src)
    one_error(rc, err, f"{src}: meta.pitch_m")


def test_ply_ids_past_32_bits_are_written_as_what_they_are(icub_json, tmp_path):
    """The PLY writer declared every id ``int`` (32 bits) and wrote 2**40 under it: a consumer that
    believes the header reads garbage. Ids past 32 bits are declared ``double`` (exact to 2**53);
    past 2**53 the export is one error naming the key."""
    import trimesh

    from vtcore.layout import load

    doc = json.loads(json.dumps(icub_json))
    doc["taxels"]["taxel_ids"] = [2 ** 40 + k for k in range(24)]
    src = _write(tmp_path, doc)
    (rc, _, err), out = _export(src, tmp_path, "ply")
    assert rc == 0, err
    assert "property double taxel_id" in out.read_text()
    assert load(out).taxel_ids.tolist() == doc["taxels"]["taxel_ids"]
    raw = trimesh.load(out).metadata["_ply_raw"]["vertex"]["data"]["taxel_id"].ravel()
    assert raw.astype("int64").tolist() == doc["taxels"]["taxel_ids"]
    doc["taxels"]["taxel_ids"][0] = 2 ** 60
    src = _write(tmp_path, doc)
    (rc, _, err), out = _export(src, tmp_path, "ply")
    one_error(rc, err, "taxel_ids: holds 1152921504606846976")
