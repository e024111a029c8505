"""The :class:`Layout`: where the taxels of a skin are, and who they are."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..errors import InputError


@dataclass
class Layout:
    """A skin layout: one row per taxel.

    positions : (N, 3) float, metres, in the end-effector (or ``frame``) frame.
    normals : (N, 3) float, unit outward normals.
    taxel_ids : (N,) int, taxel UID (CySkin: ``module_uid << 4 | sensor``; iCub: row index).
    module_ids : (N,) int, the module each taxel belongs to.
    flat : (N, 2) float, metres, or None: coordinates in the flat (unrolled) patch
        domain when known, the natural domain for triangulation and tactile images.
    roles : (N,) str, "pressure" unless a module type says otherwise ("thermal").
    frame : str, the name of the frame the positions are expressed in (a robot link, a patch
        frame, or a mesh's own coordinates).
    transform : (4, 4) float, the pose of ``frame`` in its parent: ``p_parent = R p + t``
        (identity by default: the frame is its own parent, e.g. a skin born on a robot link).
    parent : str or None: the name of the frame ``transform`` places ``frame`` in (a CySkin
        ``parent_frames`` name, a robot link); None when unnamed or the same as ``frame``.
    meta : free-form provenance (source file, module type, patch, placement report).
    can_ids : (N,) int or None, the CAN address that carries each taxel (iCub:
        ``board_address << 4 | triangle``; CySkin: the hub's module address), -1 unknown.
    normals_estimated : (N,) bool or None: True where the normal was estimated (the file had
        none) rather than read; writers of lossless formats write those rows as they were read.
    """

    positions: np.ndarray
    normals: np.ndarray
    taxel_ids: np.ndarray
    module_ids: np.ndarray
    flat: np.ndarray | None = None
    roles: np.ndarray | None = None
    frame: str = "end_effector"
    transform: np.ndarray = field(default_factory=lambda: np.eye(4))
    meta: dict = field(default_factory=dict)
    can_ids: np.ndarray | None = None
    normals_estimated: np.ndarray | None = None
    parent: str | None = None

    def __post_init__(self):
        self.positions = np.ascontiguousarray(self.positions, dtype=np.float64).reshape(-1, 3)
        n = len(self.positions)
        self.normals = np.ascontiguousarray(self.normals, dtype=np.float64).reshape(-1, 3)
        self.taxel_ids = np.asarray(self.taxel_ids, dtype=np.int64).reshape(-1)
        self.module_ids = np.asarray(self.module_ids, dtype=np.int64).reshape(-1)
        if self.flat is not None:
            self.flat = np.ascontiguousarray(self.flat, dtype=np.float64).reshape(-1, 2)
        if self.roles is None:
            self.roles = np.full(n, "pressure", dtype=object)
        else:
            self.roles = np.asarray(self.roles, dtype=object).reshape(-1)
        self.transform = np.asarray(self.transform, dtype=np.float64).reshape(4, 4)
        if self.can_ids is not None:
            self.can_ids = np.asarray(self.can_ids, dtype=np.int64).reshape(-1)
        if self.normals_estimated is not None:
            self.normals_estimated = np.asarray(self.normals_estimated, dtype=bool).reshape(-1)
        optional = tuple(k for k in ("flat", "can_ids", "normals_estimated") if getattr(self, k) is not None)
        for name in ("normals", "taxel_ids", "module_ids", "roles") + optional:
            if len(getattr(self, name)) != n:
                raise InputError(f"has {len(getattr(self, name))} rows but positions has {n}", key=name)
        if not np.all(np.isfinite(self.positions)):
            bad = int(np.flatnonzero(~np.isfinite(self.positions).all(axis=1))[0])
            raise InputError(f"taxel {bad} has a non-finite position", key="positions")

    def __len__(self) -> int:
        return len(self.positions)

    @property
    def n_modules(self) -> int:
        return len(np.unique(self.module_ids))

    def subset(self, index) -> "Layout":
        """The layout restricted to ``index`` (a boolean mask or integer indices)."""
        idx = index if isinstance(index, slice) else np.asarray(index)
        return Layout(self.positions[idx], self.normals[idx], self.taxel_ids[idx], self.module_ids[idx],
                      None if self.flat is None else self.flat[idx], self.roles[idx], self.frame,
                      self.transform.copy(), dict(self.meta),
                      None if self.can_ids is None else self.can_ids[idx],
                      None if self.normals_estimated is None else self.normals_estimated[idx], self.parent)

    def transformed(self, matrix: np.ndarray, frame: str | None = None) -> "Layout":
        """Positions and normals mapped by the 4x4 rigid ``matrix`` (p' = R p + t).

        The result's ``transform`` is this layout's transform times ``inv(matrix)``,
        so the taxels keep their place in the parent frame.
        """
        m = np.asarray(matrix, dtype=np.float64).reshape(4, 4)
        r, t = m[:3, :3], m[:3, 3]
        out = self.subset(slice(None))
        out.positions = self.positions @ r.T + t
        out.normals = self.normals @ r.T
        out.frame = frame or self.frame
        out.transform = self.transform @ np.linalg.inv(m)
        return out

    def posed(self, transform, parent: str | None = None) -> "Layout":
        """The same taxels (positions unchanged, still in ``frame``) with ``transform`` as the
        pose of ``frame`` in ``parent`` (the frame's declared place, e.g. the visual origin of
        the mesh a skin was laid on, in its robot link). ``parent`` None keeps the current one."""
        out = self.subset(slice(None))
        out.transform = rigid_transform(transform, "transform")
        out.parent = parent if parent is not None else self.parent
        return out

    def in_parent(self) -> "Layout":
        """The taxels re-expressed in the parent frame: positions ``R p + t``, normals ``R n``,
        transform identity, ``frame`` the parent's name (the parent becomes the frame)."""
        if self.parent is None and not np.allclose(self.transform, np.eye(4)):
            raise InputError("the layout's transform places it in an unnamed parent: name the parent "
                             "(reframe --parent NAME) before expressing the taxels in it", key="parent")
        out = self.transformed(self.transform, frame=self.parent or self.frame)
        out.transform = np.eye(4)  # exactly: transform @ inv(transform) rounds
        out.parent = None
        return out

    def renumber(self, first_module: int = 0) -> "Layout":
        """The layout with its modules numbered ``first_module``, ``first_module + 1``, ...

        Modules keep their order (by current id). Taxel ids that are CySkin UIDs of
        their modules (:func:`vtcore.layout.uids.follows_cyskin`) are rebuilt for the
        new module ids with the same sensor numbers; any other ids (iCub rows, a file's
        own numbering) are kept as they are. ``flat``, ``can_ids``, roles and the rest
        are kept.
        """
        from .uids import cyskin_sensors, cyskin_uids, follows_cyskin

        out = self.subset(slice(None))
        if len(out) == 0:
            return out
        _, rank = np.unique(self.module_ids, return_inverse=True)
        out.module_ids = rank.astype(np.int64) + int(first_module)
        if follows_cyskin(self.taxel_ids, self.module_ids):
            out.taxel_ids = cyskin_uids(out.module_ids, cyskin_sensors(self.taxel_ids))
        return out

    @classmethod
    def concat(cls, layouts, *, renumber: bool = True) -> "Layout":
        """The taxels of ``layouts`` one after another, as one layout.

        The first layout keeps its module ids; with ``renumber`` each following one is
        renumbered (:meth:`renumber`) to start after the largest module id before it, so
        module ids stay distinct (CySkin taxel ids follow; other ids are kept); without,
        every id is kept as it is (the caller knows they are distinct). Positions are taken
        to be in the first layout's frame: its ``frame``, ``transform`` and ``meta`` are
        the result's. ``flat`` is kept when every layout has it (the coordinates are
        concatenated as they are: meaningful in one chart, e.g. pieces of one unrolled
        layout); ``can_ids`` and ``normals_estimated`` are kept when any layout has them,
        -1 (unknown) and False for the taxels of those that do not.
        """
        layouts = list(layouts)
        if not layouts:
            raise InputError("concat needs at least one layout", key="layouts")
        parts, top = [], None
        for lay in layouts:
            if renumber and top is not None and len(lay):
                lay = lay.renumber(top + 1)
            parts.append(lay)
            if len(lay):
                top = int(lay.module_ids.max()) if top is None else max(top, int(lay.module_ids.max()))

        def joined(name, fill):
            if all(getattr(p, name) is None for p in parts):
                return None
            return np.concatenate([getattr(p, name) if getattr(p, name) is not None else np.full(len(p), fill)
                                   for p in parts])

        first = layouts[0]
        flat = np.vstack([p.flat for p in parts]) if all(p.flat is not None for p in parts) else None
        return cls(np.vstack([p.positions for p in parts]), np.vstack([p.normals for p in parts]),
                   np.concatenate([p.taxel_ids for p in parts]), np.concatenate([p.module_ids for p in parts]),
                   flat, np.concatenate([p.roles for p in parts]), first.frame, first.transform.copy(),
                   dict(first.meta), joined("can_ids", -1), joined("normals_estimated", False), first.parent)


def rigid_transform(matrix, key: str = "transform", max_translation: float | None = None) -> np.ndarray:
    """``matrix`` as a (4, 4) float64 rigid transform (rotation with determinant +1, bottom row
    0 0 0 1), or an InputError naming ``key``; translations beyond ``max_translation`` metres refused."""
    t = np.asarray(matrix, dtype=np.float64)
    if t.shape != (4, 4) or not np.isfinite(t).all():
        raise InputError("must be a finite 4x4 matrix", key=key)
    r = t[:3, :3]
    if not np.allclose(r @ r.T, np.eye(3), atol=1e-4) or not np.allclose(t[3], [0, 0, 0, 1]) \
            or np.linalg.det(r) < 0:  # a mirror keeps r r^T = I but turns the skin inside out
        raise InputError("must be rigid (a rotation: orthonormal, determinant +1; bottom row 0 0 0 1)", key=key)
    if max_translation is not None and np.abs(t[:3, 3]).max() > max_translation:
        raise InputError(f"translation must be within +-{max_translation:g} m, got "
                         f"{np.abs(t[:3, 3]).max():.3g} m", key=key)
    return t
