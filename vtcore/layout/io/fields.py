"""The fields of our layout JSON, each with the check its writers and consumers need.

One declarative table of :class:`vtcore.inputs.Spec` (:data:`DOCUMENT`, :data:`TAXELS`,
:data:`META`): the JSON reader (:mod:`.native`) validates every field it keeps against it, so
what the reader accepts every writer can write (the iCub writer a header line, the MJCF writer
a body name, the PLY writer a face). A new field (a robot file, a link frame) is one line here.
A ``meta`` key that is not in the table is free-form provenance: kept and written back by the
JSON writer, read by nothing else.

The checks that every reader shares (a frame is a name, a role a word, a transform rigid) live in
:mod:`.checks`, whose :func:`~.checks.check_layout` applies them to a Layout whatever file it came from.
"""

from __future__ import annotations

from ...inputs import Spec
from . import cyskin, icub
from .checks import MAX_COORDINATE_M, SIZE_M, line_problem, name_problem, rigid_problem, role_problem, text_problem


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


__all__ = ["DOCUMENT", "META", "PER_TAXEL", "TAXELS", "relation_problems"]
