"""The one way a triangle mesh enters vtcore: read, checked, scaled to metres (docs/inputs.md).

Every mesh a user gives (``vtcore layout place MESH --scale S``, a scene's
``end_effector.mesh`` and ``[[objects]]`` meshes, the add-on's Blender objects) goes
through :func:`checked_mesh` before any computation, so a bad one is refused the same
way everywhere, as an :class:`~vtcore.errors.InputError` that states the accepted range:

- at least one triangle; face indices that name existing vertices;
- every vertex finite (checked before anything multiplies or merges them: numpy would
  print a RuntimeWarning first, and trimesh's vertex merge overflows past about 1e300);
- the scale factor finite and > 0 (a negative one mirrors the mesh and turns it inside out);
- the scaled mesh's size (the largest side of its bounding box) within ``size_range``
  and every scaled coordinate within +-:data:`MAX_COORDINATE_M`.

Why a size range: the placement's solvers (heat-method log map, SVD frames, closest-point
ties) use tolerances set for robot parts; below a micrometre the SVD does not converge,
and beyond some hundred metres a placement takes minutes and gigabytes (measured in
docs/inputs.md). A layout surface must be :data:`SURFACE_SIZE_M` (1 mm .. 100 m: a
fingertip to a large machine); pressed objects take the primitives' range
(``vtcore.contact.objects.SIZE_RANGE_M``), passed in by their caller.
"""

from __future__ import annotations

import math

import numpy as np

from ..errors import InputError
from ..inputs import check_input, clean, int_array
from .io import MAX_COORDINATE_M

#: metres: the accepted size (largest bounding-box side) of a surface a skin is laid on
SURFACE_SIZE_M = (1e-3, 100.0)


def _range_text(lo: float, hi: float) -> str:
    return f"{lo:g} m .. {hi:g} m"


def check_scale(scale, key: str = "scale") -> float:
    """``scale`` (metres per mesh unit) as a float after checking it is finite and > 0."""
    try:
        s = float(scale)
    except (TypeError, ValueError, OverflowError):
        raise InputError(f"must be a number (metres per mesh unit), got {clean(repr(scale), 40)}", key=key) from None
    if not (math.isfinite(s) and s > 0):
        raise InputError(f"must be a finite number > 0 (metres per mesh unit; 0.001 for millimetres), got {s:g}"
                         + ("; a negative scale would mirror the mesh inside out" if s < 0 else ""), key=key)
    return s


def checked_mesh(vertices, faces, scale: float = 1.0, *, size_range=SURFACE_SIZE_M, key: str | None = "mesh",
                 scale_key: str = "scale", file=None, process: bool = True):
    """A ``trimesh.Trimesh`` in metres from ``vertices`` (V, 3) in the file's unit, ``faces``
    (F, 3) vertex indices and ``scale`` (metres per file unit), after checking them all.

    size_range : (lo, hi) metres, the accepted largest bounding-box side after scaling.
    key / scale_key / file : what an error names (key None: the file alone). process : let trimesh merge duplicate
    vertices (safe here: the coordinates are finite and bounded by then).
    Raises InputError stating the accepted range; nothing is computed before the checks.
    """
    import trimesh

    where = {"file": None if file is None else clean(file, 300)}
    s = check_scale(scale, scale_key)
    try:
        v = np.asarray(vertices, dtype=np.float64).reshape(-1, 3)
        f = np.asarray(faces).reshape(-1, 3) if np.size(faces) else np.zeros((0, 3), np.int64)
    except (TypeError, ValueError):
        raise InputError("vertices must be (V, 3) numbers and faces (F, 3) vertex indices", key=key,
                         **where) from None
    if not len(f) or not len(v):
        raise InputError("the mesh has no triangles", key=key, **where)
    f = int_array(f, lo=0, hi=len(v) - 1, key=f"{key} faces" if key else "faces", **where)
    if not np.isfinite(v).all():
        bad = int(np.flatnonzero(~np.isfinite(v).all(axis=1))[0])
        raise InputError(f"the mesh has non-finite vertices (vertex {bad} is {clean(v[bad].tolist(), 80)})",
                         key=key, **where)
    # Python floats from here on: a product or difference past 1.8e308 becomes inf, not a numpy warning
    mn, mx = v.min(axis=0), v.max(axis=0)
    reach = max(float(np.abs(mn).max()), float(np.abs(mx).max())) * s
    size = max(float(b) - float(a) for a, b in zip(mn, mx)) * s
    rmin, rmax = size_range
    if not (rmin * (1 - 1e-6) <= size <= rmax * (1 + 1e-6)):  # a mesh of 1 mm in float32 (STL) or other units
        raise InputError(f"the mesh is {size:.3g} m across after scaling by {s:g}; accepted sizes are "
                         f"{_range_text(rmin, rmax)} (check {scale_key}: 0.001 for a mesh in millimetres)",
                         key=key, **where)
    if reach > MAX_COORDINATE_M:
        raise InputError(f"vertex coordinates reach {reach:.3g} m after scaling; accepted within "
                         f"+-{MAX_COORDINATE_M:g} m (move the mesh near its origin)", key=key, **where)
    return trimesh.Trimesh(v * s if s != 1.0 else v, f, process=process, validate=False)


#: numpy's message for text it could not read to its end (np.fromstring: trimesh's text STL and OBJ)
_UNREAD = "string or file could not be read to its end"


def read_trimesh(path):
    """``trimesh.load(path, force="mesh", process=False)`` without pycollada's NumPy 2.5 deprecation
    warning: reading a DAE, pycollada assigns ``.shape`` to its index arrays (not our code to fix),
    and the warning reached users as ``vtcore: warning:`` lines before every result or error.

    A text mesh with stray characters among its numbers raises (ValueError) in every numpy: numpy
    < 2.5 read it up to them with a DeprecationWarning no user sees (and placed on what it read),
    numpy 2.5 raises."""
    import warnings

    import trimesh

    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", message="Setting the shape on a NumPy array", category=DeprecationWarning)
        warnings.filterwarnings("error", _UNREAD, DeprecationWarning)
        try:
            return trimesh.load(path, force="mesh", process=False)
        except DeprecationWarning as exc:  # numpy < 2.5's message says what 2.5 does; 2.5's text
            raise ValueError(str(exc).partition("; this will raise")[0]) from None


def load_mesh(path, scale: float = 1.0, *, size_range=SURFACE_SIZE_M, key: str | None = "mesh",
              scale_key: str = "scale"):
    """Read the mesh file at ``path`` (STL, OBJ, PLY, ... through trimesh) and return it checked
    and scaled to metres by :func:`checked_mesh`. Raises InputError naming the file."""
    check_scale(scale, scale_key)  # before reading: a bad --scale needs no file
    p = check_input(path, "mesh file")  # folders, pipes and devices refused before opening
    try:
        # process=False: trimesh's vertex merge overflows (a RuntimeWarning) on huge coordinates;
        # checked_mesh merges once the vertices are known to be finite and bounded
        mesh = read_trimesh(p)
    except Exception as exc:  # trimesh raises many types for bad files  # noqa: BLE001
        raise InputError(f"cannot read mesh: {clean(exc, 200)}", file=clean(p, 300), key=key) from None
    return checked_mesh(getattr(mesh, "vertices", np.zeros((0, 3))), getattr(mesh, "faces", np.zeros((0, 3))),
                        scale, size_range=size_range, key=key, scale_key=scale_key, file=p)


__all__ = ["SURFACE_SIZE_M", "check_scale", "checked_mesh", "load_mesh", "read_trimesh"]
