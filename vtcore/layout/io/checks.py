"""The checks every layout reader's result takes, whatever the format (no format module imported here).

A frame is a name, a role a word, a transform rigid within +-1 km, flat coordinates within +-1 km:
:func:`check_layout` applies them in :func:`vtcore.layout.load`; :mod:`.fields` builds the JSON
reader's table from them, and the format modules check what they keep with them.
"""

from __future__ import annotations

import re

import numpy as np

from ...errors import FormatError, InputError
from ...inputs import clean
from ..model import rigid_transform

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
