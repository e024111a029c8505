"""Issue 28, the tasks that came later (reach, path following, their probes): scene values at the extremes.

Every value that sizes a control loop or an allocation is held to the time and memory budgets before
the work starts (a control period of 1e-320 was ``int(inf)``, 1e-9 a 323 GiB array), sizes outside a
robot's range are refused by the schema, and a position loop the controller cannot integrate is one
error naming the key. The contract of docs/inputs.md: exit 2, one ``vtcore: error:`` line naming the
scene file and key, before the probing starts.
"""

from __future__ import annotations

import pytest

from test_inputs_extremes import SCENES, one_error, run


@pytest.mark.parametrize("setting, key, needle", [
    ("task.dt=1e-320", "task.dt", "control loop(s) of 120 s"),        # was: OverflowError int(inf)
    ("task.dt=1e-9", "task.dt", "control loop(s) of 120 s"),          # was: 1.2e11 steps, no end
    ("task.readings=1000000000", "task.readings", "1000000000 readings x 10 taxels"),  # was: 74.5 GiB array
])
def test_reach_loops_and_readings_are_held_to_the_budgets(tmp_path, setting, key, needle):
    scene = SCENES / "reach_clutter.toml"
    rc, _, err = run("run", scene, "--set", setting, "--out", tmp_path / "o")
    one_error(rc, err, f"{scene}: {key}: ", needle, "budget")
    assert not (tmp_path / "o").exists()


@pytest.mark.parametrize("setting, needle", [
    ("task.skin_length=1e308", "task.skin_length: must be <= 2.0 m"),     # was: int(inf) rings of taxels
    ("task.link_radius=1e308", "task.link_radius: must be <= 2.0 m"),
    ("task.goal=[1e308, 0.0]", "task.goal: must be <= 1000.0 m"),         # was: NaN paths
    ("task.r_max=1e308", "task.r_max: must be <= 1000.0 m"),              # was: overflow in Eq. 6
    ("task.dt=5.0", "task.dt: must be <= 1.0 s"),
])
def test_reach_sizes_outside_a_robots_range_are_refused(setting, needle):
    scene = SCENES / "reach_clutter.toml"
    rc, _, err = run("run", scene, "--check", "--set", setting)
    one_error(rc, err, f"{scene}: {needle}")


@pytest.mark.parametrize("setting, needle", [
    ("task.dt=1e-320", "task.dt: a 0.065 m path"),                        # was: OverflowError int(inf)
    ("task.dt=1e-9", "task.dt: a 0.065 m path"),                          # was: a 323 GiB array
    ("task.speed=1e-320", "task.speed: a 0.065 m path"),                  # was: OverflowError int(inf)
    ("task.readings=1000000000", "task.readings: 1000000000 readings"),
    ("task.omega=1e308", "task.omega: the robot's position loop"),        # was: OverflowError in omega ** 2
    ("task.omega=1000", "task.omega: the robot's position loop"),         # was: inf, then NaN responses
    ("task.zeta=100", "task.omega: the robot's position loop"),
])
def test_path_following_loops_are_held_to_the_budgets_and_stable(tmp_path, setting, needle):
    scene = SCENES / "path_following_bottle.toml"
    rc, _, err = run("run", scene, "--set", setting, "--out", tmp_path / "o")
    one_error(rc, err, f"{scene}: {needle}")
    assert not (tmp_path / "o").exists()


@pytest.mark.parametrize("key, value, needle", [
    ("stations", 10 ** 9, "task.stations: 1000000000 contact solves"),
    ("ring_stations", 1e-320, "task.ring_stations: 27 + inf contact solves"),
])
def test_path_following_contact_solves_are_held_to_the_time_budget(key, value, needle):
    from vtcore.augment.probing import cyskin_module_layout
    from vtcore.errors import InputError
    from vtcore.scene.tasks.path_following import PARAMS, stations

    p = {k: f.default for k, f in PARAMS.fields.items()}
    p[key] = value
    with pytest.raises(InputError) as info:
        stations(p, 0.123, cyskin_module_layout())
    assert needle in f"{info.value.key}: {info.value.reason}", str(info.value)


def test_the_control_library_refuses_what_the_scene_does():
    """The same guards hold for a Python caller of vtcore.control (keys named as the functions call them)."""
    import numpy as np

    from vtcore.control.link_skin import LinkSkin
    from vtcore.control.path_following import ForceController, follow_path
    from vtcore.control.reach import reach
    from vtcore.errors import InputError

    with pytest.raises(InputError, match="unbounded memory") as info:
        reach([0, 0], [0.4, 0], [], controller="impedance", dt=1e-320)
    assert info.value.key == "dt"
    with pytest.raises(InputError, match="must be 0.001 .. 2 m") as info:
        LinkSkin(length=1e308)
    assert info.value.key == "length"
    with pytest.raises(InputError, match="unstable") as info:
        ForceController(omega=1e308)
    assert info.value.key == "omega"
    flat = (lambda x: np.full(len(x), 1e6))
    with pytest.raises(InputError, match="unbounded memory"):
        follow_path([0, 0, 0], [0.065, 0, 0], flat, flat, c_max=2e7, speed=1e-320)
    r = follow_path([0, 0, 0], [0.065, 0, 0], flat, flat, c_max=2e7)   # the defaults run, finite
    assert np.isfinite(r.response).all() and len(r.time) == 21668


# ----------------------------------------------------------------------------- evaluate
@pytest.mark.parametrize("setting, needle", [
    ("task.spacing=1e308", "task.spacing: must be <= 1.0 m"),             # was: OverflowError in spacing ** 2
    ("task.max_separation=1e308", "task.max_separation: must be <= 1.0 m"),  # was: int(inf) separations
    ("task.margin=1e308", "task.margin: must be <= 1.0 m"),
])
def test_evaluate_sizes_past_a_metre_are_refused(setting, needle):
    scene = SCENES / "evaluate_hexagon.toml"
    rc, _, err = run("run", scene, "--check", "--set", setting)
    one_error(rc, err, f"{scene}: {needle}")


def test_evaluate_separations_step_of_1e_320_is_one_error(tmp_path):
    """Found: ``task.two_point_step=1e-320`` made int(inf) separations in two_point.separations."""
    scene = SCENES / "evaluate_hexagon.toml"
    rc, _, err = run("run", scene, "--set", "task.two_point_step=1e-320", "--out", tmp_path / "o")
    one_error(rc, err, f"{scene}: task.two_point_step: ", "more than 1,000")
    assert not (tmp_path / "o").exists()


def test_evaluate_library_counts_before_it_allocates():
    import numpy as np
    import trimesh

    from vtcore.errors import InputError
    from vtcore.evaluate.samples import sample_surface
    from vtcore.evaluate.two_point import separations

    for step, hi in ((1e-320, 0.05), (1e-3, 1e308)):
        with pytest.raises(InputError, match="more than 1,000") as info:
            separations(0.005, step, hi)
        assert info.value.key == "two_point_step"
    assert len(separations(0.005, 1e-3, 0.05)) == 46 and len(separations(0.06, 1e-3, 0.05)) == 0
    box = trimesh.creation.box(extents=[0.05, 0.05, 0.01])
    taxels = np.array([[0.0, 0.0, 0.005], [0.01, 0.0, 0.005]])
    with pytest.raises(InputError, match="exceed 8,000,000") as info:   # was: inf points cast to int64
        sample_surface(box, taxels, spacing=1e-320)
    assert info.value.key == "spacing"
    coarse = sample_surface(box, taxels, spacing=1e308)                  # was: OverflowError
    assert len(coarse.positions) >= 1 and np.isfinite(coarse.positions).all()
