"""Calibrated layout files: read and write, one module per format.

Like python-can's ``can.io``: each format module (:mod:`.native`, :mod:`.icub`, :mod:`.cyskin`,
:mod:`.csv`, :mod:`.ply`, :mod:`.mjcf`, :mod:`.urdf`) has ``NAME``, ``SUFFIXES``, ``read(path, units=None) -> Layout``
(``None`` for export-only formats) and ``write(layout, path, **options)``; :data:`FORMAT_MODULES`
maps each name to its module and :func:`load`/:func:`save` dispatch through it.

Formats (``format=`` names):

- ``json``: our own versioned JSON (``"format": "vtcore-layout", "version": 1``):
  positions, normals, taxel and module ids, roles, CAN addresses, frame name and
  4x4 transform (row-major), units, flat coordinates when known, provenance.
- ``icub``: the iCub skinGui positions text (``name``, ``spatial_sampling``,
  ``taxel2Repr ( ... )``, ``[calibration]`` rows ``x y z nx ny nz``, 12 per triangle).
- ``cyskin``: the CySkin calibration JSON (``file_version`` "2"; variants with
  ``skin``, ``tactile_maps`` or both; we write ``info`` + ``skin`` + ``tactile_maps``).
- ``csv``: one taxel a row under a header (``x,y,z`` required; ``nx,ny,nz``,
  ``taxel_id``, ``module_id``, ``u,v``, ``role``, ``can_id`` optional; ``x_mm`` style
  headers declare millimetres).
- ``ply``: vertices with per-taxel attributes, faces of the skin mesh (ASCII written;
  ASCII and binary read).
- ``mjcf``: export only: one MuJoCo site per taxel and a ``touch`` sensor on each, as a
  fragment (see :mod:`.mjcf`; merged into a robot's own MJCF: :mod:`vtcore.robot.mjcf_tree`).
- ``urdf``: export only: one fixed link ``<parent>_vtskin_<n>`` per taxel (see :mod:`.urdf`; merged into
  a robot's own URDF: :mod:`vtcore.robot.urdf_tree`).

Readers are lenient about what real files do (mixed tabs and spaces, CRLF,
scientific notation, non-unit or placeholder normals, repeated positions,
mismatched declared counts): they keep going and warn with
:class:`~vtcore.layout.LayoutWarning`; every warning is also kept in
``layout.meta["import_warnings"]``. A value that cannot be a number (NaN,
text) or a short row is an error that names the file and line.

Units: files without a declared unit are checked: taxels whose median
neighbour spacing exceeds 0.1 "metres" are in millimetres; we convert and warn.
Pass ``units="m"`` or ``units="mm"`` to declare them instead.
"""

from __future__ import annotations

import json
import warnings
from pathlib import Path

import numpy as np

from ...errors import FormatError, InputError, VtError
from ...inputs import check_input, clean, read_bytes
from ..mesh import LayoutWarning
from ..model import Layout, rigid_transform
from . import csv, cyskin, icub, mjcf, native, ply, urdf

# name -> module with read/write (the one table every dispatch goes through)
FORMAT_MODULES = {m.NAME: m for m in (native, icub, cyskin, csv, ply, mjcf, urdf)}
FORMATS = tuple(FORMAT_MODULES)
READ_FORMATS = tuple(n for n, m in FORMAT_MODULES.items() if m.read is not None)
# suffix -> format name when writing; ".json" is ambiguous (ours or CySkin), ours wins on save
SUFFIX_FORMATS = {s: n for n, m in reversed(FORMAT_MODULES.items()) for s in m.SUFFIXES if s}
from .checks import MAX_COORDINATE_M, check_layout


def detect_format(path: Path) -> str:
    """The format of an existing file: from its suffix and, for ``.json``, its content."""
    ext = path.suffix.lower()
    if ext == ".json":
        try:
            data = json.loads(read_bytes(path, "layout file").decode("utf-8", errors="replace"))
        except (OSError, ValueError, RecursionError):
            return native.NAME
        if isinstance(data, dict) and data.get("format") != "vtcore-layout" and (
                "skin" in data or "tactile_maps" in data or "info" in data):
            return cyskin.NAME
        return native.NAME
    if ext == "":
        return icub.NAME
    if ext in SUFFIX_FORMATS:
        return SUFFIX_FORMATS[ext]
    raise InputError(f"cannot tell the layout format of {path.name!r} from its extension; "
                     f"pass format= one of {', '.join(FORMATS)}", file=path)


def load(path, format: str | None = None, *, units: str | None = None) -> Layout:
    """Read a layout file.

    path : file. format : one of ``json, icub, cyskin, csv, ply`` (default: from
    the extension and, for ``.json``, the content). units : ``"m"`` or ``"mm"``
    to declare the file's length unit; by default declared units in the file
    are used, else millimetres are detected (and warned about).
    """
    path = check_input(Path(path), "layout file")  # folders, pipes and devices refused unopened
    fmt = format or detect_format(path)
    if fmt not in READ_FORMATS:
        raise InputError(f"cannot read format {fmt!r}; readable: {', '.join(READ_FORMATS)}", file=path,
                         key="format")
    try:
        with warnings.catch_warnings():
            # overflow or an empty mean inside a reader shows as a non-finite result, refused below
            warnings.simplefilter("ignore", RuntimeWarning)
            with np.errstate(all="ignore"):
                layout = FORMAT_MODULES[fmt].read(path, units=units)
    except VtError:
        raise
    except (ValueError, TypeError, KeyError, IndexError, AttributeError, OverflowError, RecursionError) as exc:
        # the boundary's last line: a value of a type or size a reader did not expect
        raise FormatError(f"not a readable {fmt} layout: {type(exc).__name__}: {clean(exc)}", file=path) from None
    # the backstop of every reader: a Layout with NaN or infinity must not get to a writer (or to the
    # caller's physics); the readers refuse them earlier, naming the line or key
    for key in ("positions", "normals", "transform", "flat"):
        a = getattr(layout, key)
        if a is not None and not np.isfinite(np.asarray(a, dtype=np.float64)).all():
            raise FormatError("holds non-finite values", file=path, key=key)
    if len(layout) and np.abs(layout.positions).max() > MAX_COORDINATE_M:
        raise FormatError(f"must be within +-{MAX_COORDINATE_M:g} m, got "
                          f"{np.abs(layout.positions).max():g} m (wrong units?)", file=path, key="positions")
    check_layout(layout, path)  # a frame, roles and transform every writer can write, whatever the format
    return layout


#: formats written in the parent (the robot link the skin hangs from), not in the layout's frame
IN_PARENT = ("urdf",)


def writes_in_parent(fmt: str, options: dict) -> bool:
    """Whether format ``fmt`` with these writer options writes taxel positions in the layout's
    parent (a URDF) rather than in a frame of its own."""
    return fmt in IN_PARENT


def in_link(layout: Layout, transform, name: str = "") -> Layout:
    """``layout`` with its taxels at ``transform`` in the link it hangs from: ``transform`` (4, 4),
    the pose of the layout's frame in that link, is applied to the taxels (``T p``) and the result's
    own transform is the identity. It takes the place of the layout's own transform (warned about,
    naming the file ``name``, when the two differ). A URDF and a robot export are written so."""
    t = rigid_transform(transform, "transform", MAX_COORDINATE_M)
    own = layout.transform
    layout = layout.transformed(t)
    if not np.allclose(own, np.eye(4), atol=1e-9) and not np.allclose(own, t, atol=1e-9):
        warnings.warn(f"{name}: the given transform replaces the layout's own (the pose of "
                      f"{layout.frame!r} in {layout.parent or 'its parent'!r}): the taxels are written "
                      "at the given pose in the link", LayoutWarning, stacklevel=3)
    layout.transform = np.eye(4)  # T p is already in the link
    check_in_reach(layout)
    return layout


def check_in_reach(layout: Layout) -> None:
    """An InputError when a transform moved the taxels beyond what every layout reader accepts."""
    if len(layout) and np.abs(layout.positions).max() > MAX_COORDINATE_M:
        raise InputError(f"moves taxels {np.abs(layout.positions).max():.3g} m from the origin, beyond the "
                         f"+-{MAX_COORDINATE_M:g} m every layout reader accepts", key="transform")


def save(layout: Layout, path, format: str | None = None, *, transform=None, **options) -> None:
    """Write ``layout`` to ``path`` (written to a temporary file, then renamed).

    format : one of ``json, icub, cyskin, csv, ply, mjcf, urdf`` (default from the
    extension; ``.json`` means our own JSON).
    transform : optional (4, 4) rigid transform ``T``: the pose of the layout's frame in the
        frame the file is written in, so the file's taxels are ``T p`` (``p_file = R p + t``).
        Formats that carry a frame (json, csv, ply, cyskin, the MJCF fragment) also write that
        file frame's pose in the layout's parent (``transform @ inv(T)``), so the skin keeps its
        place there. A URDF is written in the parent link itself: there ``T`` is the pose of the
        layout's frame in that link and takes the place of the layout's own ``transform``
        (:func:`in_link`).
    options : passed to the format's ``write`` (see each format module). A skin merged into a
        robot's own URDF or MJCF (``model=``) is :func:`vtcore.robot.export_skinned`'s.
    """
    path = Path(path)
    fmt = format
    if fmt is None:
        fmt = SUFFIX_FORMATS.get(path.suffix.lower())
        if fmt is None:
            raise InputError(f"cannot tell the format from {path.name!r}; pass format= one of "
                             f"{', '.join(FORMATS)}", file=path)
    if fmt not in FORMAT_MODULES:
        raise InputError(f"unknown format {fmt!r}; use one of {', '.join(FORMATS)}", file=path, key="format")
    if "model" in options:
        raise InputError("a layout file has no robot model: a skin goes into a robot's URDF or MJCF through "
                         "vtcore.robot.export_skinned (vtcore robot export, vtcore layout export --model)",
                         file=path, key="model")
    if transform is not None:
        if writes_in_parent(fmt, options):
            layout = in_link(layout, transform, path.name)
        else:  # the frame's pose in its parent moves the other way: it must stay a transform a reader accepts
            layout = layout.transformed(rigid_transform(transform, "transform", MAX_COORDINATE_M))
            try:
                rigid_transform(layout.transform, "transform", MAX_COORDINATE_M)
            except InputError as exc:
                raise InputError(f"would make the layout's own transform {exc.reason}", key="transform") from None
            check_in_reach(layout)
    FORMAT_MODULES[fmt].write(layout, path, **options)


__all__ = ["IN_PARENT", "writes_in_parent", "in_link", "FORMATS", "READ_FORMATS", "FORMAT_MODULES", "SUFFIX_FORMATS", "detect_format", "load", "save"]
