"""Issue 28: scene values at the extremes, one-line errors and warnings, NaN in outputs.

Each test rebuilds one failure the issue lists: a scene value whose size reached numpy or a solver
unchecked, a multi-line error, Python's own warning lines, a non-finite output array. The contract
of docs/inputs.md: exit 2 with exactly one ``vtcore: error:`` line naming the file and key.
"""

from __future__ import annotations


import numpy as np
import pytest

from test_inputs_extremes import SCENES, one_error, run

# ----------------------------------------------------------------------------- scenes at the extremes
def test_sampling_rate_of_1e308_is_one_error_naming_the_key(tmp_path):
    """Found: ``--set effects.sampling.rate=1e308`` on the demo raised ValueError in sample_clock."""
    rc, _, err = run("run", SCENES / "demo.toml", "--set", "effects.sampling.rate=1e308", "--out", tmp_path / "o")
    one_error(rc, err, "demo.toml: effects.sampling.rate", "VTCORE_MEMORY_BUDGET")
    assert not (tmp_path / "o").exists()


def test_sample_clock_refuses_more_ticks_than_the_budget(monkeypatch):
    from vtcore.contact.sensor import sample_clock
    from vtcore.errors import InputError

    f, t = np.zeros((3, 4)), np.array([0.0, 1.0, 2.0])
    with pytest.raises(InputError, match="rate: .* samples"):
        sample_clock(f, t, 1e308)
    monkeypatch.setenv("VTCORE_MEMORY_BUDGET", "1M")
    with pytest.raises(InputError, match="rate"):
        sample_clock(f, t, 1e5)
    frames, clock = sample_clock(f, t, 2.0)
    assert frames.shape == (5, 4) and np.allclose(clock, [0, 0.5, 1, 1.5, 2])


def test_layer_thickness_of_1e9_is_one_error_before_allocating(tmp_path):
    """Found: ``--set layer.thickness=1e9`` asked numpy for 6.98 TiB in grid_cells; the budget was
    not consulted there (and the cell count wrapped round in int64)."""
    rc, _, err = run("run", SCENES / "demo.toml", "--set", "layer.thickness=1e9", "--out", tmp_path / "o")
    one_error(rc, err, "demo.toml: layer.thickness")
    assert not (tmp_path / "o").exists()


@pytest.mark.parametrize("span, dx", [(1e9, 1e-3), (0.1, 1e-320), (1e308, 1e-3), (0.1, 1e-6)])
def test_grid_cells_are_counted_before_any_allocation(span, dx):
    from vtcore.contact.grid import grid_cells
    from vtcore.errors import InputError

    with pytest.raises(InputError, match="grid.spacing: .*cells"):
        grid_cells(np.array([-span, -span]), np.array([span, span]), dx)


def test_grid_cells_follow_the_memory_budget(monkeypatch):
    from vtcore.contact.grid import grid_cells
    from vtcore.errors import InputError

    lo, hi = np.array([-0.05, -0.05]), np.array([0.05, 0.05])
    X, _ = grid_cells(lo, hi, 2e-4)  # 500 x 500
    assert X.shape == (500, 500)
    monkeypatch.setenv("VTCORE_MEMORY_BUDGET", "1M")
    with pytest.raises(InputError, match="VTCORE_MEMORY_BUDGET"):
        grid_cells(lo, hi, 2e-4)


def test_reach_clutter_with_a_layer_of_1e308_is_one_error(tmp_path):
    """Found: reach_clutter with the layer's thickness at 1e308 ended in LinAlgError "SVD did not
    converge" in press.py _surface_height."""
    rc, _, err = run("run", SCENES / "reach_clutter.toml", "--set", "layer.thickness=1e308",
                     "--out", tmp_path / "o")
    one_error(rc, err, "reach_clutter.toml: layer.thickness")


@pytest.mark.parametrize("thickness", ["1e308", "1e9"])
def test_validate_with_a_layer_of_1e308_is_one_error(tmp_path, thickness):
    """Found by the issue-28 Done-when check on the scenes written after the issue: the validate scene
    (real CySkin recordings, finger pad conforming to the curved patch) with ``layer.thickness=1e308``
    ended in OverflowError (round of infinity) in calibrate/simulate.py, a traceback to the user."""
    rc, _, err = run("run", SCENES / "validate_cyskin_gesture.toml", "--set", f"layer.thickness={thickness}",
                     "--out", tmp_path / "o")
    one_error(rc, err, "validate_cyskin_gesture.toml: layer.thickness: ", "beyond any skin")
    assert not (tmp_path / "o").exists()


def test_press_on_a_patch_a_kilometre_across_is_finite_or_one_error():
    """The surface fit of the press solver at the far end of the coordinates a layout may have
    (1 km): a clear error naming the key, never LinAlgError or NaN."""
    import trimesh

    from vtcore.contact import SoftLayer, press
    from vtcore.errors import InputError
    from vtcore.layout import Layout

    g = np.linspace(-1, 1, 5)
    xy = np.array([(x, y) for x in g for y in g]) * 1e3
    pos = np.column_stack([xy, 1e-3 * (xy ** 2).sum(axis=1)])
    lay = Layout(pos, np.tile([0, 0, 1.0], (25, 1)), np.arange(25), np.zeros(25, int))
    ball = trimesh.creation.icosphere(2, radius=0.01)
    pose = np.eye(4)
    pose[2, 3] = 0.5
    with pytest.raises(InputError) as exc:
        press(lay, ball, pose, SoftLayer(thickness=3e-3), force=1.0)
    assert exc.value.key, exc.value


# ----------------------------------------------------------------------------- one line, warnings
def test_a_scene_with_several_problems_is_one_error_line(tmp_path):
    """Found: 76 scene errors printed several lines (one per problem) instead of one."""
    rc, _, err = run("run", SCENES / "demo.toml", "--check", "--set", "layer.thickness=-1",
                     "--set", "task.force=-2", "--set", "effects.noise.sigma=-3", "--set", "effects.nosie=1")
    one_error(rc, err, "demo.toml: ", "layer.thickness", "task.force", "4 problems")


def test_details_flag_lists_every_scene_problem(tmp_path):
    rc, _, err = run("run", SCENES / "demo.toml", "--check", "--details", "--set", "layer.thickness=-1",
                     "--set", "task.force=-2", "--set", "effects.noise.sigma=-3", "--set", "effects.nosie=1")
    assert rc == 2
    lines = err.rstrip("\n").split("\n")
    assert lines[0].startswith("vtcore: error: ") and len(lines) == 5, err
    assert all(ln.startswith("  ") for ln in lines[1:]), err


def test_an_error_message_with_line_breaks_is_one_line():
    from vtcore.cli import error_text
    from vtcore.errors import InputError

    text = error_text(InputError("first\nsecond\r\nthird\x1b[31m", key="k"))
    assert text.startswith("vtcore: error: k: first") and "second" in text and "third" in text
    assert "\n" not in text and "\r" not in text and "\x1b" not in text


def test_warnings_inside_a_run_are_vtcore_warning_lines(tmp_path):
    """Found: 5 runs printed Python's own ``RuntimeWarning`` lines. Every warning raised inside a
    run becomes one ``vtcore: warning:`` line naming the scene file and the effect or task."""
    import warnings

    from vtcore.scene.notices import warnings_of

    with warnings_of(SCENES / "demo.toml") as caught:
        with caught.key("effects.noise"):
            np.log(np.zeros(1))
        warnings.warn("plain", UserWarning)
    lines = caught.lines()
    assert lines == [f"{SCENES / 'demo.toml'}: effects.noise: divide by zero encountered in log",
                     f"{SCENES / 'demo.toml'}: task: plain"], lines


# ----------------------------------------------------------------------------- NaN in outputs
def test_undocumented_non_finite_output_arrays_are_reported(tmp_path):
    from vtcore.scene.runner import nonfinite_arrays

    arrays = {"frames": np.array([[1.0, np.nan]]), "force": np.array([1.0, 2.0]),
              "mesh_distance_mm": np.array([np.nan, 1.0]), "edge": np.array([True])}
    assert nonfinite_arrays(arrays, {"mesh_distance_mm": "each run's first tap"}) == {"frames": 1}
    assert nonfinite_arrays(arrays) == {"frames": 1, "mesh_distance_mm": 1}


@pytest.mark.slow
def test_contour_documents_the_nan_of_its_distances(tmp_path):
    """contour_mug_curved wrote NaN into image_distance_mm unmutated: the first tap of each run has no
    distance (seed 002 does not count it) and the arrays stay aligned with the taps. That NaN is
    meaningful: it sits at each run's first tap only, result.json says what it means
    (``arrays_nan``), and no other output array holds a non-finite value."""
    import json

    rc, _, err = run("run", SCENES / "contour_mug_curved.toml", "--set", "task.runs=2", "--set", "task.max_taps=3",
                     "--set", "output.plots=false", "--out", tmp_path / "o")
    assert rc == 0 and "NaN" not in err, err
    result = json.loads((tmp_path / "o" / "result.json").read_text())
    methods = ("mesh", "image", "subtaxel")
    assert set(result["arrays_nan"]) == {f"{m}_distance_mm" for m in methods}
    assert all("first tap" in v for v in result["arrays_nan"].values())
    with np.load(tmp_path / "o" / "arrays.npz") as z:
        for name in z.files:
            a = z[name]
            if name in result["arrays_nan"]:
                run_of = z[name.replace("_distance_mm", "_run")]
                first = np.r_[True, np.diff(run_of) != 0]
                assert np.array_equal(np.isnan(a), first), (name, a, run_of)
            elif a.dtype.kind in "fc":
                assert np.isfinite(a).all(), name


# ----------------------------------------------------------------------------- found by the scene-extremes fuzz
TINY = """
[scene]
name = "tiny"
task = "press"
seed = 1
[end_effector]
shape = "plane"
size = [0.05, 0.05]
[layout]
patch = "triangle"
[layer]
thickness = 0.003
grid_spacing = 0.0015
samples_per_taxel = 3
[[objects]]
kind = "sphere"
radius = 0.01
[task]
force = 2.0
readings = 3
[effects.soft_layer]
[effects.object_compliance]
[effects.gain]
[effects.noise]
[effects.sampling]
rate = 10.0
[output]
plots = false
"""


@pytest.fixture
def tiny(tmp_path):
    p = tmp_path / "tiny.toml"
    p.write_text(TINY)
    return p


@pytest.mark.parametrize("setting, needle", [
    ("layer.grid_spacing=1e308", "layer.grid_spacing: must be <= 0.01 m"),       # 2 * dx overflowed: no cells
    ("effects.sampling.phase=1e308", "effects.sampling.phase: must be <= 3600.0 s"),  # int(-inf)
    ("effects.object_compliance.default_stiffness=5e-324", "default_stiffness: must be >= 1.0 N/m"),  # F / k = inf
    ("objects[0].gap=-1e308", None),  # --set cannot address an array of tables: edited below
    ("effects.gain.p_half=1e308", "effects.gain.p_half: must be <= 1000000000000.0 Pa"),  # overflow in gain
    ("layout.pitch=1e-320", "layout.pitch: must be >= 0.0001 m"),  # every taxel on one point
    ("effects.drift.rate=1e308", "effects.drift.rate: must be <= 1000000000.0"),  # 1e308 counts/s * t = inf
])
def test_values_the_scene_fuzz_found_are_refused_by_name(tiny, tmp_path, setting, needle):
    if needle is None:
        tiny.write_text(TINY.replace("radius = 0.01\n", "radius = 0.01\ngap = -1e308\n"))
        setting, needle = "task.readings=3", "objects[0].gap: must be >= -0.1 m"
    rc, _, err = run("run", tiny, "--set", setting, "--out", tmp_path / "o")
    one_error(rc, err, f"{tiny}: ", needle)
    assert not (tmp_path / "o").exists()


def test_a_sampling_clock_that_never_ticks_is_one_error(tiny, tmp_path):
    """Found: a phase past the run's last frame gave no reading, then IndexError in the press task."""
    rc, _, err = run("run", tiny, "--set", "effects.sampling.phase=1000", "--out", tmp_path / "o")
    one_error(rc, err, f"{tiny}: effects.sampling.phase: 1000 s is past the last frame")


@pytest.mark.parametrize("thickness", ["5e-324", "1e-320", "1e-7"])
def test_a_layer_thinner_than_a_micrometre_is_one_error(tiny, tmp_path, thickness):
    """Found by --fuzz-long (scene extremes): ``layer.thickness=5e-324`` ran to the end with NaN in
    ``arrays.npz`` frames. No elastomer layer is thinner than 1 um: the schema's floor."""
    rc, _, err = run("run", tiny, "--set", f"layer.thickness={thickness}", "--out", tmp_path / "o")
    one_error(rc, err, f"{tiny}: layer.thickness: must be >= 1e-06 m")


def test_a_target_the_physics_cannot_reach_names_the_scene(tiny, tmp_path):
    """An UnreachableTargetError raised inside the run names the scene file (and 'task')."""
    rc, _, err = run("run", tiny, "--set", "task.force=1e4", "--out", tmp_path / "o")
    one_error(rc, err, f"{tiny}: task: ", "bottoms out")


def test_a_warning_of_a_run_is_a_vtcore_warning_line(tiny, tmp_path):
    """Warnings inside a run are ``vtcore: warning: SCENE: KEY: ...`` lines, never Python's own
    ``UserWarning``/``RuntimeWarning`` lines with a source line; result.json and report.md list them."""
    import json

    rc, _, err = run("run", tiny, "--set", "layout.at=[0.0, 0.0, -1.0]", "--out", tmp_path / "o")
    assert rc == 0, err
    lines = err.rstrip("\n").split("\n")
    assert lines and all(ln.startswith(f"vtcore: warning: {tiny}: task: ") for ln in lines), err
    assert "Warning" not in err and "warnings.warn" not in err
    result = json.loads((tmp_path / "o" / "result.json").read_text())
    # the off-surface placement, and (since the sensor's large-deformation warning) the 36 % compression
    assert result["warnings"] and all(w["key"] == "task" for w in result["warnings"])
    assert any("off the surface" in w["message"] for w in result["warnings"]), result["warnings"]
    assert "## Warnings" in (tmp_path / "o" / "report.md").read_text()


@pytest.mark.parametrize("t_end, needle", [
    ("1e308", "would need unbounded memory"),       # was: OverflowError in int(inf)
    ("1e5", "time budget of 3600 s"),                # was: 2 million contact solves, hours
])
def test_a_trajectory_longer_than_the_budgets_is_refused_before_it_starts(tmp_path, t_end, needle):
    scene = tmp_path / "traj.toml"
    scene.write_text(TINY.replace("radius = 0.01\n", "radius = 0.01\n[[objects.keyframes]]\nt = 0.0\n"
                                  f"[[objects.keyframes]]\nt = {t_end}\noffset = [0.0, 0.0, -0.002]\n"))
    rc, _, err = run("run", scene, "--out", tmp_path / "o")
    one_error(rc, err, f"{scene}: task.rate: ", "contact frames", needle)


def test_time_budget_is_a_setting(monkeypatch):
    from vtcore.errors import InputError
    from vtcore.inputs import need_time, time_budget

    assert time_budget() == 3600.0
    need_time(100, 1.0, key="k", what="w")
    monkeypatch.setenv("VTCORE_TIME_BUDGET", "90s")
    with pytest.raises(InputError, match="k: w would take at least 100 s, more than the time budget of 90 s"):
        need_time(100, 1.0, key="k", what="w")
    monkeypatch.setenv("VTCORE_TIME_BUDGET", "2h")
    assert time_budget() == 7200.0
    monkeypatch.setenv("VTCORE_TIME_BUDGET", "soon")
    with pytest.raises(InputError, match="VTCORE_TIME_BUDGET"):
        time_budget()


@pytest.mark.parametrize("setting, needle", [
    ("end_effector.size=[-1e308, 1e308]", "end_effector.size[0]: must be >= 0.001"),  # hung in subdivide_to_size
    ("end_effector.size=[0.05, 1e308]", "end_effector.size[1]: must be <= 100.0"),
    ("end_effector.radius=1e308", "end_effector.radius: must be <= 100.0"),
])
def test_primitive_end_effectors_span_what_a_skin_is_laid_on(tiny, setting, needle):
    """Found by the long scene fuzz: a plane 1e308 m wide hung trimesh's subdivision (its edge lengths
    overflow to infinity). Primitives take the size range of mesh files (1 mm .. 100 m)."""
    rc, _, err = run("run", tiny, "--check", "--set", setting)
    one_error(rc, err, f"{tiny}: ", needle)
