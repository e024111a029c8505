"""Virtual depth cameras, point-cloud files, colour mapping and PLY output."""

import numpy as np
import pytest

from vtcore.augment import (DepthCamera, colour_map, depth_camera_view, make_seed000_object, read_ply_vertices,
                            read_point_cloud, two_cameras, visual_cloud, write_ply)
from vtcore.errors import FormatError, InputError


@pytest.fixture(scope="module")
def ball():
    return make_seed000_object("tennis_ball")


def test_camera_sees_the_front_with_outward_normals(ball):
    cam = DepthCamera(eye=(0.4, 0.0, 0.0335), target=(0.0, 0.0, 0.0335), width=320, height=240)
    pts, nrm = depth_camera_view(ball.mesh, cam)
    assert len(pts) > 500
    centre = np.array([0, 0, 0.0335])
    r = np.linalg.norm(pts - centre, axis=1)
    np.testing.assert_allclose(r, 0.0335, atol=5e-4)                 # on the sphere
    assert pts[:, 0].min() > -0.005                                   # only the half facing the camera
    radial = (pts - centre) / r[:, None]
    assert np.all(np.einsum("ij,ij->i", nrm, radial) > 0.95)          # normals face out / the camera


def test_two_cameras_merge_and_subsample(ball):
    cams = two_cameras(target=(0, 0, 0.0335), width=320, height=240)
    one, _ = visual_cloud(ball.mesh, cams[:1], rng=0)
    both, nb = visual_cloud(ball.mesh, cams, rng=0)
    assert len(both) > len(one)
    sub, ns = visual_cloud(ball.mesh, cams, n_points=300, rng=0)
    assert sub.shape == ns.shape == (300, 3)
    again, _ = visual_cloud(ball.mesh, cams, n_points=300, rng=0)
    np.testing.assert_array_equal(sub, again)                         # seeded
    with pytest.raises(InputError, match="no camera sees"):
        visual_cloud(ball.mesh, [DepthCamera(eye=(0.4, 0, 0.03), target=(1.0, 0, 0.03), width=32, height=24)])


def test_colour_map_darker_is_stiffer_and_shared():
    rgb = colour_map([0.0, 5e6, 1e7, 2e7, np.nan], 0.0, 1e7)
    lum = rgb[:, :3].astype(float) @ [0.299, 0.587, 0.114]
    assert lum[0] > lum[1] > lum[2]                                   # darker = stiffer
    np.testing.assert_array_equal(rgb[2], rgb[3])                     # clipped to the shared scale
    np.testing.assert_array_equal(rgb[4], [128, 128, 128])            # no information: grey
    assert rgb.dtype == np.uint8
    with pytest.raises(InputError, match="c_min < c_max"):
        colour_map([1.0], 1.0, 1.0)


def test_ply_round_trip_with_scalars_and_rgb(tmp_path):
    rng = np.random.default_rng(0)
    pts = rng.normal(size=(50, 3))
    nrm = pts / np.linalg.norm(pts, axis=1, keepdims=True)
    c = rng.uniform(0, 1e7, 50)
    rgb = colour_map(c, 0, 1e7)
    path = write_ply(tmp_path / "a.ply", pts, normals=nrm, rgb=rgb, scalars={"tactile_color": c, "friction": c * 0},
                     comment="two\nlines")
    back = read_ply_vertices(path)
    np.testing.assert_allclose(np.c_[back["x"], back["y"], back["z"]], pts, rtol=1e-6)
    np.testing.assert_allclose(back["tactile_color"], c, rtol=1e-6)
    np.testing.assert_array_equal(np.c_[back["red"], back["green"], back["blue"]], rgb)
    p2, n2 = read_point_cloud(path)                                   # Open3D reads it too
    np.testing.assert_allclose(p2, pts, rtol=1e-6)
    np.testing.assert_allclose(n2, nrm, rtol=1e-5, atol=1e-6)
    with pytest.raises(InputError):
        write_ply(tmp_path / "b.ply", pts, scalars={"c": c[:3]})
    assert not (tmp_path / "b.ply").exists()                          # nothing half-written


def test_read_point_cloud_estimates_normals_and_handles_pcd_and_errors(tmp_path, ball):
    import open3d as o3d

    pts, _ = visual_cloud(ball.mesh, two_cameras(target=(0, 0, 0.0335), width=120, height=90), rng=0)
    pc = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(pts))
    o3d.io.write_point_cloud(str(tmp_path / "c.pcd"), pc)
    p, n = read_point_cloud(tmp_path / "c.pcd")
    assert len(p) == len(pts)
    radial = (p - [0, 0, 0.0335]) / np.linalg.norm(p - [0, 0, 0.0335], axis=1, keepdims=True)
    assert np.mean(np.einsum("ij,ij->i", n, radial) > 0.9) > 0.95     # estimated, oriented outwards
    (tmp_path / "junk.ply").write_bytes(b"\x00\x01garbage")
    with pytest.raises(FormatError):
        read_point_cloud(tmp_path / "junk.ply")
    with pytest.raises(FormatError, match="not found"):
        read_point_cloud(tmp_path / "missing.ply")
    with pytest.raises(FormatError, match="unsupported"):
        (tmp_path / "c.xyz").write_text("0 0 0\n")
        read_point_cloud(tmp_path / "c.xyz")
    write_ply(tmp_path / "empty.ply", np.empty((0, 3)))
    p, n = read_point_cloud(tmp_path / "empty.ply")
    assert p.shape == (0, 3)
