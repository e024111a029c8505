"""Layout.renumber / Layout.concat (vtcore.layout.model), the add-on's merge and anchor, without bpy."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from vtcore.errors import InputError
from vtcore.layout import Layout, make_patch, seed002_curved
from vtcore.layout.uids import cyskin_modules, cyskin_sensors, cyskin_uids, follows_cyskin
from vtcore.scene import interactive as I


def _flat_layout(kind="triangle", shift=0.0, **kw):
    p = make_patch(kind)
    pos = np.column_stack([p.flat + [shift, 0.0], np.zeros(len(p))])
    return p.to_layout(pos, np.tile([0.0, 0.0, 1.0], (len(p), 1)), **kw)


def test_cyskin_uids_round_trip_and_unknown_modules():
    mods, sens = np.array([0, 0, 5, 4094]), np.array([1, 10, 0, 11])
    uids = cyskin_uids(mods, sens)
    assert uids.tolist() == [17, 26, 96, 4095 * 16 + 11]
    np.testing.assert_array_equal(cyskin_modules(uids), mods)
    np.testing.assert_array_equal(cyskin_sensors(uids), sens)
    assert cyskin_modules([0, -3]).tolist() == [-1, -1]
    assert follows_cyskin(uids, mods) and follows_cyskin([], [])
    assert not follows_cyskin(np.arange(4), mods)  # iCub-style row numbers


def test_renumber_rebuilds_cyskin_ids_and_keeps_everything_else():
    lay = _flat_layout("hexagon")
    lay.can_ids = np.arange(len(lay)) % 7
    lay.module_ids = lay.module_ids * 3 + 10  # gaps: 10, 13, 16, ...
    lay.taxel_ids = cyskin_uids(lay.module_ids, cyskin_sensors(lay.taxel_ids))
    out = lay.renumber(4)
    assert sorted(set(out.module_ids)) == list(range(4, 10))
    np.testing.assert_array_equal(out.taxel_ids, cyskin_uids(out.module_ids, cyskin_sensors(lay.taxel_ids)))
    np.testing.assert_array_equal(out.flat, lay.flat)
    np.testing.assert_array_equal(out.can_ids, lay.can_ids)
    assert out.flat is not lay.flat  # a copy: editing one leaves the other alone
    # iCub-style ids (rows of a positions file) are not CySkin UIDs: kept
    icub = Layout(lay.positions, lay.normals, np.arange(len(lay)) + 100, lay.module_ids)
    np.testing.assert_array_equal(icub.renumber(0).taxel_ids, np.arange(len(lay)) + 100)
    assert len(Layout(np.zeros((0, 3)), np.zeros((0, 3)), [], []).renumber(3)) == 0


def test_concat_keeps_flat_can_ids_and_distinct_modules():
    a, b = _flat_layout("triangle"), _flat_layout("hexagon", shift=0.05)
    a.can_ids = np.full(len(a), 3)
    b.normals_estimated = np.ones(len(b), bool)
    out = Layout.concat([a, b])
    assert len(out) == len(a) + len(b)
    assert set(out.module_ids[:len(a)]) == {0} and set(out.module_ids[len(a):]) == set(range(1, 7))
    assert follows_cyskin(out.taxel_ids, out.module_ids) and len(np.unique(out.taxel_ids)) == len(out)
    np.testing.assert_array_equal(out.flat, np.vstack([a.flat, b.flat]))
    assert out.can_ids.tolist() == [3] * len(a) + [-1] * len(b)
    assert out.normals_estimated.tolist() == [False] * len(a) + [True] * len(b)
    assert out.meta == a.meta and out.frame == a.frame
    # a layout without flat coordinates: the whole has none
    c = Layout(b.positions, b.normals, b.taxel_ids, b.module_ids)
    assert Layout.concat([a, c]).flat is None and Layout.concat([a, c]).normals_estimated is None
    # renumber=False keeps every id (the caller made them distinct)
    same = Layout.concat([a, b], renumber=False)
    np.testing.assert_array_equal(same.module_ids, np.concatenate([a.module_ids, b.module_ids]))
    with pytest.raises(InputError, match="at least one"):
        Layout.concat([])


def test_concat_keeps_non_cyskin_ids_and_empty_layouts_change_nothing():
    a = _flat_layout("triangle")
    icub = Layout(a.positions + 0.1, a.normals, np.arange(len(a)) + 500, np.zeros(len(a)), can_ids=np.arange(len(a)))
    empty = a.subset(np.zeros(len(a), bool))
    out = Layout.concat([empty, a, icub])
    np.testing.assert_array_equal(out.taxel_ids[:len(a)], a.taxel_ids)
    np.testing.assert_array_equal(out.taxel_ids[len(a):], np.arange(len(a)) + 500)
    assert set(out.module_ids[len(a):]) == {1}
    assert out.can_ids.tolist() == [-1] * len(a) + list(range(len(a)))


def test_merge_keeps_can_ids_and_drops_flat_of_two_charts():
    a, b = _flat_layout("hexagon"), _flat_layout("triangle", shift=0.06)
    a.can_ids = np.full(len(a), 0x21)
    alone = I.merge(None, b)
    np.testing.assert_array_equal(alone.flat, b.flat)  # one patch: its unrolling is the skin's
    two = I.merge(a, b)
    assert two.flat is None  # b was unrolled about its own anchor
    assert two.can_ids.tolist() == [0x21] * len(a) + [-1] * len(b)
    assert set(two.module_ids[len(a):]) == {6}


@pytest.fixture(scope="module")
def curved():
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return seed002_curved()[0]


def test_selection_anchor_on_a_curved_selection_lets_the_fill_tile_it(curved):
    """The hard case of the add-on's Fill: a selection over the top and the curved flank.
    Its area-weighted mean lies inside the body, nearest a face outside the selection."""
    mesh = curved
    c, nrm, area = mesh.triangles_center, mesh.face_normals, mesh.area_faces
    region = (c[:, 0] > -0.04) & (nrm[:, 2] > -0.2)
    assert (nrm[region, 2] < 0.5).any() and (nrm[region, 2] > 0.99).any()  # top and flank
    mean = (c[region] * area[region, None]).sum(0) / area[region].sum()
    assert not region[np.argmin(((c - mean) ** 2).sum(1))]  # the old anchor's face is not selected
    at = I.selection_anchor(c, area, region)
    i = np.flatnonzero(region)[np.argmin(((c[region] - mean) ** 2).sum(1))]
    np.testing.assert_array_equal(at, c[i])
    np.testing.assert_array_equal(I.selection_anchor(c, area, np.flatnonzero(region)), at)  # indices too


@pytest.mark.slow
def test_a_fill_from_the_selection_anchor_tiles_the_curved_selection(curved):
    mesh = curved
    c, nrm, area = mesh.triangles_center, mesh.face_normals, mesh.area_faces
    region = (c[:, 0] > -0.04) & (nrm[:, 2] > -0.2)
    at = I.selection_anchor(c, area, region)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        edit = I.lay_patch(mesh.vertices, mesh.faces, at, fill_region=region)
    assert len(edit.layout) >= 50 and edit.report["overlaps"] == 0
    nearest = np.argmin(((edit.layout.positions[:, None, :] - c[None]) ** 2).sum(-1), axis=1)
    assert region[nearest].mean() > 0.95


def test_selection_anchor_bad_input():
    c = np.eye(3)
    with pytest.raises(InputError, match="select at least one face"):
        I.selection_anchor(c, np.ones(3), np.zeros(3, bool))
    with pytest.raises(InputError, match="2 face areas for 3"):
        I.selection_anchor(c, np.ones(2), [0])
    with pytest.raises(InputError, match="a mask of 2 faces for 3"):
        I.selection_anchor(c, np.ones(3), [True, False])
    with pytest.raises(InputError, match="0..2"):
        I.selection_anchor(c, np.ones(3), [3])
    # zero-area faces (degenerate selection) still give a selected centre, not NaN
    np.testing.assert_array_equal(I.selection_anchor(c, np.zeros(3), [1, 2]), c[1])


def test_move_module_keeps_ids_and_can_ids(curved):
    mesh = curved
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        # the hexagon in the middle of the flat top (at its first face it hung over the edge: refused)
        c, top = mesh.triangles_center, mesh.face_normals[:, 2] > 0.99
        at = c[top][np.argmin(np.linalg.norm(c[top] - c[top].mean(0), axis=1))]
        edit = I.lay_patch(mesh.vertices, mesh.faces, at)
        lay = edit.layout
        lay.can_ids = lay.module_ids + 40
        at = lay.positions[lay.module_ids == 2].mean(0) + [0.004, 0.0, 0.0]
        moved = I.move_module(lay, 2, mesh.vertices, mesh.faces, at).layout
    assert len(moved) == len(lay)
    assert moved.flat is None  # the moved module and the rest were unrolled about different points
    m = moved.module_ids == 2
    np.testing.assert_array_equal(np.sort(moved.taxel_ids[m]), np.sort(lay.taxel_ids[lay.module_ids == 2]))
    np.testing.assert_array_equal(moved.can_ids, moved.module_ids + 40)
