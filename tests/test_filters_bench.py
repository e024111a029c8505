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
        if r["row"].startswith("mesh_filter"):  # against Eq. 6 summed edge by edge from the triangles
            assert r["rel_err"] < (1e-12 if r["knob"] == "float64" else 1e-5), r
        if r["row"] == "image_backproject_all":  # against a plain loop over the flat triangles
            assert r["pos_err_mm"] < 1e-9 and r["rel_err"] < 1e-9 and r["misses"] == 0, r
    grids = {r["knob"].split(",")[0] for r in rows if r["row"] == "image_backproject_all"}
    assert len(grids) >= 3


def test_eq6_reference_by_hand():
    # two triangles (0 1 2), (1 3 2) on unit-ish edges: r_i = sum_j p_j (p_j - p_i) / d_ij
    import numpy as np

    from vtcore.filters.bench import eq6_reference

    pos = np.array([[0, 0, 0], [1, 0, 0], [0, 2, 0], [1, 2, 0.0]])
    p = np.array([1.0, 2.0, 3.0, 5.0])
    r = eq6_reference(pos, [[0, 1, 2], [1, 3, 2]], p[None])[0]
    d12 = np.sqrt(5.0)
    want = [2 * (2 - 1) / 1 + 3 * (3 - 1) / 2,
            1 * (1 - 2) / 1 + 3 * (3 - 2) / d12 + 5 * (5 - 2) / 2,
            1 * (1 - 3) / 2 + 2 * (2 - 3) / d12 + 5 * (5 - 3) / 1,
            2 * (2 - 5) / 2 + 3 * (3 - 5) / 1]
    assert np.allclose(r, want, rtol=1e-14)


def test_backproject_reference_by_hand():
    # one flat triangle (0,0) (2,0) (0,2) lifted to z = x + 2y: inside pixels land on that plane
    import numpy as np

    from vtcore.filters.bench import backproject_reference

    flat = np.array([[0, 0], [2, 0], [0, 2.0]])
    pos = np.column_stack([flat, flat[:, 0] + 2 * flat[:, 1]])
    px = np.array([[0.5, 0.5], [1.0, 1.0], [1.5, 1.5], [0.0, 0.0]])
    inside, pts = backproject_reference(flat, pos, [[0, 1, 2]], px)
    assert inside.tolist() == [True, True, False, True]
    assert np.allclose(pts[inside], [[0.5, 0.5, 1.5], [1.0, 1.0, 3.0], [0, 0, 0]])
