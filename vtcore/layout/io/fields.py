"""The fields of our layout JSON, each with the check its writers and consumers need.

One declarative table of :class:`vtcore.inputs.Spec` (:data:`DOCUMENT`, :data:`TAXELS`,
:data:`META`): the JSON reader (:mod:`.native`) validates every field it keeps against it, so
what the reader accepts every writer can write (the iCub writer a header line, the MJCF writer
a body name, the PLY writer a face). A new field (a robot file, a link frame) is one line here.
A ``meta`` key that is not in the table is free-form provenance: kept and written back by the
JSON writer, read by nothing else.

The checks that every reader shares (a frame is a name, a role a word, a transform rigid) are
the functions :func:`name_problem`, :func:`role_problem` and :func:`rigid_problem`;
:func:`check_layout` applies them to a Layout whatever file it came from.
"""

from __future__ import annotations

import re

import numpy as np

from ...errors import FormatError, InputError
from ...inputs import Spec, clean
from ..model import rigid_transform
from . import cyskin, icub

#: Largest |coordinate| of a taxel (and of its flat map, and of a transform's translation), metres:
#: a skin larger than a kilometre is a unit or file error.
MAX_COORDINATE_M = 1e3
#: Longest frame or module name; robot link names are tens of characters.
MAX_NAME_CHARS = 256
#: A module pitch (``meta.pitch_m``), a taxel disc (``meta.taxel_radius_m``): a micrometre to a metre.
SIZE_M = (1e-6, 1.0)

_CONTROL = re.compile(r"[\x00-\x1f\x7f-\x9f\u2028\u2029\ufeff\ufffe\uffff\ud800-\udfff]")
_ROLE = re.compile(r"[A-Za-z0-9_.+-]{1,64}")


def text_problem(v: str) -> str | None:
    """Free text written into a file's line or attribute: no control characters (no line breaks)."""
    m = _CONTROL.search(v)
    if m:
        return f"holds a control character ({clean(m.group())}) at {m.start()}; names and texts are one line"
    return None


def name_problem(v: str) -> str | None:
    """A frame or element name every writer can write: non-empty, one line, at most 256 characters."""
    if not v.strip():
        return "must not be empty (the name of the frame the positions are in)"
    if len(v) > MAX_NAME_CHARS:
        return f"must be at most {MAX_NAME_CHARS} characters, got {len(v)}"
    return text_problem(v)


def role_problem(v: str) -> str | None:
    """A taxel role (``pressure``, ``thermal``): a word, as the CSV and PLY writers need it."""
    if not _ROLE.fullmatch(v):
        return f"must be a word of letters, digits and _ . + - (at most 64), got {clean(repr(v), 40)}"
    return None


def line_problem(v: str) -> str | None:
    if "\n" in v or "\r" in v:
        return "holds a line break; each entry is one line of the file"
    return None


def rigid_problem(t) -> str | None:
    """Why ``t`` is not a rigid 4x4 transform within +-1 km (:func:`vtcore.layout.model.rigid_transform`), or None."""
    try:
        rigid_transform(t, "transform", MAX_COORDINATE_M)
    except InputError as exc:
        return exc.reason
    return None


def _strs(each=None, required=False) -> Spec:
    return Spec("strs", required=required, each=each)


#: The top level of the document (``format`` and ``version`` are checked first, by the reader).
DOCUMENT: dict[str, Spec] = {
    "version": Spec("int", required=False, lo=0),
    "units": Spec("str", required=False, choices=("m", "mm")),
    "frame": Spec("str", required=False, default="end_effector", check=name_problem),
    # the link the frame sits in (the transform is the frame's pose there); "" or null: unnamed
    "parent": Spec("str", required=False, check=lambda v: name_problem(v) if v else None),
    "transform": Spec("floats", required=False, shape=(4, 4), check=rigid_problem),
    "n_taxels": Spec("int", required=False, lo=0),
}

#: ``taxels``: one row per taxel (every list has the positions' length, checked by the reader).
TAXELS: dict[str, Spec] = {
    "positions": Spec("floats", shape=(None, 3)),
    "normals": Spec("floats", shape=(None, 3)),
    "taxel_ids": Spec("ints", required=False, shape=(None,)),
    "module_ids": Spec("ints", required=False, shape=(None,)),
    "roles": _strs(role_problem),
    "flat": Spec("floats", required=False, shape=(None, 2), lo=-MAX_COORDINATE_M, hi=MAX_COORDINATE_M),
    "can_ids": Spec("ints", required=False, shape=(None,)),
    "normals_estimated": Spec("bools", required=False),
}

#: ``meta``: the entries a writer or a consumer reads, with what it needs of them.
META: dict[str, Spec] = {
    # provenance, shown or written as text
    "name": Spec("str", required=False, check=text_problem),
    "source": Spec("str", required=False),
    "source_format": Spec("str", required=False),
    "mesh": Spec("str", required=False),
    "end_effector": Spec("str", required=False, check=text_problem),
    "import_warnings": _strs(),
    "module": Spec("str", required=False),
    "module_type": Spec("str", required=False),
    "module_mirror": Spec("bool", required=False),
    "id_scheme": Spec("str", required=False),
    # sizes the MJCF writer and `layout info` use
    "pitch_m": Spec("float", required=False, lo=SIZE_M[0], hi=SIZE_M[1]),
    "taxel_radius_m": Spec("float", required=False, lo=SIZE_M[0], hi=SIZE_M[1]),
    "placement": Spec("dict", required=False),
    # the faces a file was read with (PLY, CySkin): indices of taxels (stale ones fall back to the skin mesh)
    "faces": Spec("ints", required=False, shape=(None, 3), lo=0),
    # the contour and edge tasks' reference point x_R (seed 002)
    "reference_taxel": Spec("int", required=False, lo=0),
    "reference_point": Spec("floats", required=False, shape=(3,), lo=-MAX_COORDINATE_M, hi=MAX_COORDINATE_M),
    # iCub positions file, as read (io/icub.py writes it back line for line)
    "icub_rows": Spec("int", required=False, lo=0, hi=icub.MAX_ROWS),
    "taxel2Repr": Spec("ints", required=False, shape=(None,)),
    "spatial_sampling": Spec("str", required=False, check=text_problem),
    "icub_header": Spec("dict", required=False),
    "icub_names": _strs(line_problem),
    "icub_header_lines": _strs(icub.header_line_problem),
    "icub_row_text": _strs(icub.row_problem),
    "icub_units": Spec("str", required=False, choices=("m", "mm")),
    "icub_digests": _strs(),
    "icub_boards": Spec("ints", required=False, shape=(None,), lo=0, hi=15),
    # CySkin calibration JSON, as read (io/cyskin.py writes it back)
    "info": Spec("dict", required=False),
    "cyskin_doc": Spec("dict", required=False, check=cyskin.doc_problem),
    "cyskin_units": Spec("str", required=False, choices=("m", "mm")),
    "cyskin_digests": _strs(),
    "cyskin_transform": Spec("str", required=False),
    "cyskin_flat": Spec("str", required=False),
    "cyskin_ids": Spec("str", required=False),
}

#: Per-taxel lists that must have one entry per position.
PER_TAXEL = ("normals", "taxel_ids", "module_ids", "roles", "flat", "can_ids", "normals_estimated")


def relation_problems(taxels: dict, meta: dict, n: int):
    """``(key, reason)`` of the first rule between fields that is broken, or None."""
    for k in PER_TAXEL:
        v = taxels.get(k)
        if v is not None and len(v) != n:
            return f"taxels.{k}", f"has {len(v)} entries for {n} positions"
    rows, text = meta.get("icub_rows"), meta.get("icub_row_text")
    if rows is not None and text is not None and rows != len(text):
        return "meta.icub_rows", f"is {rows} but meta.icub_row_text has {len(text)} rows"
    ref = meta.get("reference_taxel")
    if ref is not None and ref >= n:
        return "meta.reference_taxel", f"must be a taxel index 0..{n - 1}, got {ref}"
    return None


def check_layout(layout, path) -> None:
    """The checks every reader's Layout takes before a writer can see it (FormatError naming the file):
    the frame (and the parent, where there is one) is a name, each role a word, the transform rigid, flat coordinates within +-1 km."""
    for key in ("frame", "parent"):
        v = getattr(layout, key, None)
        if key == "parent" and not v:
            continue
        msg = name_problem(v) if isinstance(v, str) else f"must be a string, got {type(v).__name__}"
        if msg:
            raise FormatError(msg, file=path, key=key)
    bad = [k for k, r in enumerate(layout.roles) if not isinstance(r, str) or role_problem(r)]
    if bad:
        r = layout.roles[bad[0]]
        why = role_problem(r) if isinstance(r, str) else f"must be a string, got {type(r).__name__}"
        raise FormatError(f"taxel {bad[0]}: {why}", file=path, key="roles")
    t = np.asarray(layout.transform, dtype=np.float64)
    if np.isfinite(t).all():
        msg = rigid_problem(t)
        if msg:
            raise FormatError(msg, file=path, key="transform")
    if layout.flat is not None and len(layout.flat) and np.isfinite(layout.flat).all() \
            and np.abs(layout.flat).max() > MAX_COORDINATE_M:
        raise FormatError(f"flat coordinates must be within +-{MAX_COORDINATE_M:g} m, got "
                          f"{np.abs(layout.flat).max():.3g} m (wrong units?)", file=path, key="flat")
