"""Reaching in clutter with Eqs. 6-7 (seed 000, Sect. 4.3): the Eq. 7 speed bug, the reactive and
impedance baselines, the link's skin in counts."""

import numpy as np
import pytest

from vtcore.control.link_skin import LinkSkin
from vtcore.control.reach import Obstacle, influence_radii, reach
from vtcore.errors import InputError


def test_equation_6():
    np.testing.assert_allclose(influence_radii([1e7, 5e5], 0.07), [0.07, 0.0035])
    with pytest.raises(InputError):
        influence_radii([0.0, 0.0])


def obstacles(pole_colour=1e7, prism_colour=5e5, pole_y=0.03):
    return [Obstacle("pole", "circle", (0.2, pole_y), 0.012, 2e5, pole_colour),
            Obstacle("prism", "box", (0.2, -0.05), (0.03, 0.03), 300.0, prism_colour)]


def test_eq7_turns_the_motion_and_never_speeds_it_up():
    """The bug of issue 30: Eq. 7's deviation was added as extra velocity (as large as the nominal
    speed), so near the pole the robot moved faster than nominal. Now it turns the motion only: with
    the pole within its Eq. 6 radius but out of reach, the augmented run never touches anything, moves
    at exactly the nominal speed, takes a longer path than the reactive run (the same controller
    without Eq. 7, a straight line here) and needs exactly that much more time."""
    clear = [Obstacle("pole", "circle", (0.2, 0.045), 0.012, 2e5, 1e7)]    # 45 mm off the line, eps 70 mm
    speed, dt = 0.02, 0.01
    aug = reach((0, 0), (0.4, 0), clear, controller="augmented", speed=speed, dt=dt, rng=0)
    base = reach((0, 0), (0.4, 0), clear, controller="reactive", speed=speed, dt=dt, rng=0)
    assert aug.reached and base.reached and aug.force.max() == base.force.max() == 0.0
    steps = np.hypot(*np.diff(np.vstack([[0, 0], aug.position]), axis=0).T) / dt
    np.testing.assert_allclose(steps[:-1], speed, rtol=1e-9)            # nominal, never more
    assert np.abs(aug.position[:, 1]).max() > 0.008                     # Eq. 7 moved the path ...
    assert np.abs(base.position[:, 1]).max() < 1e-12                    # ... which is straight without it
    assert aug.path_length() > base.path_length() + 0.002
    assert aug.time_to_target == pytest.approx(aug.path_length() / speed, abs=2 * dt)
    assert base.time_to_target == pytest.approx((0.4 - 0.003) / speed, abs=2 * dt)   # 3 mm: the arrival tolerance


@pytest.mark.parametrize("controller", ["augmented", "reactive", "impedance", "straight"])
def test_commanded_speed_never_exceeds_nominal_in_clutter(controller):
    r = reach((0, 0), (0.4, 0), obstacles(), controller=controller, speed=0.02, rng=1)
    assert r.reached and r.speed_cmd.max() <= 0.02 * (1 + 1e-12)
    assert r.time_to_target >= (0.4 - 0.003) / 0.02 - 0.01              # nobody arrives early


def test_augmented_avoids_the_pole_when_its_reactive_layer_accepts_the_sponge():
    """With the reactive threshold above what the sponge presses on the skin, the augmented run goes
    round the pole through the sponge; the reactive and impedance runs hit the pole."""
    skin = LinkSkin()
    kw = dict(skin=skin, react_threshold=skin.compression_counts(0.3), react_full=skin.compression_counts(0.6))
    runs = {c: reach((0, 0), (0.4, 0), obstacles(), controller=c, rng=0, **kw)
            for c in ("augmented", "reactive", "impedance")}
    assert all(r.reached for r in runs.values())
    assert runs["augmented"].per_obstacle[:, 0].max() == 0.0 and runs["augmented"].per_obstacle[:, 1].max() > 1.0
    assert runs["reactive"].per_obstacle[:, 0].max() > 1.0 and runs["impedance"].per_obstacle[:, 0].max() > 1.0
    assert runs["augmented"].mean_contact_intensity() > 0


def test_equal_colours_missing_colour_and_bad_controller():
    r = reach((0, 0), (0.4, 0), obstacles(1e7, 1e7), controller="augmented")
    assert np.all(np.isfinite(r.position))
    with pytest.raises(InputError, match="colour"):
        reach((0, 0), (0.4, 0), obstacles(None), controller="augmented")
    with pytest.raises(InputError, match="unknown controller"):
        reach((0, 0), (0.4, 0), obstacles(), controller="teleport")


def test_box_penetration_inside_outside_and_corner():
    box = Obstacle("b", "box", (0.0, 0.0), (0.01, 0.02), 100.0)
    pen, n, r = box.penetration(np.array([0.0, 0.025]), 0.01)
    assert pen == pytest.approx(0.005) and np.allclose(n, [0, 1]) and np.isinf(r)
    pen, n, r = box.penetration(np.array([0.008, 0.0]), 0.01)     # centre inside: out through the nearest face
    assert pen == pytest.approx(0.012) and np.allclose(n, [1, 0])
    pen, n, r = box.penetration(np.array([0.015, 0.025]), 0.01)   # beyond a corner: a small radius
    assert pen > 0 and np.isfinite(r) and np.allclose(n, np.array([0.005, 0.005]) / np.hypot(0.005, 0.005))


def test_skin_contact_law_between_its_limits():
    skin = LinkSkin(noise=0.0)
    soft = skin.law(300.0, np.inf)                         # a sponge: the obstacle takes the overlap
    f = soft.force(0.01)
    assert f == pytest.approx(300.0 * (0.01 - soft.compression(0.01)), rel=1e-3)   # the series split
    assert 0.95 * 300.0 * 0.01 < f < 300.0 * 0.01                               # mostly the sponge
    rigid = skin.law(1e12, 0.012)                          # a metal pole: the layer takes it (F = C d^1.5)
    d = 5e-4
    c = skin.winkler * skin.length * 4 / 3 * np.sqrt(2 * rigid.r_eff)
    assert rigid.force(d) == pytest.approx(c * d ** 1.5, rel=1e-3)
    assert rigid.compression(d) == pytest.approx(d, rel=1e-3)
    assert soft.force(-1e-3) == 0.0 and np.isnan(rigid.force(skin.thickness))   # past the layer: the caller says so


def test_skin_reads_contacts_in_counts():
    skin = LinkSkin()
    rng = np.random.default_rng(0)
    idle = skin.read(np.zeros(len(skin.angles)), rng)
    assert idle.min() == 0 and skin.intensity(idle) == 0.0 and skin.contacts(idle) == []   # noise is not contact
    up, down = (np.pi / 2, 5e-4, 0.008), (-np.pi / 2, 3e-4, 0.025)
    ring = skin.counts([up, down])
    assert ring.max() <= skin.max_counts and ring.argmax() == np.argmin(np.abs(skin.angles - np.pi / 2))
    frame = skin.read(ring, rng)
    found = sorted(skin.contacts(frame), key=lambda c: c[0][1])
    assert len(found) == 2                                 # opposite contacts do not cancel
    np.testing.assert_allclose(found[0][0], [0, -1], atol=0.1)   # within a taxel pitch (17 deg)
    np.testing.assert_allclose(found[1][0], [0, 1], atol=0.1)
    assert skin.intensity(frame) == pytest.approx(skin.rows * ring[ring > 900].sum(), rel=0.05)
