"""Fuzz of what the layout readers accept, fed to every writer and to ``layout info`` (issue 28).

The principle: a writer fed what a reader accepts never crashes. Inputs are our layout JSON with
its fields edited structurally (a value set to an extreme: 0, negative, 1e-320, 1e308, NaN, a
string, null, a list; scaled, copied from elsewhere, deleted, duplicated; a field the table knows
added: ``meta.pitch_m``, ``meta.faces``, ...), from seeds that carry every kind of ``meta`` (an iCub
file, a CySkin file, a placed layout with its placement report and flat map, PLY faces and CAN
ids), and the readable formats' own files mutated byte by byte. Each input is exported to every
format (``layout export --format F``) and summarised (``layout info --json``). Every call must end
in exit 2 with one ``vtcore: error:`` line, or exit 0 with an output its consumer reads with finite
numbers: our readers for json/icub/cyskin/csv/ply, MuJoCo for MJCF (one touch sensor per taxel),
yourdfpy for URDF; ``layout info --json`` prints finite numbers; ``vtcore robot export`` (the skinned
UR5, URDF and MJCF) of the same layouts hung on a link. See fuzzing.py for the contract.
"""

from __future__ import annotations

import json
import math
import re
from pathlib import Path

import numpy as np
import pytest
from hypothesis import strategies as st

from fuzzing import assert_clean_exit, fuzz, mutated, mutated_doc, run_cli

ROOT = Path(__file__).resolve().parents[2]
LAYOUTS = ROOT / "scenes" / "layouts"
SUFFIX = {"json": ".json", "icub": ".txt", "cyskin": ".json", "csv": ".csv", "ply": ".ply", "mjcf": ".xml",
          "urdf": ".urdf"}


@pytest.fixture(scope="module")
def seeds(tmp_path_factory):
    """Our JSON of four layouts (as decoded documents) and the byte seeds of the readable formats."""
    import warnings

    import trimesh

    from vtcore.layout import load, place, save
    from vtcore.layout.mesh import LayoutWarning

    d = tmp_path_factory.mktemp("writer_seeds")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", LayoutWarning)
        icub = load(LAYOUTS / "icub_two_triangles.txt")
        cyskin = load(LAYOUTS / "seed001_hexagon.cyskin.json")
        mesh = trimesh.creation.cylinder(radius=0.03, height=0.1, sections=32)
        placed, _ = place(mesh, "triangle", [0.03, 0.0, 0.0])
        save(icub, d / "p.ply", "ply")
        plyd = load(d / "p.ply")
        plyd.can_ids = np.arange(len(plyd)) % 3 - 1
    docs = []
    for i, lay in enumerate((icub, cyskin, placed, plyd)):
        save(lay, d / f"{i}.json", "json")
        docs.append(json.loads((d / f"{i}.json").read_text()))
    raw = {"icub": [(LAYOUTS / "icub_two_triangles.txt").read_bytes()],
           "cyskin": [(LAYOUTS / "seed001_hexagon.cyskin.json").read_bytes()],
           "json": [(d / "0.json").read_bytes(), (d / "2.json").read_bytes()]}
    for fmt in ("csv", "ply"):
        save(icub, d / f"s{SUFFIX[fmt]}", fmt)
        raw[fmt] = [(d / f"s{SUFFIX[fmt]}").read_bytes()]
    return docs, raw


def _names():
    from vtcore.layout.io.fields import DOCUMENT, META, TAXELS

    return [*DOCUMENT, *(f"taxels.{k}" for k in TAXELS), *(f"meta.{k}" for k in META)]


def _finite_xml(path: Path) -> None:
    """Every number in the XML's numeric attributes is finite (no nan/inf written into a robot file;
    a frame may be *named* "nan")."""
    text = path.read_text(encoding="utf-8")
    hit = re.search(r'\b(pos|quat|size|zaxis|xyz|rpy|rgba)="[^"]*\b(nan|inf)', text, re.I)
    assert not hit, f"non-finite number in {path.name}: {hit.group(0) if hit else ''}"


def check_output(fmt: str, out: Path, n_taxels: int | None) -> None:
    """The exported file read by its consumer, with finite numbers."""
    from vtcore.layout import load

    if fmt in ("json", "icub", "cyskin", "csv", "ply"):
        back = load(out, fmt)
        assert np.isfinite(back.positions).all() and np.isfinite(back.normals).all()
        assert np.isfinite(back.transform).all()
    elif fmt == "mjcf":
        _finite_xml(out)
        mujoco = pytest.importorskip("mujoco")
        model = mujoco.MjModel.from_xml_path(str(out))
        assert n_taxels is None or model.nsensor == n_taxels
    elif fmt == "urdf":
        _finite_xml(out)
        yourdfpy = pytest.importorskip("yourdfpy")
        robot = yourdfpy.URDF.load(str(out), build_scene_graph=False, load_meshes=False)
        assert n_taxels is None or len(robot.robot.joints) == n_taxels


def export_all(src: Path, out_dir: Path, fmt_in: str | None = None) -> None:
    """``layout export`` of ``src`` to every format, each outcome held to the contract."""
    from vtcore.layout.io import FORMATS

    n = None
    for fmt in FORMATS:
        out = out_dir / f"out_{fmt}{SUFFIX[fmt]}"
        out.unlink(missing_ok=True)
        argv = ["layout", "export", src, "--format", fmt, "--out", out]
        rc, so, se = run_cli(f"layout export {fmt}", argv)
        assert_clean_exit(rc, so, se)
        if rc == 0:
            if n is None:
                n = int(so.rsplit(":", 1)[1].split()[0]) if ": " in so else None
            check_output(fmt, out, n)
        else:
            assert not out.exists(), "a refused export left a file"
    return None


def _dump(doc) -> str:
    return json.dumps(doc, indent=1)  # NaN and Infinity as the tokens a careless writer leaves


def test_fuzz_export_every_format(seeds, tmp_path, pytestconfig):
    docs, raw = seeds
    names = _names()
    src = tmp_path / "in.json"

    def check(example):
        kind, data = example
        if kind == "doc":
            src.write_text(_dump(data), encoding="utf-8")
            export_all(src, tmp_path)
        else:
            fmt, blob = data
            path = tmp_path / f"in_raw{SUFFIX[fmt]}"
            path.write_bytes(blob)
            export_all(path, tmp_path, fmt)

    raw_strategy = st.sampled_from(sorted(raw)).flatmap(lambda f: st.tuples(st.just(f), mutated(raw[f])))
    fuzz(pytestconfig, st.one_of(st.tuples(st.just("doc"), mutated_doc(docs, names)),
                                 st.tuples(st.just("doc"), mutated_doc(docs, names)),
                                 st.tuples(st.just("doc"), mutated_doc(docs, names)),
                                 st.tuples(st.just("raw"), raw_strategy)), check)


def _finite_json_numbers(text: str) -> None:
    def refuse(token):
        raise AssertionError(f"layout info printed {token}")

    json.loads(text, parse_constant=refuse)


def test_fuzz_layout_info(seeds, tmp_path, pytestconfig):
    docs, raw = seeds
    names = _names()
    src = tmp_path / "in.json"

    def check(doc):
        src.write_text(_dump(doc), encoding="utf-8")
        rc, so, se = run_cli("layout info", ["layout", "info", src, "--json"])
        assert_clean_exit(rc, so, se)
        if rc == 0:
            _finite_json_numbers(so)
            info = json.loads(so)
            assert all(math.isfinite(v) for v in info["bbox_min_m"] + info["bbox_max_m"])
        rc, so, se = run_cli("layout info", ["layout", "info", src])
        assert_clean_exit(rc, so, se)

    fuzz(pytestconfig, mutated_doc(docs, names), check)


def _ur5() -> Path:
    import sysconfig

    p = (Path(sysconfig.get_paths()["purelib"]) / "cmeel.prefix" / "share" / "example-robot-data" / "robots"
         / "ur_description" / "urdf" / "ur5_robot.urdf")
    if not p.exists():
        pytest.skip("example-robot-data is not installed")
    return p


def test_fuzz_robot_export(seeds, tmp_path, pytestconfig):
    """``vtcore robot export`` (the skinned robot, URDF and MJCF through MuJoCo's URDF import) of the
    same edited layouts hung on the UR5's forearm (by frame) or wrist (by parent): a new writer fed
    what the reader accepts. An export that succeeds is read by yourdfpy or compiled by MuJoCo."""
    docs, _ = seeds
    ur5 = _ur5()
    names = _names()
    hung = []
    for doc in docs:
        hung.append({**doc, "frame": "forearm_link", "parent": None, "transform": None})
        hung.append({**doc, "frame": "skin", "parent": "wrist_1_link"})
    src = tmp_path / "in.json"

    def check(example):
        doc, fmt = example
        src.write_text(_dump(doc), encoding="utf-8")
        out = tmp_path / ("skinned.urdf" if fmt == "urdf" else "skinned.xml")
        out.unlink(missing_ok=True)
        rc, so, se = run_cli(f"robot export {fmt}", ["robot", "export", ur5, src, "--out", out])
        assert_clean_exit(rc, so, se)
        if rc == 0:
            check_output(fmt, out, None)
        else:
            assert not out.exists(), "a refused export left a file"

    fuzz(pytestconfig, st.tuples(mutated_doc(hung, names), st.sampled_from(["urdf", "mjcf"])), check)
