"""``vtcore bench control --quick`` (closed-loop contour error next to detection time); no timing asserts."""

from __future__ import annotations

import csv


def test_control_bench_quick(tmp_path):
    from vtcore.control import bench

    rows = bench.run(tmp_path, quick=True)
    assert (tmp_path / "table.md").exists() and (tmp_path / "accuracy_vs_time.png").exists()
    with open(tmp_path / "table.csv", newline="") as fh:
        assert len(list(csv.DictReader(fh))) == len(rows)
    assert {r["row"] for r in rows} == {"contour_mesh", "contour_image", "contour_subtaxel"}
    for r in rows:
        assert r["taps"] >= 2 and r["ms_per_tap"] > 0
        assert 0 <= r["d_mean_mm"] <= r["d_max_mm"] < 7.5  # below the taxel pitch


def test_bench_command_lists_control_and_filters():
    from vtcore.cli.bench import available

    names = available()
    assert names["control"] == "vtcore.control.bench" and names["filters"] == "vtcore.filters.bench"
