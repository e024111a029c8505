"""Reaching in clutter with Eqs. 6-7 (seed 000, Sect. 4.3)."""

import numpy as np
import pytest

from vtcore.control.reach import Obstacle, influence_radii, reach
from vtcore.errors import InputError


def test_equation_6():
    np.testing.assert_allclose(influence_radii([1e7, 5e5], 0.07), [0.07, 0.0035])
    with pytest.raises(InputError):
        influence_radii([0.0, 0.0])


def obstacles(pole_colour=1e7, prism_colour=5e5):
    return [Obstacle("pole", "circle", (0.2, 0.03), 0.012, 2e5, pole_colour),
            Obstacle("prism", "box", (0.2, -0.05), (0.03, 0.03), 300.0, prism_colour)]


def test_augmented_avoids_the_stiff_pole_straight_does_not():
    straight = reach((0, 0), (0.4, 0), obstacles(), use_colours=False)
    aug = reach((0, 0), (0.4, 0), obstacles(), use_colours=True)
    assert straight.reached and aug.reached
    assert straight.per_obstacle[:, 0].max() > 1.0                # the straight path hits the pole
    assert aug.per_obstacle[:, 0].max() == 0.0                    # the augmented one never touches it
    assert aug.per_obstacle[:, 1].max() > 0.0                     # ... and pushes through the sponge instead
    assert aug.mean_contact_intensity() < straight.mean_contact_intensity()


def test_equal_colours_treat_obstacles_alike_and_missing_colour_is_an_error():
    r = reach((0, 0), (0.4, 0), obstacles(1e7, 1e7), use_colours=True)
    assert np.all(np.isfinite(r.position))
    with pytest.raises(InputError, match="colour"):
        reach((0, 0), (0.4, 0), obstacles(None), use_colours=True)


def test_box_penetration_inside_and_outside():
    box = Obstacle("b", "box", (0.0, 0.0), (0.01, 0.02), 100.0)
    pen, n = box.penetration(np.array([0.0, 0.025]), 0.01)
    assert pen == pytest.approx(0.005) and np.allclose(n, [0, 1])
    pen, n = box.penetration(np.array([0.008, 0.0]), 0.01)     # centre inside: out through the nearest face
    assert pen == pytest.approx(0.012) and np.allclose(n, [1, 0])
