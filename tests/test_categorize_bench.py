"""``vtcore bench categorize --quick`` writes its table and plot (timings are never asserted)."""

from __future__ import annotations

import csv


def test_bench_quick_writes_table_and_plot(tmp_path):
    from vtcore.categorize import bench

    rows = bench.run(tmp_path, quick=True)
    assert {r["model"] for r in rows} == {"finite_layer", "halfspace", "local"}
    # the reference is a converged run on finer objects and grid, none of the rows: the finite layer
    # converges towards it as its grid is refined
    fl = sorted((r for r in rows if r["model"] == "finite_layer"), key=lambda r: -r["grid_mm"])
    assert fl[-1]["max_image_error"] < 0.02 and fl[-1]["max_image_error"] < fl[0]["max_image_error"]
    assert fl[-1]["max_expected_accuracy_error"] <= 0.05
    assert all(r["max_expected_accuracy_error"] != r["max_expected_accuracy_error"]  # NaN: nothing reached
               or 0.0 <= r["max_expected_accuracy_error"] <= 0.5 for r in rows)
    for name in ("table.md", "table.csv", "accuracy_vs_time.png"):
        assert (tmp_path / name).stat().st_size > 0
    with open(tmp_path / "table.csv", newline="") as fh:
        assert len(list(csv.DictReader(fh))) == len(rows)
