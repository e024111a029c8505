"""Every module type in the registry against the source it claims, and mirrored modules.

Sources (each test below names the one it checks):

- ``cyskin10``: seeds 001 and 002 (/work/shared/seeds): "capacitive taxels 4 mm in diameter at
  7.5 mm pitch", "6 interconnected triangular modules, each hosting 10 taxels" (seed 001, Fig. 3b),
  arranged as a triangle of 4 per side.
- ``cyskin11``: seed 002 ("each module contains up to 11" taxels) and the CySkin format notes
  (/work/shared/formats/cyskin_calibration.md: "a planar hexagon of 61 taxels in 6 modules"); where
  the 11th taxel sits is our assumption (the hexagon's centre site), stated in vtcore.layout.modules.
- ``icub12``: the old iCub triangle of skinGui, icub-main ``src/tools/iCubSkinGui/src/include/Triangle.h``
  (commit 2258631c): slot offsets ``30 dX - 15, 30 dY - 10 H`` mm from the unit-triangle pattern with
  ``H = sin 60``, ``L = 2 H / 9``; outline ``(-15, -8.66), (15, -8.66), (0, 17.32)``.
- ``icub10``: the current iCub triangle, skinGui's ``triangle_10pad``, icub-main
  ``src/tools/iCubSkinGui/src/include/Triangle_10pad.h`` (commit a829ee36): slot offsets ``dX[i], dY[i]``
  in mils, drawn at 1/40 (outline ``dXv, dYv`` in drawing units), thermal pads drawn at slots 6 and 10,
  mirror ``if (lrMirror==1) x=-x`` before the rotation ``cx + cos th x - sin th y``. The unit is
  confirmed by a second, independent table of the same pads in millimetres (the CDC pad positions
  quoted in matejhof/icub_matej ``transformNominalTriangle.m``: P0 = (6.533, 0) mm ...).
"""

import json

import numpy as np
import pytest
import trimesh
from scipy.spatial import cKDTree

from vtcore.cli import main
from vtcore.layout import MODULES, get_module, load, make_patch
from vtcore.layout.patches import patch_from_poses, tile_poses

MIL_MM = 0.0254


def nn(points):
    d, _ = cKDTree(points).query(points, 2)
    return d[:, 1]


def check_cyskin10(m):
    """Seeds 001/002: 10 taxels of 4 mm at 7.5 mm pitch, a 4-per-side triangle, 6 modules make 60 taxels."""
    assert len(m) == 10 and list(m.sensors) == list(range(1, 11))
    assert m.taxel_diameter == pytest.approx(4e-3)
    np.testing.assert_allclose(nn(m.taxels), 7.5e-3)
    d = np.linalg.norm(m.taxels[:, None] - m.taxels[None], axis=-1)
    assert d.max() == pytest.approx(3 * 7.5e-3)  # side of 3 pitches: 4 taxels a side
    assert len(make_patch("hexagon", m)) == 60  # seed 001's patch


def check_cyskin11(m):
    """Seed 002 (up to 11 taxels) and the format notes (a planar hexagon of 61 taxels in 6 modules)."""
    assert len(m) == 11
    np.testing.assert_allclose(m.taxels[:10], MODULES["cyskin10"].taxels)
    assert len(make_patch("hexagon", m)) == 61


def check_icub12(m):
    """icub-main Triangle.h: the unit pattern scaled by 30 and shifted by (15, 10 H), in mm."""
    H, L = np.sin(np.radians(60)), 2 * np.sin(np.radians(60)) / 9
    dX, dY = np.zeros(12), np.zeros(12)
    dX[5] = L * np.cos(np.radians(30)); dX[4] = 0.5 - dX[5]; dX[2] = 0.5 + dX[5]; dX[1] = 1.0 - dX[5]  # noqa: E702
    dX[6] = 0.25; dX[3] = 0.5; dX[0] = 0.75  # noqa: E702
    dX[7] = 0.25 + dX[5]; dX[11] = 0.75 - dX[5]  # noqa: E702
    dX[8] = dX[7]; dX[10] = dX[11]  # noqa: E702
    dX[9] = 0.5
    dY[5] = L * np.sin(np.radians(30)); dY[4] = dY[5]; dY[2] = dY[5]; dY[1] = dY[5]  # noqa: E702
    dY[6] = 0.5 * H - L; dY[3] = L; dY[0] = dY[6]  # noqa: E702
    dY[7] = 0.5 * H - L * np.sin(np.radians(30)); dY[11] = dY[7]  # noqa: E702
    dY[8] = 0.5 * H + L * np.sin(np.radians(30)); dY[10] = dY[8]  # noqa: E702
    dY[9] = H - L
    np.testing.assert_allclose(m.taxels * 1e3, np.column_stack([30 * dX - 15, 30 * dY - 10 * H]), atol=1e-9)
    np.testing.assert_allclose(m.outline * 1e3, [[-15, -8.66], [15, -8.66], [0, 17.32]], atol=6e-3)
    assert list(m.sensors) == list(range(12)) and m.id_scheme == "icub"
    assert set(np.flatnonzero(m.roles == "thermal")) == {6, 10}


# Triangle_10pad.h, dX[i], dY[i] (mils) in slot order, transcribed from the source
TRIANGLE_10PAD = {8: (-128.62, 222.83), 10: (0, 296.55), 9: (0, 445.54), 11: (128.62, 222.83), 0: (257.2, 0),
                  6: (-256.3, -147.64), 1: (385.83, -222.83), 2: (128.62, -222.83), 3: (0.0, 0.0),
                  4: (-128.62, -222.83), 5: (-385.83, -222.83), 7: (-257.2, 0.0)}
# the same pads in mm (CDC pad positions table, P0..P11)
CDC_PADS_MM = [(6.533, 0), (9.8, -5.66), (3.267, -5.66), (0, 0), (-3.267, -5.66), (-9.8, -5.66), (-6.51, -3.75),
               (-6.533, 0), (-3.267, 5.66), (0, 11.317), (0, 7.507), (3.267, 5.66)]


def check_icub10(m):
    """icub-main Triangle_10pad.h (mils -> mm), cross-checked against the CDC pad table in mm."""
    mil = np.array([TRIANGLE_10PAD[i] for i in range(12)], float)
    np.testing.assert_allclose(m.taxels * 1e3, mil * MIL_MM, atol=1e-9)
    # P10 (a thermal pad) is 7.507 mm in the table and 296.55 mil = 7.532 mm in skinGui: we follow skinGui
    np.testing.assert_allclose(m.taxels * 1e3, CDC_PADS_MM, atol=0.03)
    assert np.all(m.taxels[3] == 0)  # the centre taxel 3 is the module origin
    assert np.linalg.norm(m.taxels[0]) * 1e3 == pytest.approx(6.533, abs=1e-3)
    assert list(m.sensors) == list(range(12)) and m.slots == 12 and m.id_scheme == "icub"
    assert set(np.flatnonzero(m.roles == "thermal")) == {6, 10}  # drawn at half radius in skinGui
    # skinGui's drawn outline: (+-55/4, -32.5/4), (0, 63/4) drawing units of 40 mil
    np.testing.assert_allclose(m.outline * 1e3, np.array([[-55 / 4, -32.5 / 4], [55 / 4, -32.5 / 4], [0, 63 / 4]])
                               * 40 * MIL_MM, atol=1e-9)


SOURCES = {"cyskin10": check_cyskin10, "cyskin11": check_cyskin11, "icub12": check_icub12, "icub10": check_icub10}


def test_every_registered_module_has_a_source_check():
    assert set(MODULES) == set(SOURCES), "a module type was added without a test against its source"


@pytest.mark.parametrize("name", sorted(SOURCES))
def test_module_matches_its_source(name):
    SOURCES[name](MODULES[name])


def skingui_10pad(cx, cy, th_deg, mirror):
    """Triangle_10pad's constructor for one triangle of a skinGui layout (drawing units)."""
    c, s = np.cos(np.radians(th_deg)), np.sin(np.radians(th_deg))
    out = []
    for i in range(12):
        x, y = np.array(TRIANGLE_10PAD[i]) / 40.0
        if mirror == 1:
            x = -x
        out.append((cx + c * x - s * y, cy + s * x + c * y))
    return np.array(out)


@pytest.mark.parametrize("row", [(0, 100.00, -20.00, 30.00, 1), (1, 109.24, -4.00, -30.00, 1),
                                 (16, 100.00, -100.00, -210.00, 0), (25, 164.66, -116.00, -30.00, 0)])
def test_mirrored_triangle_as_skingui_draws_it(row):
    """Rows of icub-main app/skinGui/conf/skinGui/left_forearm_V2.ini (id, x, y, orientation, gain 5, mirror)."""
    _, cx, cy, th, mirror = row
    unit = 40 * MIL_MM * 1e-3  # metres per drawing unit
    p = patch_from_poses(get_module("icub10", mirror=bool(mirror)), [[np.radians(th), cx * unit, cy * unit]])
    np.testing.assert_allclose(p.flat / unit, skingui_10pad(cx, cy, th, mirror), atol=1e-9)
    np.testing.assert_array_equal(p.sensors, np.arange(12))  # slot numbering kept when mirrored


@pytest.mark.parametrize("name", sorted(SOURCES))
def test_mirror_image_tiles_like_the_original(name):
    m, mm = get_module(name), get_module(name, mirror=True)
    assert mm.mirrored and not m.mirrored and mm.name == name
    np.testing.assert_allclose(mm.mirror().taxels, m.taxels)
    np.testing.assert_allclose(mm.taxels[:, 0], -m.taxels[:, 0])
    x, y = mm.outline.T
    assert (x * np.roll(y, -1) - np.roll(x, -1) * y).sum() > 0  # still counter-clockwise
    for kind in ("hexagon", "strip:5"):
        a, b = make_patch(kind, m), make_patch(kind, m, mirror=True)
        assert len(a) == len(b)
        assert nn(b.flat).min() == pytest.approx(nn(a.flat).min())  # no module runs into another
    ta = patch_from_poses(m, tile_poses(m, [-0.04, -0.04], [0.04, 0.04]))
    tb = patch_from_poses(mm, tile_poses(mm, [-0.04, -0.04], [0.04, 0.04]))
    assert len(ta) == len(tb) and nn(tb.flat).min() == pytest.approx(nn(ta.flat).min())


def test_icub10_tiling_keeps_modules_apart():
    p = make_patch("hexagon", "icub10")
    assert len(p) == 72 and (p.roles == "thermal").sum() == 12
    pressure = p.flat[p.roles == "pressure"]
    mods = p.module_ids[p.roles == "pressure"]
    d = np.linalg.norm(pressure[:, None] - pressure[None], axis=-1)
    same = mods[:, None] == mods[None]
    np.fill_diagonal(d, np.inf)
    assert d[same].min() == pytest.approx(6.533e-3, abs=1e-6)  # within a module: the pad pitch
    # across modules: a gap a little wider than the pitch, as skinGui's forearm layout spaces them
    assert 6.533e-3 < d[~same].min() < 1.5 * 6.533e-3


@pytest.fixture(scope="module")
def cylinder(tmp_path_factory):
    d = tmp_path_factory.mktemp("mesh")
    trimesh.creation.cylinder(radius=0.04, height=0.12, sections=96).subdivide_to_size(0.004).export(d / "c.stl")
    return d / "c.stl"


def test_cli_place_mirrored_icub10(cylinder, tmp_path, capsys):
    outs = {}
    for mirror in (False, True):
        out = tmp_path / f"m{int(mirror)}.json"
        assert main(["layout", "place", str(cylinder), "--patch", "triangle", "--module", "icub10",
                     "--at", "0.04", "0", "0", "--direction", "0", "0", "1", "--out", str(out)]
                    + (["--mirror"] if mirror else [])) == 0
        outs[mirror] = load(out)
    a, b = outs[False], outs[True]
    assert b.meta["module_mirror"] is True and a.meta["module_mirror"] is False
    np.testing.assert_array_equal(a.taxel_ids, np.arange(12))
    np.testing.assert_array_equal(b.taxel_ids, np.arange(12))
    # slot 0 lies 6.53 mm from the centre taxel 3 along the patch x axis (+z), on the other side when mirrored
    for lay, sign in ((a, 1), (b, -1)):
        d = lay.positions[0] - lay.positions[3]
        assert d[2] * sign > 6.4e-3
        np.testing.assert_allclose(lay.positions[3], [0.04, 0, 0], atol=1e-4)
    capsys.readouterr()
    assert main(["layout", "info", str(tmp_path / "m1.json"), "--json"]) == 0
    info = json.loads(capsys.readouterr().out)
    assert info["module_type"] == "icub10" and info["roles"] == {"pressure": 10, "thermal": 2}


def test_scene_mirror_key(tmp_path):
    from vtcore.scene.loader import load_scene
    from vtcore.scene.sections.layout import build_layout

    base = ('[scene]\nname = "t"\ntask = "press"\n[[objects]]\nname = "s"\nkind = "sphere"\nradius = 0.01\n'
            '[end_effector]\nshape = "plane"\nsize = [0.1, 0.1]\n[layout]\npatch = "triangle"\nmodule = "icub10"\n')
    lays = []
    for mirror in ("false", "true"):
        f = tmp_path / f"{mirror}.toml"
        f.write_text(base + f"mirror = {mirror}\n")
        lays.append(build_layout(load_scene(f)))
    np.testing.assert_allclose(lays[1].positions[:, 0], -lays[0].positions[:, 0], atol=1e-12)
    assert lays[1].meta["module_mirror"] is True


def test_icub10_positions_file_rows_are_slots(tmp_path):
    """An icub10 layout written as an iCub positions file: row = triangle * 12 + slot (the iCub
    numbering), thermal pads kept at slots 6 and 10, positions back within the file's precision."""
    from vtcore.layout import save

    lay = make_patch("strip:2", "icub10", mirror=True).flat_layout()
    save(lay, tmp_path / "p.txt", "icub")
    back = load(tmp_path / "p.txt", "icub")
    np.testing.assert_array_equal(back.taxel_ids, np.arange(24))
    np.testing.assert_allclose(back.positions, lay.positions, atol=1e-6)
    assert set(np.flatnonzero(back.roles == "thermal")) == {6, 10, 18, 22}
