"""``vtcore bench filters --quick`` writes its table and plot (timings are not asserted)."""

from __future__ import annotations

import csv


def test_filters_bench_quick(tmp_path):
    from vtcore.filters import bench

    rows = bench.run(tmp_path, quick=True)
    assert (tmp_path / "table.md").exists() and (tmp_path / "accuracy_vs_time.png").exists()
    with open(tmp_path / "table.csv", newline="") as fh:
        table = list(csv.DictReader(fh))
    assert len(table) == len(rows)
    kinds = {r["row"] for r in rows}
    assert {"mesh_filter", "mesh_filter_batch", "detect_mesh", "detect_image", "detect_subtaxel"} <= kinds
    assert not any(k.startswith("contour_") for k in kinds)  # closed loop: vtcore bench control
    for r in rows:
        assert r["ms_per_frame"] > 0
        if r["row"].startswith("detect_"):
            assert r["pos_err_mm"] < 7.5 and r["misses"] == 0
