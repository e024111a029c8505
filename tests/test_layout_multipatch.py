"""Several patches on one skin: overlaps against modules already placed, long CAD faces,
no bridging skin-mesh edges between patches, deterministic placement."""

import warnings

import numpy as np
import pytest
import trimesh
from scipy.spatial.distance import cdist

from vtcore.layout import Layout, LayoutWarning, fill, make_patch, place, seed002_curved, skin_mesh
from vtcore.layout.conform import OVERLAP_FRACTION, find_overlaps

PITCH = 7.5e-3
R = 0.03


@pytest.fixture(scope="module")
def cad_cylinder():
    # a CAD-style cylinder: 96 sections, side faces 200 mm long from cap to cap
    return trimesh.creation.cylinder(radius=R, height=0.2, sections=96)


def quiet(fn, *a, **k):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", LayoutWarning)
        return fn(*a, **k)


def test_long_cad_faces_are_kept_when_cropping(cad_cylinder):
    """The crop round 'at' kept only faces with a vertex within reach, so the long side faces of a
    CAD cylinder were dropped and 56 of 60 taxels fell 'off the boundary' onto 37 positions."""
    lay, rep = quiet(place, cad_cylinder, "hexagon", (R, 0, 0), (0, 1, 0))
    assert len(rep.off_boundary) == 0
    assert len(np.unique(lay.positions.round(7), axis=0)) == 60
    assert np.abs(np.hypot(*lay.positions[:, :2].T) - R).max() < 1e-4
    assert rep.strain_max < 0.01
