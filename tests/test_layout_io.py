"""Layout files: round trips, lenient readers, errors with line numbers, units."""

import json
import warnings
import xml.etree.ElementTree as ET

import numpy as np
import pytest

from vtcore.errors import FormatError, InputError
from vtcore.layout import Layout, LayoutWarning, load, make_patch, save, seed002_curved
from vtcore.layout.io.cyskin import write as write_cyskin

FORMATS = [("json", "json"), ("icub", "txt"), ("cyskin", "json"), ("csv", "csv"), ("ply", "ply")]


@pytest.fixture(scope="module")
def curved():
    return seed002_curved()[1]


def same(a: Layout, b: Layout, ids=True, atol=1e-12):
    np.testing.assert_allclose(a.positions, b.positions, atol=atol, rtol=0)
    np.testing.assert_allclose(a.normals, b.normals, atol=atol, rtol=0)
    if ids:
        np.testing.assert_array_equal(a.taxel_ids, b.taxel_ids)
        np.testing.assert_array_equal(a.module_ids, b.module_ids)
    np.testing.assert_array_equal(a.roles.astype(str), b.roles.astype(str))


@pytest.mark.parametrize("fmt,ext", FORMATS)
def test_round_trip_each_format(tmp_path, curved, fmt, ext):
    f1, f2 = tmp_path / f"a.{ext}", tmp_path / f"b.{ext}"
    with warnings.catch_warnings():
        warnings.simplefilter("error", LayoutWarning)  # our own files are clean
        save(curved, f1, fmt)
        a = load(f1, fmt)
        save(a, f2, fmt)
        b = load(f2, fmt)
    same(a, b)
    same(curved, a, ids=fmt != "icub", atol=1e-11)  # iCub ids are file rows
    if fmt in ("json", "cyskin", "csv", "ply"):
        np.testing.assert_allclose(a.flat, curved.flat, atol=1e-11)
    if fmt == "json":
        assert a.meta["reference_taxel"] == curved.meta["reference_taxel"]


def test_json_keeps_frame_transform_can(tmp_path):
    lay = make_patch("strip:2").flat_layout()
    lay.can_ids = np.arange(20) % 3
    lay.frame = "l_hand"
    t = np.eye(4)
    t[:3, 3] = [0.1, 0.2, 0.3]
    lay.transform = t
    save(lay, tmp_path / "x.json")
    b = load(tmp_path / "x.json")
    assert b.frame == "l_hand"
    np.testing.assert_array_equal(b.can_ids, lay.can_ids)
    np.testing.assert_allclose(b.transform, t)
    doc = json.loads((tmp_path / "x.json").read_text())
    assert doc["format"] == "vtcore-layout" and doc["version"] == 1 and doc["units"] == "m"


def test_export_in_another_frame(tmp_path, curved):
    t = np.array([[0, -1, 0, 0.1], [1, 0, 0, 0], [0, 0, 1, -0.05], [0, 0, 0, 1.0]])
    save(curved, tmp_path / "t.csv", transform=t)
    b = load(tmp_path / "t.csv")
    np.testing.assert_allclose(b.positions, curved.positions @ t[:3, :3].T + t[:3, 3], atol=1e-11)
    np.testing.assert_allclose(b.normals, curved.normals @ t[:3, :3].T, atol=1e-11)
    with pytest.raises(InputError, match="rigid"):
        save(curved, tmp_path / "u.csv", transform=np.diag([2.0, 1, 1, 1]))


def icub_text(rows, t2r=None, crlf=False, extra_header=""):
    t2r = t2r if t2r is not None else [3 if i % 12 not in (6, 10) else -2 for i in range(len(rows))]
    lines = ["name\tl_forearm", "spatial_sampling taxel", extra_header,
             "taxel2Repr ( " + " ".join(map(str, t2r)) + " )", "", "[calibration]"]
    lines += rows
    return ("\r\n" if crlf else "\n").join(lines) + "\n"


def messy_icub_rows():
    """Two triangles the way real files write them."""
    lay = make_patch("strip:2", "icub12").flat_layout()
    rows = []
    for k, (p, n) in enumerate(zip(lay.positions, lay.normals)):
        if k % 12 in (6, 10):
            rows.append("0 0 0 0 0 0")  # thermal pads have no position in many files
            continue
        sep = "\t" if k % 2 else "  "
        vals = [f"{v:.6e}" if k % 3 == 0 else f"{v:.6f}" for v in p] + [f"{v:g}" for v in n * 0.7]
        rows.append(sep.join(vals))
    rows[5] = rows[4]  # repeated position (a taxel placed at its neighbour's place)
    return rows


def test_icub_messy_file_reads_with_warnings(tmp_path):
    rows = messy_icub_rows()
    f = tmp_path / "left_forearm.txt"
    f.write_bytes(icub_text(rows, t2r=[3] * 30, crlf=True, extra_header="name l_forearm_frame").encode())
    with pytest.warns(LayoutWarning) as rec:
        lay = load(f)
    text = " | ".join(str(w.message) for w in rec)
    assert "taxel2Repr has 30 entries for 24" in text
    assert "not unit length" in text
    assert "repeat" in text
    assert "'name' lines" in text
    assert len(lay) == 20  # 24 rows, 4 empty thermal slots
    np.testing.assert_allclose(np.linalg.norm(lay.normals, axis=1), 1)
    assert lay.frame == "l_forearm_frame" and lay.meta["name"] == "l_forearm"
    assert lay.meta["import_warnings"]
    np.testing.assert_array_equal(lay.taxel_ids[:6], [0, 1, 2, 3, 4, 5])


def test_icub_placeholder_and_missing_normals(tmp_path):
    lay = make_patch("hexagon", "icub12").flat_layout()
    pos = lay.positions.copy()
    pos[:, 2] = -0.02 * pos[:, 0] ** 2 / 0.03 ** 2  # convex, so "1 0 0" everywhere is a placeholder
    rows = [" ".join(f"{v:.6f}" for v in p) + " 1 0 0" for p in pos]
    f = tmp_path / "p.txt"
    f.write_text(icub_text(rows))
    with pytest.warns(LayoutWarning, match="placeholder"):
        load(f)
    rows = [" ".join(f"{v:.6f}" for v in p) + " 0 0 0" for p in pos]
    f.write_text(icub_text(rows))
    with pytest.warns(LayoutWarning, match="no normal"):
        b = load(f)
    assert np.all(b.normals[:, 2] > 0.5)  # estimated and oriented (no reference: away from the centroid)


def test_icub_reads_every_row_and_roles(tmp_path):
    lay = make_patch("strip:2", "icub12").flat_layout()
    save(lay, tmp_path / "i.txt", "icub")
    b = load(tmp_path / "i.txt")
    assert len(b) == 24  # the reference reader drops the last row; we do not
    assert (b.roles == "thermal").sum() == 4


@pytest.mark.parametrize("bad,msg", [("0.01 0.02 nan 0 0 1", "not a finite"), ("0.01 0.02 0.03 0 0", "has 5 values"),
                                     ("0.01 0.02 abc 0 0 1", "not a number")])
def test_icub_errors_name_the_line(tmp_path, bad, msg):
    rows = ["0.01 0.02 0.03 0 0 1"] * 5 + [bad] + ["0.02 0.02 0.03 0 0 1"] * 6
    f = tmp_path / "bad.txt"
    f.write_text(icub_text(rows))
    with pytest.raises(FormatError, match=msg) as exc:
        load(f)
    assert exc.value.line == 12  # 6 header lines, bad is the 6th calibration row
    assert "bad.txt:12" in str(exc.value)


def test_icub_import_export_import_unchanged(tmp_path):
    rows = messy_icub_rows()
    f = tmp_path / "orig.txt"
    f.write_text(icub_text(rows))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", LayoutWarning)
        a = load(f)
        save(a, tmp_path / "again.txt")
        b = load(tmp_path / "again.txt")
    same(a, b)
    assert b.meta["icub_rows"] == a.meta["icub_rows"] == 24


def cyskin_doc(lay, variant="B", mm=False, bare_map=False, row_major=False):
    scale = 1e3 if mm else 1.0
    tf = np.eye(4)
    tf[:3, :3] = [[0, -1, 0], [1, 0, 0], [0, 0, 1]]
    tf[:3, 3] = [0.01, 0.02, 0.03]
    taxels = [{"id": int(i), "x": (p * scale).tolist(), "n": n.tolist(), "type": "pressure", "cut": 0}
              for i, p, n in zip(lay.taxel_ids, lay.positions, lay.normals)]
    faces = [[0, 1, 4], [0, 1, 4], [1, 2, 5]]
    skin = {"n_taxels": len(taxels) + 1, "n_faces": 3, "taxels": taxels, "faces": faces,
            "parent_frames": [{"key": 0, "id": 0, "type": "", "name": "wrist",
                               "tf_matrix": (tf if row_major else tf.T).reshape(-1).tolist()}]}
    mp = {"key": "0", "name": "map", "type": "isomap", "description": "d", "n_taxels": len(taxels),
          "n_faces": 3, "faces": faces,
          "taxels": [{"id": int(i), "x": (f * scale).tolist(), "type": "pressure", "cut": 0}
                     for i, f in zip(lay.taxel_ids, lay.flat)]}
    info = {"file_version": "2", "type": "rigid_body", "name": "x", "application": "a", "description": ""}
    if variant == "A":
        return {"info": info, "skin": skin}, tf
    if variant == "C":
        return {"tactile_maps": mp if bare_map else [mp]}, tf
    return {"info": info, "skin": skin, "tactile_maps": mp if bare_map else [mp]}, tf


@pytest.mark.parametrize("variant,bare", [("A", False), ("B", False), ("B", True), ("C", False), ("C", True)])
def test_cyskin_variants(tmp_path, variant, bare):
    lay = make_patch("hexagon").flat_layout()
    doc, tf = cyskin_doc(lay, variant, bare_map=bare)
    f = tmp_path / "c.json"
    f.write_text(json.dumps(doc))
    with pytest.warns(LayoutWarning):
        b = load(f)
    assert len(b) == 60
    np.testing.assert_array_equal(b.taxel_ids, lay.taxel_ids)
    np.testing.assert_array_equal(b.module_ids, lay.module_ids)
    if variant != "C":
        np.testing.assert_allclose(b.positions, lay.positions)
        np.testing.assert_allclose(b.transform, tf)  # column-major in the file
        assert b.parent == "wrist" and b.frame == "wrist_patch"
        assert b.meta["faces"][0] == [0, 1, 4]
    if variant != "A":
        np.testing.assert_allclose(b.flat, lay.flat)


def test_cyskin_warnings_and_row_major_hint(tmp_path):
    lay = make_patch("hexagon").flat_layout()
    doc, _ = cyskin_doc(lay, row_major=True)
    doc["skin"]["taxels"][1]["id"] = doc["skin"]["taxels"][0]["id"]  # repeated UID
    f = tmp_path / "c.json"
    f.write_text(json.dumps(doc))
    with pytest.warns(LayoutWarning) as rec:
        load(f)
    text = " | ".join(str(w.message) for w in rec)
    for part in ("n_taxels says 61", "duplicated faces", "belong to no face", "repeated taxel ids", "row-major"):
        assert part in text


def test_cyskin_import_export_import_unchanged(tmp_path, curved):
    doc, _ = cyskin_doc(curved)
    f = tmp_path / "orig.json"
    f.write_text(json.dumps(doc))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", LayoutWarning)
        a = load(f)
        save(a, tmp_path / "again.json", "cyskin")
        b = load(tmp_path / "again.json")
    same(a, b)
    np.testing.assert_allclose(a.transform, b.transform)
    np.testing.assert_allclose(a.flat, b.flat)
    assert a.parent == b.parent == "wrist" and a.frame == b.frame == "wrist_patch"
    assert a.meta["faces"] == b.meta["faces"] == doc["skin"]["faces"]  # the maker's faces survive


def test_millimetres_detected_or_declared(tmp_path):
    lay = make_patch("hexagon").flat_layout()
    doc, _ = cyskin_doc(lay, "A", mm=True)
    f = tmp_path / "mm.json"
    f.write_text(json.dumps(doc))
    with pytest.warns(LayoutWarning, match="millimetres"):
        b = load(f)
    np.testing.assert_allclose(b.positions, lay.positions, atol=1e-12)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", LayoutWarning)
        c = load(f, units="mm")
    np.testing.assert_allclose(c.positions, lay.positions, atol=1e-12)
    with pytest.warns(LayoutWarning, match="is it millimetres"):
        d = load(f, units="m")  # declared wins, but never silently
    assert np.ptp(d.positions[:, 0]) > 10
    # CSV with x_mm headers is declared
    rows = ["x_mm,y_mm,z_mm"] + [f"{p[0] * 1e3},{p[1] * 1e3},{p[2] * 1e3}" for p in lay.positions]
    (tmp_path / "mm.csv").write_text("\n".join(rows))
    with pytest.warns(LayoutWarning, match="no normal"):
        e = load(tmp_path / "mm.csv")
    np.testing.assert_allclose(e.positions, lay.positions, atol=1e-12)
    with pytest.raises(InputError, match="units"):
        load(tmp_path / "mm.csv", units="cm")


@pytest.mark.parametrize("row,msg,line", [("3,0.01,nan,0.0", "not a finite", 4), ("3,0.01,0.02", "has 3 values", 4),
                                          ("3,0.01,x,0.0", "not a number", 4)])
def test_csv_errors_name_the_line(tmp_path, row, msg, line):
    text = "# units: m\ntaxel_id,x,y,z\n1,0,0,0\n" + row + "\n4,0.0075,0,0\n"
    f = tmp_path / "t.csv"
    f.write_text(text)
    with pytest.raises(FormatError, match=msg) as exc:
        load(f)
    assert exc.value.line == line


def test_csv_missing_columns_and_empty(tmp_path):
    (tmp_path / "a.csv").write_text("x,y\n1,2\n")
    with pytest.raises(FormatError, match="lacks column"):
        load(tmp_path / "a.csv")
    (tmp_path / "b.csv").write_text("")
    with pytest.raises(FormatError, match="empty"):
        load(tmp_path / "b.csv")
    with pytest.raises(InputError, match="not found"):
        load(tmp_path / "none.csv")


def test_ply_has_faces_and_attributes(tmp_path, curved):
    save(curved, tmp_path / "s.ply")
    text = (tmp_path / "s.ply").read_text()
    assert "property int taxel_id" in text and "element skin_face" in text
    b = load(tmp_path / "s.ply")
    assert len(b.meta["faces"]) > 300
    # a binary PLY written by another tool
    import trimesh

    m = trimesh.Trimesh(curved.positions, np.asarray(b.meta["faces"]), process=False)
    m.export(tmp_path / "bin.ply", encoding="binary")
    with pytest.warns(LayoutWarning, match="no normal"):
        c = load(tmp_path / "bin.ply")
    np.testing.assert_allclose(c.positions, curved.positions, atol=1e-6)


def test_mjcf_sites_and_touch_sensors(tmp_path, curved):
    save(curved, tmp_path / "skin.xml", "mjcf")
    root = ET.parse(tmp_path / "skin.xml").getroot()
    sites = root.findall(".//site")
    touch = root.findall(".//sensor/touch")
    assert len(sites) == len(touch) == len(curved)
    assert {t.get("site") for t in touch} == {s.get("name") for s in sites}
    p = np.array([list(map(float, s.get("pos").split())) for s in sites])
    np.testing.assert_allclose(p, curved.positions + 5e-4 * curved.normals, atol=1e-8)  # on its 1 mm pad
    assert len(root.findall(".//geom")) == len(curved)  # the fragment's pads (it senses when attached)
    save(curved, tmp_path / "bare.xml", "mjcf", pad=False)
    sites = ET.parse(tmp_path / "bare.xml").getroot().findall(".//site")
    p = np.array([list(map(float, s.get("pos").split())) for s in sites])
    np.testing.assert_allclose(p, curved.positions, atol=1e-8)
    with pytest.raises(InputError, match="cannot read"):
        load(tmp_path / "skin.xml", "mjcf")


def test_nothing_half_written(tmp_path, monkeypatch):
    lay = make_patch("triangle").flat_layout()
    f = tmp_path / "keep.csv"
    save(lay, f)
    before = f.read_bytes()
    import vtcore.layout.io.csv as lio

    from vtcore.layout.io.common import number

    def boom(v):  # fail half-way through the rows
        if boom.calls > 50:
            raise RuntimeError("disk full")
        boom.calls += 1
        return number(v)

    boom.calls = 0
    monkeypatch.setattr(lio, "number", boom)
    with pytest.raises(RuntimeError):
        save(make_patch("hexagon").flat_layout(), f)
    assert f.read_bytes() == before
    assert not [p for p in tmp_path.iterdir() if p.name != "keep.csv"]


def test_write_cyskin_faces_default_is_skin_mesh(tmp_path):
    lay = make_patch("hexagon").flat_layout()
    write_cyskin(lay, tmp_path / "c.json")
    doc = json.loads((tmp_path / "c.json").read_text())
    assert doc["skin"]["n_faces"] == 94 and doc["tactile_maps"][0]["type"] == "isomap"
    assert doc["info"]["file_version"] == "2"
    m = np.reshape(doc["skin"]["parent_frames"][0]["tf_matrix"], (4, 4)).T
    np.testing.assert_allclose(m, np.eye(4))
