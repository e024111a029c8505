"""Lossless round trips: import then export in the same format gives back the file's number tables
byte for byte, for every iCub and CySkin variant that ../shared/formats/ describes (built here)."""

import copy
import json
import re
import warnings

import numpy as np
import pytest

from vtcore.cli import main
from vtcore.layout import LayoutWarning, load, make_patch, save


def quiet_load(path, **kw):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", LayoutWarning)
        return load(path, **kw)


# --- iCub variants (icub_skin.md) --------------------------------------------------------------------------
def icub_rows(n_tri=16, seed=0):
    """Slots of ``n_tri`` triangles on a gently curved forearm: x y z nx ny nz, metres."""
    lay = make_patch(f"strip:{n_tri}", "icub12").flat_layout()
    rng = np.random.default_rng(seed)
    p = lay.positions.copy()
    p[:, 2] = 0.03 - 0.5 * p[:, 1] ** 2 / 0.03
    n = np.column_stack([np.zeros(len(p)), p[:, 1] / 0.03, np.ones(len(p))])
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    p += rng.normal(0, 1e-5, p.shape)
    return np.column_stack([p, n]), lay.roles


def t2r_for(n_rows, thermal_slots=(6, 10)):
    return [-2 if i % 12 in thermal_slots else (i // 12) * 12 + 3 for i in range(n_rows)]


def fmt_rows(data, style="plain", sep=" "):
    out = []
    for k, r in enumerate(data):
        if style == "plain":
            vals = [f"{v:.6f}" for v in r]
        elif style == "mixed":  # scientific and plain, tabs and spaces
            vals = [f"{v:.6e}" if k % 3 == 0 else f"{v:.7g}" for v in r]
            sep = "\t" if k % 2 else "  "
        else:
            vals = [repr(float(v)) for v in r]
        out.append(sep.join(vals))
    return out


def build_icub(variant):
    """(text, description) of one variant of a skinGui positions file."""
    n_tri = {"big": 32, "odd_rows": 2}.get(variant, 16)
    data, _ = icub_rows(n_tri, seed=len(variant))
    n_rows = len(data)
    t2r = t2r_for(n_rows)
    header = ["name l_forearm", "spatial_sampling taxel"]
    style, eol = "plain", "\n"
    thermal_empty = variant in ("thermal_zero", "t2r_960", "crlf_mixed", "big")
    if thermal_empty:
        data[[i for i in range(n_rows) if i % 12 in (6, 10)]] = 0.0
    if variant == "crlf_mixed":
        style, eol = "mixed", "\r\n"
        header[0] = "name\tl_forearm"
    if variant == "placeholder":
        data[:, 3:] = [1, 0, 0]
    if variant == "non_unit":
        data[:, 3:] *= np.linspace(0.5, 1.0, n_rows)[:, None]
    if variant == "zero_normals":
        data[5:40, 3:] = 0.0
    if variant == "repeated":
        data[13, :3] = data[15, :3]  # placed at the triangle centre
    if variant == "second_name":
        header.append("name l_forearm_frame")
    if variant == "triangle_sampling":
        header[1] = "spatial_sampling triangle"
    if variant == "t2r_960":
        t2r = t2r + [-1] * (960 - n_rows)
    if variant == "fingertip":
        t2r = [-1] * n_rows  # fingertip files: no representative taxels
    if variant == "odd_rows":
        data = data[:-5]
        t2r = t2r[:-5]
    if variant == "empty_triangle":
        data[24:36] = 0.0
    lines = header + ["taxel2Repr ( " + " ".join(map(str, t2r)) + " )", "", "[calibration]"]
    if variant == "no_header":
        lines = header + ["taxel2Repr ( " + " ".join(map(str, t2r)) + " )"]
    if variant == "t2r_multiline":
        lines = header + ["taxel2Repr ( " + " ".join(map(str, t2r[:96])), "   " + " ".join(map(str, t2r[96:])) + " )",
                          "// comment line kept", "[calibration]"]
    lines += fmt_rows(data, style)
    return eol.join(lines) + eol


ICUB_VARIANTS = ["plain", "crlf_mixed", "thermal_zero", "placeholder", "non_unit", "zero_normals", "repeated",
                 "second_name", "triangle_sampling", "t2r_960", "fingertip", "odd_rows", "empty_triangle",
                 "no_header", "t2r_multiline", "big"]


def icub_tables(text):
    """The number tables of a positions file: taxel2Repr tokens and the calibration rows (as text)."""
    text = text.replace("\r\n", "\n")
    m = re.search(r"taxel2Repr\s*\((.*?)\)", text, re.S)
    t2r = m.group(1).split() if m else None
    rows = [ln.strip() for ln in text.split("\n")
            if ln.strip() and re.match(r"^[-+0-9.]", ln.strip()) and len(ln.split()) >= 6]
    names = re.findall(r"^name\s+(\S+)", text, re.M)
    ss = re.findall(r"^spatial_sampling\s+(\S+)", text, re.M)
    return t2r, rows, names, ss


@pytest.mark.parametrize("variant", ICUB_VARIANTS)
def test_icub_round_trip_byte_for_byte(tmp_path, variant):
    src = tmp_path / "in.txt"
    src.write_bytes(build_icub(variant).encode())
    a = quiet_load(src)
    save(a, tmp_path / "out.txt", "icub")
    assert icub_tables((tmp_path / "out.txt").read_text()) == icub_tables(src.read_text())
    # through our JSON (import, then export)
    save(a, tmp_path / "mid.json")
    b = quiet_load(tmp_path / "mid.json")
    save(b, tmp_path / "again.txt", "icub")
    assert icub_tables((tmp_path / "again.txt").read_text()) == icub_tables(src.read_text())
    c = quiet_load(tmp_path / "again.txt")
    for x, y in ((a, b), (a, c)):
        np.testing.assert_array_equal(x.positions, y.positions)
        np.testing.assert_array_equal(x.normals, y.normals)
        np.testing.assert_array_equal(x.taxel_ids, y.taxel_ids)
        np.testing.assert_array_equal(x.normals_estimated, y.normals_estimated)
    if variant == "zero_normals":
        assert a.normals_estimated.sum() == 35 and np.all(np.abs(np.linalg.norm(a.normals, axis=1) - 1) < 1e-9)


def test_icub_cli_export_is_lossless(tmp_path, capsys):
    src = tmp_path / "left_forearm.txt"
    src.write_bytes(build_icub("crlf_mixed").encode())
    assert main(["layout", "import", str(src), "--out", str(tmp_path / "l.json")]) == 0
    assert main(["layout", "export", str(tmp_path / "l.json"), "--format", "icub", "--out",
                 str(tmp_path / "o.txt")]) == 0
    assert icub_tables((tmp_path / "o.txt").read_text()) == icub_tables(src.read_text())


def test_icub_zero_normals_estimated_only_on_request(tmp_path):
    src = tmp_path / "z.txt"
    src.write_text(build_icub("zero_normals"))
    assert main(["layout", "export", str(src), "--format", "icub", "--estimate-normals",
                 "--out", str(tmp_path / "est.txt")]) == 0
    _, rows, _, _ = icub_tables((tmp_path / "est.txt").read_text())
    n = np.array([[float(v) for v in r.split()[3:6]] for r in rows])
    assert np.all(np.abs(np.linalg.norm(n[5:40], axis=1) - 1) < 1e-9)  # estimates written
    assert rows[:5] == icub_tables(src.read_text())[1][:5]  # the rest as read


def test_icub_taxel2repr_kept_and_disagreement_warned(tmp_path):
    src = tmp_path / "f.txt"
    src.write_text(build_icub("fingertip"))
    with pytest.warns(LayoutWarning, match="taxel2Repr disagrees with the calibration rows at 192 slots"):
        a = load(src)
    assert a.meta["taxel2Repr"] == [-1] * 192


def test_icub_moved_taxels_written_afresh_and_exactly(tmp_path):
    src = tmp_path / "p.txt"
    src.write_text(build_icub("plain"))
    a = quiet_load(src)
    t = np.eye(4)
    t[:3, 3] = [0.001, 0, 0]
    save(a, tmp_path / "moved.txt", "icub", transform=t)
    b = quiet_load(tmp_path / "moved.txt")
    np.testing.assert_array_equal(b.positions, a.positions + [0.001, 0, 0])  # shortest exact decimals
    _, rows, _, _ = icub_tables((tmp_path / "moved.txt").read_text())
    assert rows != icub_tables(src.read_text())[1]


# --- CySkin variants (cyskin_calibration.md) ------------------------------------------------------------------
def cyskin_base(n_modules=6, mm=False, seed=0):
    lay = make_patch("hexagon" if n_modules == 6 else f"strip:{n_modules // 2}").flat_layout()
    rng = np.random.default_rng(seed)
    s = 1e3 if mm else 1.0
    p = lay.positions.copy()
    p[:, 2] = -0.5 * p[:, 0] ** 2 / 0.05  # half-cylinder-like bend
    n = np.column_stack([p[:, 0] / 0.05, np.zeros(len(p)), np.ones(len(p))])
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    p += rng.normal(0, 2e-5, p.shape)
    from vtcore.layout.mesh import skin_mesh

    faces = skin_mesh(lay).triangles.tolist()
    taxels = [{"id": int(i), "x": (q * s).tolist(), "n": m.tolist(), "type": "pressure", "cut": 0}
              for i, q, m in zip(lay.taxel_ids, p, n)]
    tf = [0.7071, 0.7071, 0.0, 0.0, -0.7071, 0.7071, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 12.5 * (1 if mm else 1e-3),
          -3.25 * (1 if mm else 1e-3), 40.0 * (1 if mm else 1e-3), 1.0]
    skin = {"n_taxels": len(taxels), "n_faces": len(faces),
            "parent_frames": [{"key": 0, "id": 0, "type": "", "name": "r_forearm", "tf_matrix": tf}],
            "taxels": taxels, "faces": faces}
    iso = {"key": 1, "name": "r_forearm_isomap", "type": "isomap", "description": ["unrolled", "by isomap"],
           "n_taxels": len(taxels), "n_faces": len(faces), "faces": faces,
           "taxels": [{"id": int(i), "x": (f * s).tolist(), "type": "pressure", "cut": 0}
                      for i, f in zip(lay.taxel_ids, lay.flat)]}
    flat = copy.deepcopy(iso)
    flat.update(key="2", name="r_forearm_flat", type="flat_mesh", description="orthographic")
    for t, q in zip(flat["taxels"], p):
        t["x"] = (q[:2] * s).tolist()
    info = {"file_version": "2", "type": "rigid_body", "name": "right forearm (wrong name)",
            "application": "skin_calibration", "description": "r_forearm patch 3"}
    return info, skin, iso, flat


def build_cyskin(variant):
    mm = variant == "B_mm"
    info, skin, iso, flat = cyskin_base(mm=mm, seed=len(variant))
    if variant == "A":
        return {"info": info, "skin": skin}
    if variant in ("B", "B_mm"):
        return {"info": info, "skin": skin, "tactile_maps": [iso, flat]}
    if variant == "B_bare":
        return {"info": info, "skin": skin, "tactile_maps": iso}
    if variant == "C":
        return {"tactile_maps": [iso, flat]}
    if variant == "C_bare":
        return {"tactile_maps": iso}
    if variant == "full_flatmap":  # the *_full_flatmap files: one flat_sensors_placement map
        fm = copy.deepcopy(iso)
        fm.update(type="flat_sensors_placement", name="full_flatmap", key=0)
        return {"info": info, "skin": skin, "tactile_maps": [fm]}
    if variant == "zero_normals":
        for t in skin["taxels"][10:20]:
            t["n"] = [0, 0, 0]
        return {"info": info, "skin": skin}
    if variant == "planar_inward":
        for t in skin["taxels"]:
            t["x"][2] = 0.0
            t["n"] = [0, 0, -1]
        return {"info": info, "skin": skin, "tactile_maps": [iso]}
    if variant == "messy":  # lying counts, duplicated faces, lonely taxels, repeated and zero ids, cuts
        skin["n_taxels"] += 1
        skin["faces"] = skin["faces"][:40] + skin["faces"][:2]
        skin["taxels"][3]["id"] = skin["taxels"][4]["id"]
        skin["taxels"][7]["id"] = 0
        skin["taxels"][8]["cut"] = 1
        return {"info": info, "skin": skin, "tactile_maps": [iso]}
    raise ValueError(variant)


CYSKIN_VARIANTS = ["A", "B", "B_mm", "B_bare", "C", "C_bare", "full_flatmap", "zero_normals", "planar_inward",
                   "messy"]


@pytest.mark.parametrize("variant", CYSKIN_VARIANTS)
def test_cyskin_round_trip(tmp_path, variant):
    doc = build_cyskin(variant)
    src = tmp_path / "in.json"
    src.write_text(json.dumps(doc, indent=1) + "\n")
    a = quiet_load(src)
    save(a, tmp_path / "out.json", "cyskin")
    assert json.loads((tmp_path / "out.json").read_text()) == doc  # every key, map and number as read
    assert (tmp_path / "out.json").read_bytes() == src.read_bytes()  # our indent style: byte for byte
    save(a, tmp_path / "mid.json")  # through our JSON
    b = quiet_load(tmp_path / "mid.json")
    save(b, tmp_path / "again.json", "cyskin")
    assert (tmp_path / "again.json").read_bytes() == src.read_bytes()
    if variant == "B_mm":
        np.testing.assert_allclose(a.transform[:3, 3], [0.0125, -0.00325, 0.04])  # metres inside
    if variant.startswith("C"):
        assert a.normals_estimated.all() and "skin" not in json.loads((tmp_path / "again.json").read_text())


def test_cyskin_cli_export_is_lossless(tmp_path):
    doc = build_cyskin("B")
    src = tmp_path / "r_forearm_full_flatmap.json"
    src.write_text(json.dumps(doc))
    assert main(["layout", "export", str(src), "--format", "cyskin", "--out", str(tmp_path / "o.json")]) == 0
    assert json.loads((tmp_path / "o.json").read_text()) == doc


def test_cyskin_changes_are_written_in_the_files_units(tmp_path):
    doc = build_cyskin("B_mm")
    src = tmp_path / "mm.json"
    src.write_text(json.dumps(doc))
    a = quiet_load(src)
    t = np.eye(4)
    t[:3, 3] = [0.001, 0.0, 0.0]  # export 1 mm further along x
    save(a, tmp_path / "moved.json", "cyskin", transform=t)
    out = json.loads((tmp_path / "moved.json").read_text())
    x0 = np.array([q["x"] for q in doc["skin"]["taxels"]])
    x1 = np.array([q["x"] for q in out["skin"]["taxels"]])
    np.testing.assert_allclose(x1, x0 + [1.0, 0, 0], atol=1e-9)  # still millimetres
    tf = np.reshape(out["skin"]["parent_frames"][0]["tf_matrix"], (4, 4)).T
    tf0 = np.reshape(doc["skin"]["parent_frames"][0]["tf_matrix"], (4, 4)).T
    np.testing.assert_allclose(tf @ np.r_[x1[0], 1], tf0 @ np.r_[x0[0], 1], atol=1e-9)  # same place in the parent
    assert out["tactile_maps"] == doc["tactile_maps"] and out["info"] == doc["info"]


def test_cyskin_zero_normals_estimated_on_request(tmp_path):
    doc = build_cyskin("zero_normals")
    src = tmp_path / "z.json"
    src.write_text(json.dumps(doc))
    a = quiet_load(src)
    assert a.normals_estimated.sum() == 10
    save(a, tmp_path / "e.json", "cyskin", estimate_normals=True)
    out = json.loads((tmp_path / "e.json").read_text())
    n = np.array([t["n"] for t in out["skin"]["taxels"]])
    np.testing.assert_allclose(np.linalg.norm(n, axis=1), 1, atol=1e-9)
    assert out["skin"]["taxels"][:10] == doc["skin"]["taxels"][:10]


def test_cyskin_from_elsewhere_has_no_local_path(tmp_path):
    lay = make_patch("hexagon").flat_layout()
    lay.meta["source"] = str(tmp_path / "deep" / "secret" / "place.csv")
    save(lay, tmp_path / "c.json", "cyskin")
    doc = json.loads((tmp_path / "c.json").read_text())
    assert str(tmp_path) not in json.dumps(doc) and doc["info"]["description"].endswith("place.csv")
