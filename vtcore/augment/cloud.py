"""Visual point clouds: virtual depth cameras, PLY/PCD reading, PLY writing, colour mapping.

Seed 000 merges the clouds of two Intel RealSense D415 depth cameras into one
partial view of each object (7,863 to 33,676 points). :func:`depth_camera_view`
renders what one pinhole depth camera sees of a mesh by ray casting (Open3D's
Embree-backed ``RaycastingScene``, imported inside the function), with the
surface normals of the hit triangles turned towards the camera and optional
depth noise; :func:`visual_cloud` merges several views.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .._io import atomic_write
from ..errors import FormatError, InputError


@dataclass
class DepthCamera:
    """A pinhole depth camera.

    eye, target : (3,) metres; up : (3,); fov_deg : horizontal field of view
    (D415 depth: ~65 deg); width, height : pixels (D415 modes: 1280x720, 848x480);
    depth_noise : metres, standard deviation along the ray (D415 ~ 0.5 mm at 0.5 m);
    max_range : metres.
    """

    eye: tuple = (0.45, 0.0, 0.15)
    target: tuple = (0.0, 0.0, 0.09)
    up: tuple = (0.0, 0.0, 1.0)
    fov_deg: float = 65.0
    width: int = 848
    height: int = 480
    depth_noise: float = 0.0
    max_range: float = 3.0


def two_cameras(target=(0.0, 0.0, 0.09), distance: float = 0.45, azimuth_deg: float = 35.0,
                elevation: float = 0.12, **kw) -> list[DepthCamera]:
    """Two cameras facing the object from +x, ``azimuth_deg`` either side (the paper's two D415s)."""
    t = np.asarray(target, float)
    out = []
    for a in (-azimuth_deg, azimuth_deg):
        r = np.radians(a)
        eye = t + [distance * np.cos(r), distance * np.sin(r), elevation]
        out.append(DepthCamera(eye=tuple(eye), target=tuple(t), **kw))
    return out


def depth_camera_view(mesh, camera: DepthCamera, rng=None):
    """What ``camera`` sees of ``mesh``: ``(points (P, 3) metres, normals (P, 3) unit)``.

    Normals are the hit triangles' normals turned to face the camera (a depth
    camera sees only front faces). ``rng`` seeds the depth noise.
    """
    import open3d as o3d

    v = np.asarray(mesh.vertices, dtype=np.float32)
    f = np.asarray(mesh.faces, dtype=np.uint32)
    scene = o3d.t.geometry.RaycastingScene()
    scene.add_triangles(o3d.core.Tensor(v), o3d.core.Tensor(f))
    rays = scene.create_rays_pinhole(fov_deg=float(camera.fov_deg), center=list(map(float, camera.target)),
                                     eye=list(map(float, camera.eye)), up=list(map(float, camera.up)),
                                     width_px=int(camera.width), height_px=int(camera.height))
    hit = scene.cast_rays(rays)
    t = hit["t_hit"].numpy().reshape(-1).astype(np.float64)
    r = rays.numpy().reshape(-1, 6).astype(np.float64)
    ok = np.isfinite(t) & (t < camera.max_range)
    origin, direction = r[ok, :3], r[ok, 3:]
    dn = np.linalg.norm(direction, axis=1, keepdims=True)
    direction = direction / dn
    depth = t[ok] * dn[:, 0]
    if camera.depth_noise > 0:
        depth = depth + np.random.default_rng(rng).normal(0.0, camera.depth_noise, len(depth))
    pts = origin + depth[:, None] * direction
    nrm = hit["primitive_normals"].numpy().reshape(-1, 3)[ok].astype(np.float64)
    nrm /= np.linalg.norm(nrm, axis=1, keepdims=True)
    flip = np.einsum("ij,ij->i", nrm, direction) > 0
    nrm[flip] *= -1.0
    return pts, nrm


def visual_cloud(mesh, cameras, n_points: int | None = None, rng=None):
    """Merged partial view of ``mesh`` from ``cameras``: ``(points (K, 3), normals (K, 3))``.

    n_points : if set and the merged cloud is larger, a seeded random subset of
    exactly that many points (a stand-in for the paper's merged-and-filtered
    clouds). Raises InputError if no camera sees the object.
    """
    rng = np.random.default_rng(rng)
    views = [depth_camera_view(mesh, c, rng) for c in cameras]
    pts = np.concatenate([v[0] for v in views]) if views else np.empty((0, 3))
    nrm = np.concatenate([v[1] for v in views]) if views else np.empty((0, 3))
    if len(pts) == 0:
        raise InputError("no camera sees the object: check the camera poses and field of view", key="cameras")
    if n_points is not None and len(pts) > n_points:
        keep = np.sort(rng.choice(len(pts), int(n_points), replace=False))
        pts, nrm = pts[keep], nrm[keep]
    return pts, nrm


def read_point_cloud(path, estimate_normals: bool = True, knn: int = 30):
    """Read a PLY or PCD point cloud with Open3D: ``(points (K, 3), normals (K, 3) or None)``.

    Normals come from the file, else (``estimate_normals``) from a k-nearest
    plane fit (Open3D, Hoppe et al.; the paper's ref. [32]) oriented towards
    the cloud's outside (away from its centroid). Coordinates are returned as
    stored: pass ``scale`` to the propagation if they are not metres.
    """
    import open3d as o3d

    path = Path(path)
    if not path.exists():
        raise FormatError("point cloud file not found", file=path)
    if path.suffix.lower() not in (".ply", ".pcd"):
        raise FormatError(f"unsupported point cloud type {path.suffix!r}; use .ply or .pcd", file=path)
    pc = o3d.io.read_point_cloud(str(path))
    pts = np.asarray(pc.points, dtype=np.float64)
    if len(pts) == 0:
        # Open3D returns an empty cloud (with a printed warning) for unreadable files too
        head = path.read_bytes()[:3]
        if head not in (b"ply", b"# .", b"VER", b"FIE") and not head.startswith(b"#"):
            raise FormatError("not a PLY/PCD file Open3D can read", file=path)
        return pts.reshape(0, 3), np.empty((0, 3))
    if pc.has_normals():
        nrm = np.asarray(pc.normals, dtype=np.float64)
    elif estimate_normals and len(pts) >= 3:
        pc.estimate_normals(o3d.geometry.KDTreeSearchParamKNN(knn=min(knn, len(pts))))
        nrm = np.asarray(pc.normals, dtype=np.float64).copy()
        out = np.einsum("ij,ij->i", nrm, pts - pts.mean(axis=0)) < 0
        nrm[out] *= -1
    else:
        nrm = None
    return pts, nrm


# ---------------------------------------------------------------------------
# colours
# ---------------------------------------------------------------------------

def colour_map(values, c_min: float, c_max: float, cmap: str = "viridis_r", nan_rgb=(128, 128, 128)) -> np.ndarray:
    """Linear map of tactile colours to RGB on a scale shared by all objects.

    values : (M,) float. c_min, c_max : the ends of the shared scale (values
    outside are clipped). cmap : a matplotlib colormap; the default
    ``viridis_r`` is light (yellow) for compliant and dark (purple) for stiff,
    as in seed 000's Fig. 7 ("darker colours are related to stiffer areas").
    Returns (M, 3) uint8; NaN values (no touch yet) get ``nan_rgb``.
    """
    import matplotlib

    if not (np.isfinite(c_min) and np.isfinite(c_max) and c_max > c_min):
        raise InputError(f"the colour scale needs finite c_min < c_max, got c_min={c_min}, c_max={c_max}",
                         key="c_max")
    v = np.asarray(values, dtype=np.float64).reshape(-1)
    t = np.clip((v - c_min) / (c_max - c_min), 0.0, 1.0)
    nan = ~np.isfinite(v)
    t[nan] = 0.0
    rgb = (np.asarray(matplotlib.colormaps[cmap](t))[:, :3] * 255.0 + 0.5).astype(np.uint8)
    rgb[nan] = nan_rgb
    return rgb


# ---------------------------------------------------------------------------
# PLY
# ---------------------------------------------------------------------------

def write_ply(path, points, *, normals=None, rgb=None, scalars: dict | None = None, comment: str = "") -> Path:
    """Write a binary little-endian PLY point cloud, atomically.

    points : (M, 3) float, metres (stored as float32). normals : (M, 3) or None.
    rgb : (M, 3) uint8 or None (``red green blue``, read by MeshLab, CloudCompare,
    Open3D, Blender). scalars : name -> (M,) float, written as float32 vertex
    properties (e.g. ``tactile_color``; CloudCompare shows them as scalar fields).
    Open3D cannot write extra properties, hence this small writer.
    """
    p = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    m = len(p)
    cols = [("x", "<f4", p[:, 0]), ("y", "<f4", p[:, 1]), ("z", "<f4", p[:, 2])]
    if normals is not None:
        n = np.asarray(normals, dtype=np.float64).reshape(-1, 3)
        cols += [("nx", "<f4", n[:, 0]), ("ny", "<f4", n[:, 1]), ("nz", "<f4", n[:, 2])]
    if rgb is not None:
        c = np.asarray(rgb).reshape(-1, 3)
        if c.dtype != np.uint8:
            raise InputError(f"must be uint8 (M, 3), got {c.dtype}", key="rgb")
        cols += [("red", "u1", c[:, 0]), ("green", "u1", c[:, 1]), ("blue", "u1", c[:, 2])]
    for name, arr in (scalars or {}).items():
        if not name.isidentifier():
            raise InputError(f"PLY property names must be identifiers, got {name!r}", key="scalars")
        cols.append((name, "<f4", np.asarray(arr, dtype=np.float64).reshape(-1)))
    for name, _, arr in cols:
        if len(arr) != m:
            raise InputError(f"has {len(arr)} rows but points has {m}", key=name)
    rec = np.empty(m, dtype=[(n, t) for n, t, _ in cols])
    for name, _, arr in cols:
        rec[name] = arr
    types = {"<f4": "float", "u1": "uchar"}
    header = ["ply", "format binary_little_endian 1.0"]
    if comment:
        header += [f"comment {line}" for line in comment.splitlines()]
    header += [f"element vertex {m}"] + [f"property {types[t]} {n}" for n, t, _ in cols] + ["end_header"]
    path = Path(path)
    with atomic_write(path, "wb") as fh:
        fh.write(("\n".join(header) + "\n").encode("ascii"))
        fh.write(rec.tobytes())
    return path


_PLY_TYPES = {"float": "f4", "float32": "f4", "double": "f8", "float64": "f8", "uchar": "u1", "uint8": "u1",
              "char": "i1", "int8": "i1", "ushort": "u2", "uint16": "u2", "short": "i2", "int16": "i2",
              "uint": "u4", "uint32": "u4", "int": "i4", "int32": "i4"}


def read_ply_vertices(path) -> dict[str, np.ndarray]:
    """All vertex properties of a PLY file (ascii or binary, vertex element first): name -> (M,) array.

    The counterpart of :func:`write_ply`, keeping the scalar fields Open3D drops.
    """
    path = Path(path)
    raw = path.read_bytes()
    end = raw.find(b"end_header")
    if not raw.startswith(b"ply") or end < 0:
        raise FormatError("not a PLY file (no 'ply' magic or no end_header)", file=path, line=1)
    nl = raw.find(b"\n", end)
    header = raw[:nl].decode("ascii", "replace").splitlines()
    body = raw[nl + 1:]
    fmt, count, props, in_vertex = None, None, [], False
    for i, line in enumerate(header, start=1):
        w = line.split()
        if not w:
            continue
        if w[0] == "format":
            fmt = w[1]
        elif w[0] == "element":
            if count is not None and in_vertex:
                in_vertex = False
                break
            in_vertex = w[1] == "vertex"
            if in_vertex:
                count = int(w[2])
        elif w[0] == "property" and in_vertex:
            if w[1] == "list":
                raise FormatError("list properties in the vertex element are not supported", file=path, line=i)
            if w[1] not in _PLY_TYPES:
                raise FormatError(f"unknown property type {w[1]!r}", file=path, line=i)
            props.append((w[2], _PLY_TYPES[w[1]]))
    if count is None:
        raise FormatError("no vertex element", file=path)
    if fmt == "ascii":
        rows = np.loadtxt(body.decode("ascii").splitlines()[:count], ndmin=2) if count else np.empty((0, len(props)))
        return {n: rows[:, j].astype(t) for j, (n, t) in enumerate(props)}
    order = {"binary_little_endian": "<", "binary_big_endian": ">"}.get(fmt)
    if order is None:
        raise FormatError(f"unknown PLY format {fmt!r}", file=path)
    dt = np.dtype([(n, order + t) for n, t in props])
    if len(body) < dt.itemsize * count:
        raise FormatError(f"truncated: {count} vertices need {dt.itemsize * count} bytes, file has {len(body)}",
                          file=path)
    rec = np.frombuffer(body, dtype=dt, count=count)
    return {n: rec[n].copy() for n, _ in props}
