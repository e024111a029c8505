"""The placement report as shown to a designer: vtcore.layout.summary, `layout place` and `layout info`."""

import json

import numpy as np
import pytest
import trimesh

from vtcore.cli import main
from vtcore.layout import load, place
from vtcore.layout.summary import report_fields, report_lines


def test_fields_and_lines_from_a_real_report():
    mesh = trimesh.creation.icosphere(4, radius=0.03)
    layout, rep = place(mesh, "hexagon", [0, 0, 0.03])
    f = report_fields(layout.meta["placement"])
    assert f["strain_max"] == pytest.approx(rep.strain_max) and f["strain_mean"] == pytest.approx(rep.strain_mean)
    assert f["overlaps"] == len(rep.overlaps) and f["off_boundary"] == len(rep.off_boundary)
    assert f["coverage"] == pytest.approx(rep.coverage) and f["method"] == "logmap"
    lines = report_lines(layout.meta["placement"])
    assert lines[0] == f"coverage {100 * rep.coverage:.1f} % of the region"
    assert lines[1].startswith(f"strain max {100 * rep.strain_max:.2f} %")
    assert any(line.startswith("overlaps 0 module pairs") for line in lines)


def test_missing_and_odd_fields_are_left_out():
    assert report_fields(None) == {} and report_lines({}) == []
    f = report_fields({"coverage": None, "strain_max": float("nan"), "overlaps": 2, "overlaps_within": 1,
                       "overlaps_existing": 1, "off_boundary": [3, 4, 5], "surface_distance_max_m": 2e-4})
    assert f == {"overlaps": 2, "overlaps_within": 1, "overlaps_existing": 1, "off_boundary": 3,
                 "surface_distance_max_mm": pytest.approx(0.2)}
    assert report_lines(f) == ["overlaps 2 module pairs (1 within the patch, 1 with modules already there)",
                               "3 taxels off the mapped surface"]
    # a field that overflows in the unit it is shown in (the fuzz of issue 28: -1e308 m printed
    # -Infinity in `layout info --json` as -1e311 mm)
    assert report_fields({"surface_distance_max_m": -1e308, "coverage": 1e307, "strain_max": 2e306,
                          "seconds": 1e308}) == {"seconds": 1e308}
    assert report_fields({"coverage": 10 ** 400}) == {}
    assert report_lines({"charts": 7, "seam_modules": 3}) == ["grown through 7 charts, 3 modules closing the seam"]
    assert report_lines({"charts": 1, "normal_outliers": []}) == []
    assert report_lines({"normal_outliers": [4, 9], "normal_deviation_max_deg": 81.2}) == [
        "2 taxels with a normal off their face's (up to 81 deg)"]


def test_cli_place_and_info_show_the_report(tmp_path, capsys):
    mesh = trimesh.creation.cylinder(radius=0.03, height=0.1, sections=64).subdivide_to_size(0.004)
    mesh.export(tmp_path / "c.stl")
    out = tmp_path / "c.json"
    assert main(["layout", "place", str(tmp_path / "c.stl"), "--patch", "strip:3", "--at", "0.03", "0", "0",
                 "--direction", "0", "0", "1", "--out", str(out)]) == 0
    lines = report_lines(load(out).meta["placement"])
    printed = capsys.readouterr().out.splitlines()
    assert [p.strip() for p in printed[1:]] == lines and len(lines) >= 3
    assert main(["layout", "info", str(out), "--json"]) == 0
    info = json.loads(capsys.readouterr().out)
    assert info["placement"] == json.loads(json.dumps(report_fields(load(out).meta["placement"])))
    assert info["mirror"] is False and np.isfinite(info["placement"]["coverage"])
    assert main(["layout", "info", str(out)]) == 0
    assert "placement report (logmap): " + "; ".join(lines) in capsys.readouterr().out
