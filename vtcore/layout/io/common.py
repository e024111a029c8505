"""Shared by the layout readers and writers: the import report, units, normals, numbers."""

from __future__ import annotations

import hashlib
import math
import warnings

import numpy as np

from ...errors import FormatError, InputError
from ...inputs import clean, read_text
from ...tolerances import ZERO_NORMAL
from ..mesh import LayoutWarning, nn_spacing, estimate_normals
from ..model import Layout

MM_SPACING = 0.1  # m: no skin has taxels 10 cm apart; such spacing means millimetres


class ImportReport:
    """Collects import warnings, emits each as a LayoutWarning once."""

    def __init__(self, path):
        self.path = str(path)
        self.items: list[str] = []

    def warn(self, msg: str, line: int | None = None):
        where = f"{self.path}:{line}" if line is not None else self.path
        text = f"{where}: {msg}"
        self.items.append(text)
        warnings.warn(text, LayoutWarning, stacklevel=3)


def units_scale(positions: np.ndarray, units: str | None, report: ImportReport, declared: str | None = None) -> float:
    """Scale to metres: declared units win; else millimetres are detected from the spacing."""
    u = units or declared
    if u is not None:
        if u not in ("m", "mm"):
            raise InputError(f"units must be 'm' or 'mm', got {u!r}", file=report.path, key="units")
        if u == "m" and len(positions) > 1 and np.median(nn_spacing(positions)) > MM_SPACING:
            report.warn(f"declared in metres but the median taxel spacing is "
                        f"{np.median(nn_spacing(positions)):.3g} m; is it millimetres?")
        return 1e-3 if u == "mm" else 1.0
    if len(positions) > 1:
        s = float(np.median(nn_spacing(positions)))
        if s > MM_SPACING:
            report.warn(f"median taxel spacing {s:.4g} would be {s:.4g} m: read as millimetres and "
                        f"converted to metres (declare units='m' or 'mm' to decide yourself)")
            return 1e-3
    return 1.0


def clean_normals(normals: np.ndarray, positions: np.ndarray, report: ImportReport, what: str = "normal"
                  ) -> tuple[np.ndarray, np.ndarray]:
    """Unit normals (N, 3) and the (N,) bool mask of the ones estimated.

    Zero normals (the file has none) are estimated from the neighbours and flagged;
    non-unit ones are normalised (warned); ones already unit to 1e-12 are kept bit for
    bit, so a layout read back from our own files has the same digests (:func:`row_digests`).
    """
    normals = np.array(normals, dtype=np.float64)
    if not np.isfinite(normals).all():  # a reader checks first, naming the line; this is the backstop
        raise FormatError(f"{what} of taxel {int(np.flatnonzero(~np.isfinite(normals).all(1))[0])} is not finite",
                          file=report.path)
    # |n| through the largest component: a normal of 1e308s is a direction, but its plain norm
    # overflows to inf and n / inf would be a zero (or NaN) normal
    big = np.abs(normals).max(axis=1) if len(normals) else np.zeros(0)
    scaled = normals / np.where(big > 0, big, 1.0)[:, None]
    snorm = np.linalg.norm(scaled, axis=1)
    with np.errstate(over="ignore"):
        norm = big * snorm  # inf past 1.8e308: only shown, never divided by
    zero = norm < ZERO_NORMAL
    off = ~zero & (np.abs(norm - 1) > 1e-3)
    if off.any():
        report.warn(f"{int(off.sum())} {what}s are not unit length (norm {_length(norm[off].min())}-"
                    f"{_length(norm[off].max())}); normalised")
    rescale = ~zero & (np.abs(norm - 1) > 1e-12)
    normals[rescale] = scaled[rescale] / snorm[rescale, None]
    if zero.any():
        if len(positions) >= 3:
            est = estimate_normals(positions, reference=np.where(zero[:, None], 0.0, normals)
                                   if (~zero).any() else None)
            normals[zero] = est[zero]
        else:
            normals[zero] = [0.0, 0.0, 1.0]
        report.warn(f"{int(zero.sum())} taxels have no {what} (all zeros); estimated from their neighbours "
                    "(layout.normals_estimated; written back as zeros unless asked to estimate)")
    if len(normals) > 3 and len(np.unique(np.round(normals, 9), axis=0)) == 1:
        c = positions - positions.mean(axis=0)
        if np.linalg.svd(c, compute_uv=False)[2] > 1e-3 * np.linalg.svd(c, compute_uv=False)[0]:
            report.warn(f"every {what} is {normals[0].round(6).tolist()} on a non-planar layout: "
                        "placeholder normals? kept as given")
    return normals, zero


def _length(v: float) -> str:
    return f"{v:.3g}" if math.isfinite(v) else "above 1.8e308"


def finite_rows(a: np.ndarray, path, key: str) -> np.ndarray:
    """``a`` (N, k) float, refused (naming the file, ``key`` and the first bad row) when it holds
    NaN or infinity; checked before any warning about its values is given."""
    bad = ~np.isfinite(a).reshape(len(a), -1).all(axis=1)
    if bad.any():
        raise FormatError(f"row {int(np.flatnonzero(bad)[0])} is not finite (NaN or infinity)", file=path, key=key)
    return a


def transform_of(values, path, key: str, *, line: int | None = None, column_major: bool = False) -> np.ndarray:
    """A file's 4x4 transform (16 numbers, row-major unless ``column_major``) as a finite (4, 4) float
    array; anything else is a FormatError naming the file and ``key`` (or ``line``)."""
    try:
        a = np.asarray(values, dtype=np.float64)
    except (TypeError, ValueError, OverflowError):
        raise FormatError("must be 16 numbers (a 4x4 matrix)", file=path, key=key, line=line) from None
    if a.size != 16 or a.ndim not in (1, 2) or (a.ndim == 2 and a.shape != (4, 4)):
        raise FormatError(f"must be 16 numbers (a 4x4 matrix), got shape {a.shape}", file=path, key=key, line=line)
    if not np.isfinite(a).all():
        k = int(np.flatnonzero(~np.isfinite(a.ravel()))[0])
        raise FormatError(f"number {k} is {a.ravel()[k]}, not finite", file=path, key=key, line=line)
    a = a.reshape(4, 4)
    return a.T.copy() if column_major else a


def check_repeats(positions: np.ndarray, report: ImportReport):
    from ..mesh import find_duplicates
    from .checks import MAX_COORDINATE_M

    if len(positions) and not np.abs(positions).max() <= 1e3 * MAX_COORDINATE_M:
        return  # (the bound in mm) io.load refuses such a layout by name; a k-d tree overflows on 1e308
    rep = find_duplicates(positions, 1e-7)
    k = int((rep != np.arange(len(positions))).sum())
    if k:
        report.warn(f"{k} taxels repeat another taxel's position (kept; skin_mesh merges them)")


def parse_number(token: str, path, line: int, what: str) -> float:
    try:
        v = float(token)
    except ValueError:
        raise FormatError(f"{what}: {token!r} is not a number", file=path, line=line) from None
    if not math.isfinite(v):
        raise FormatError(f"{what}: {token!r} is not a finite number", file=path, line=line)
    return v


def parse_integer(token: str, path, line: int, what: str) -> int:
    """An integer token, exactly: ``9223372036854775807`` read through a float is 2**63, past int64."""
    try:
        v = int(token)
    except ValueError:
        f = parse_number(token, path, line, what)
        if f != math.floor(f):
            raise FormatError(f"{what}: {token!r} is not an integer", file=path, line=line) from None
        v = int(f)
    if not -2**63 <= v < 2**63:
        raise FormatError(f"{what}: {clean(token, 40)} lies outside 64-bit integers", file=path, line=line)
    return v


def finish(layout: Layout, report: ImportReport, path, fmt: str) -> Layout:
    layout.meta.setdefault("source", str(path))
    layout.meta["source_format"] = fmt
    if report.items:
        layout.meta["import_warnings"] = list(report.items)
    return layout


def as_list(x):
    return None if x is None else np.asarray(x).tolist()


def default_faces(layout: Layout) -> np.ndarray:
    """The faces a file read from had (``meta["faces"]``, kept for a lossless round trip), else the
    layout's skin mesh triangles."""
    f = layout.meta.get("faces")
    if f is not None:
        f = np.asarray(f, dtype=np.int64).reshape(-1, 3)
        if not len(f) or (f.min() >= 0 and f.max() < len(layout)):
            return f
    from ..mesh import skin_mesh

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", LayoutWarning)
        return skin_mesh(layout).triangles if len(layout) >= 3 else np.zeros((0, 3), np.int64)


def taxel_labels(layout: Layout) -> np.ndarray:
    """(N,) int: the number that names each taxel's frame or site (``<parent>_skin_<n>``):
    its taxel id when the ids are unique and non-negative, else its row."""
    ids = layout.taxel_ids
    if len(ids) and ids.min() >= 0 and len(np.unique(ids)) == len(ids):
        return ids
    return np.arange(len(layout))


def identifier(name: str) -> str:
    """``name`` as a name every robot format and tool takes: letters, digits and ``_`` only
    (spaces, slashes, dots and the rest become ``_``; a leading digit gets a ``_`` before it).
    MJCF and URDF accept more, but ROS tf, MuJoCo's name lookups in scripts and iCub's
    skinManager configs break on spaces and slashes."""
    import re

    out = re.sub(r"[^A-Za-z0-9_]", "_", str(name)) or "_"
    return "_" + out if out[0].isdigit() else out


def skin_prefix(link: str, prefix: str | None = None) -> str:
    """The name prefix of a skin's taxel frames or sites on ``link``: ``prefix`` as given (it must
    already be an identifier), else ``<link>_vtskin_`` (``vtskin``, not ``skin``: robot models such
    as iCub's already carry ``<link>_skin_<n>`` frames of their own skin)."""
    if prefix is None:
        return identifier(f"{link}_vtskin_")
    if identifier(prefix) != prefix:
        raise InputError(f"{prefix!r} is not a valid name prefix (letters, digits and _ only; e.g. "
                         f"{identifier(prefix)!r})", key="--prefix")
    return prefix


def row_digests(layout: Layout) -> list[str]:
    """One short hash per taxel row of its position and normal (float64 bits).

    A reader stores them with the file's own text of each row; a writer of the same
    format writes a row's text as read when its digest still matches (the row was not
    moved, transformed or re-estimated), and formats it afresh otherwise. That is what
    makes import then export byte-for-byte on the number tables, through our JSON too.
    """
    a = np.ascontiguousarray(np.column_stack([layout.positions, layout.normals]), dtype="<f8")
    return [hashlib.blake2b(r.tobytes(), digest_size=8).hexdigest() for r in a]


def unchanged_rows(layout: Layout, digests) -> np.ndarray:
    """(N,) bool: rows whose position and normal are still what the reader produced."""
    out = np.zeros(len(layout), bool)
    if not digests:
        return out
    now = row_digests(layout)
    m = min(len(now), len(digests))
    out[:m] = [a == b for a, b in zip(now[:m], digests[:m])]
    return out


def array_digest(a: np.ndarray) -> str:
    """Hash of an array's float64 bits (has a transform, the ids or the flat map changed since reading?)."""
    return hashlib.blake2b(np.ascontiguousarray(a, dtype="<f8").tobytes(), digest_size=8).hexdigest()


def number(v: float) -> str:
    """The shortest text that reads back as exactly ``v`` (Python's float repr; ints as ints)."""
    v = float(v)
    if v == 0:
        return "-0" if math.copysign(1.0, v) < 0 else "0"
    return str(int(v)) if v.is_integer() and abs(v) < 1e15 else repr(v)


def read_json_doc(path):
    """The parsed JSON of ``path``; a syntax error is a FormatError naming the file and line."""
    import json
    from pathlib import Path

    try:
        return json.loads(read_text(Path(path), "JSON file"))
    except json.JSONDecodeError as exc:
        raise FormatError(f"not valid JSON: {exc.msg}", file=path, line=exc.lineno) from None
    except RecursionError:  # [[[[... nested past Python's stack
        raise FormatError("not valid JSON: nested too deeply", file=path) from None


