"""``vtcore bench evaluate``'s table-cell rows: each cell's maps against press-by-press solves (no timing asserts)."""

from __future__ import annotations

import pytest


@pytest.mark.slow
def test_table_cell_rows_are_measured_against_press_by_press_solves():
    import numpy as np

    from vtcore.contact import SoftLayer
    from vtcore.evaluate import bench
    from vtcore.evaluate.noise import sensor_noise
    from vtcore.layout import make_patch

    rows = bench.knob_rows(make_patch("hexagon").flat_layout(), SoftLayer(thickness=0.003), sensor_noise(), True)
    assert [r["setting"] for r in rows] == ["0.25 mm cell", "0.5 mm cell", "1 mm cell"]
    for r in rows:
        # the reference is the full contact solve, not the finest cell: even 0.25 mm has an error
        assert r["press_s_per_point"] > 0 and r["points"] == 4
        assert 0 < r["threshold_err_pct_max"] < 20 and 0 < r["loc_noise_free_err_mm_max"] < 0.2, r
    # a coarser cell is no closer to the reference
    thr = [r["threshold_err_pct_max"] for r in rows]
    assert thr[2] >= thr[0] and np.isfinite(thr).all()


def test_resolution_rows_have_a_time_and_an_error_against_press_by_press():
    """Every ``resolution`` row (seed 001 Fig. 10 as design maps) carries its map's time and its error
    against press-by-press solves with the same dead taxels, finite (issue 34; no timing asserted)."""
    import numpy as np

    from vtcore.contact import SoftLayer
    from vtcore.evaluate import bench
    from vtcore.evaluate.noise import sensor_noise
    from vtcore.layout import seed001_disc

    disc, hexagon = seed001_disc()
    rows = bench.resolution_rows(disc, hexagon, SoftLayer(thickness=0.003), sensor_noise(), True)
    assert len(rows) >= 3
    for r in rows:
        vals = [r["map_s"], r["press_s_per_point"], r["threshold_err_pct_max"], r["loc_noise_free_err_mm_max"]]
        assert np.isfinite(vals).all() and r["map_s"] > 0 and r["points"] >= 2, r
        # the maps are a shortcut of the same physics: close to the solves, but measured, not the same model
        assert r["threshold_err_pct_max"] < 20 and r["loc_noise_free_err_mm_max"] < 0.5, r
