"""Read an MJCF robot through MuJoCo's own compiler (``mujoco.MjModel.from_xml_path``).

MuJoCo resolves what an MJCF reader must get right and we should not redo: ``<include>``,
``meshdir``/``assetdir``, default classes, ``childclass``, mesh ``scale`` and its re-centring
of every mesh at its centroid (compensated in the geom's pose). We read the compiled model:
bodies are links, hinge and slide joints are joints (ball and free joints are held at the
model's reference pose), geoms are geometry: colliding ones (``contype`` or ``conaffinity``
non-zero) collision, the rest visual. Mesh vertices come as MuJoCo compiled them, already in
metres and in the geom's frame. Joint values are MuJoCo's ``qpos`` minus the reference ``qpos0``.

Bad input is one error (docs/inputs.md): the file is read as UTF-8 first (:func:`.model.read_xml`),
names are decoded safely (an ``<include>``d file MuJoCo reads itself), every number taken from the
compiled model is finite and within +-1 km, and MuJoCo's own warnings are collected
(:func:`mujoco_messages`), never printed by C onto the terminal.
"""

from __future__ import annotations

import contextlib
import warnings
from pathlib import Path

import numpy as np

from ..errors import FormatError, InputError
from .model import MAX_EXTENT_M, Geometry, Joint, Link, Robot, clean_numbers, read_xml

NAME = "mjcf"
_PRIMITIVES = {2: "sphere", 3: "capsule", 5: "cylinder", 6: "box"}
_MESH = 7


def _pose(pos, quat) -> np.ndarray:
    from scipy.spatial.transform import Rotation

    m = np.eye(4)
    w, x, y, z = quat
    m[:3, :3] = Rotation.from_quat([x, y, z, w]).as_matrix()
    m[:3, 3] = pos
    return m


class MujocoWarning(UserWarning):
    """A message MuJoCo's compiler gave about a robot file (shown as one ``vtcore: warning:`` line)."""


@contextlib.contextmanager
def mujoco_messages():
    """While active, MuJoCo's own warnings (``mju_warning``: "XML contains a 'NaN'", ...) are
    collected into the yielded list instead of being printed by C onto the terminal (and appended
    to ``MUJOCO_LOG.TXT`` in the working folder); the previous handler is restored after."""
    import mujoco

    got: list[str] = []
    old = mujoco.get_mju_user_warning()
    mujoco.set_mju_user_warning(lambda msg: got.append(" ".join(str(msg).split())))
    try:
        yield got
    finally:
        mujoco.set_mju_user_warning(old)


def mujoco_error(exc: Exception, what: str, path, messages=()) -> FormatError:
    """One FormatError line from MuJoCo's exception (its line breaks folded) and the warnings it gave."""
    text = " ".join(str(exc).split())
    extra = f" (MuJoCo also said: {'; '.join(dict.fromkeys(messages))})" if messages else ""
    return FormatError(f"MuJoCo cannot {what} it: {text}{extra}", file=path)


def warn_messages(messages, path) -> None:
    """MuJoCo's collected warnings as :class:`MujocoWarning` (each once)."""
    for msg in dict.fromkeys(messages):
        warnings.warn(f"{path}: MuJoCo: {msg}", MujocoWarning, stacklevel=3)


def compile_model(path):
    """(``mujoco.MjModel`` of the file, MuJoCo's warnings), or a FormatError naming it with
    MuJoCo's own message. The file is read first under :func:`.model.read_xml` (UTF-8, its
    declaration): MuJoCo itself takes any bytes and hands them back in names."""
    try:
        import mujoco
    except ImportError:  # e.g. inside Blender: the extension does not bundle MuJoCo
        raise InputError("reading an MJCF robot needs the mujoco package (pip install mujoco, or vtcore[robot]); "
                         "URDF robots are read without it", file=path) from None

    read_xml(path)
    with mujoco_messages() as said:
        try:
            return mujoco.MjModel.from_xml_path(str(path)), said
        except ValueError as exc:
            raise mujoco_error(exc, "compile", path, said) from None


def _names(m, kind: str, n: int, path) -> list:
    """The names of MuJoCo's ``kind`` ("body", "geom", "joint", "mesh") elements 0..n-1; a name that is
    not UTF-8 (from an ``<include>``d file, which MuJoCo reads itself) is one FormatError."""
    try:
        return [getattr(m, kind)(i).name for i in range(n)]
    except UnicodeDecodeError as exc:
        raise FormatError(f"a {kind} name is not UTF-8 (byte 0x{exc.object[exc.start:exc.start + 1].hex()}); "
                          "save the file and its includes as UTF-8", file=path, key=f"{kind}.name") from None


def check_finite(m, names: dict, path) -> None:
    """Every number this reader takes from the compiled model finite and within +-1 km: MuJoCo
    compiles ``pos="nan 0 0"`` (with only a warning), which would reach ``robot info`` as a NaN size.
    names : kind -> its element names, for the message."""
    limited = np.asarray(m.jnt_limited, bool)
    checks = (("body", "pos", m.body_pos), ("body", "quat", m.body_quat), ("geom", "pos", m.geom_pos),
              ("geom", "quat", m.geom_quat), ("geom", "size", m.geom_size), ("joint", "pos", m.jnt_pos),
              ("joint", "axis", m.jnt_axis), ("joint", "range", np.where(limited[:, None], m.jnt_range, 0.0)),
              ("mesh", "vertex", m.mesh_vert))
    for kind, attr, values in checks:
        a = np.asarray(values, dtype=np.float64)
        if not a.size:
            continue
        a = a.reshape(len(a), -1)
        bad = ~(np.isfinite(a) & (np.abs(a) <= MAX_EXTENT_M)).all(axis=1)
        if attr in ("quat", "axis"):  # MuJoCo normalises them; a 1e308 overflows the norm: all zeros
            bad |= ~(np.abs(np.linalg.norm(np.where(bad[:, None], 0.0, a), axis=1) - 1.0) < 1e-6)
        if not bad.any():
            continue
        i = int(np.flatnonzero(bad)[0])
        if kind == "mesh":  # a vertex row: the mesh it belongs to
            i = int(np.searchsorted(np.asarray(m.mesh_vertadr), i, "right")) - 1
            raise FormatError(f"mesh {names['mesh'][i] or i!r}: a vertex is not finite or beyond "
                              f"+-{MAX_EXTENT_M:g} m (its scale?)", file=path, key="mesh.scale")
        what = {"quat": "is not a rotation", "axis": "is not a direction"}[attr] \
            if attr in ("quat", "axis") and np.isfinite(a[i]).all() else \
            f"is not finite or beyond +-{MAX_EXTENT_M:g} m"
        raise FormatError(f"{kind} {names[kind][i] or i!r}: {attr} {clean_numbers(a[i])} {what} (as MuJoCo compiled it)",
                          file=path, key=f"{kind}.{attr}")


def _geometry(m, g: int, names: dict) -> Geometry:
    kind = "collision" if (m.geom_contype[g] or m.geom_conaffinity[g]) else "visual"
    origin = _pose(m.geom_pos[g], m.geom_quat[g])
    name = names["geom"][g] or None
    t = int(m.geom_type[g])
    if t == _MESH:
        k = int(m.geom_dataid[g])
        v0, nv = int(m.mesh_vertadr[k]), int(m.mesh_vertnum[k])
        f0, nf = int(m.mesh_faceadr[k]), int(m.mesh_facenum[k])
        return Geometry(kind, origin, vertices=np.array(m.mesh_vert[v0:v0 + nv], dtype=np.float64),
                        faces=np.array(m.mesh_face[f0:f0 + nf], dtype=np.int64), name=name,
                        filename=names["mesh"][k])
    size = np.asarray(m.geom_size[g], dtype=np.float64)
    if t == 6:
        return Geometry(kind, origin, primitive="box", size=tuple(2 * size), name=name)  # MuJoCo: half sizes
    if t in (3, 5):
        return Geometry(kind, origin, primitive=_PRIMITIVES[t], size=(size[0], 2 * size[1]), name=name)
    if t == 2:
        return Geometry(kind, origin, primitive="sphere", size=(size[0],), name=name)
    return None  # planes, ellipsoids, height fields, SDFs: no skin goes there


def read(path, packages: dict | None = None) -> Robot:
    """The robot of the MJCF file at ``path`` (``packages`` is for URDF's package:// and unused here)."""
    path = Path(path)
    if not path.is_file():
        raise InputError("robot file not found", file=path)
    m, said = compile_model(path)
    every = {kind: _names(m, kind, n, path) for kind, n in (("body", m.nbody), ("geom", m.ngeom),
                                                            ("joint", m.njnt), ("mesh", m.nmesh))}
    try:
        check_finite(m, every, path)
    except FormatError as exc:
        if not said:
            raise
        raise FormatError(f"{exc.reason} (MuJoCo said: {'; '.join(dict.fromkeys(said))})", file=exc.file,
                          key=exc.key) from None
    warn_messages(said, path)
    names = [n or f"body_{b}" for b, n in enumerate(every["body"])]
    if len(set(names)) != len(names):
        raise FormatError("two bodies have the same name", file=path)
    links = {n: Link(n) for n in names}
    for g in range(m.ngeom):
        geom = _geometry(m, g, every)
        if geom is not None:
            link = links[names[int(m.geom_bodyid[g])]]
            (link.visuals if geom.kind == "visual" else link.collisions).append(geom)
    joints = []
    for b in range(1, m.nbody):
        parent, child = names[int(m.body_parentid[b])], names[b]
        chain = [j for j in range(m.njnt) if int(m.jnt_bodyid[j]) == b and int(m.jnt_type[j]) in (2, 3)]
        origin = _pose(m.body_pos[b], m.body_quat[b])
        if not chain:
            joints.append(Joint(f"{child}_fixed", "fixed", parent, child, origin))
            continue
        # several joints in one body act one after another: chain them through inner frames
        for k, j in enumerate(chain):
            inner = child if k == len(chain) - 1 else f"{child}::{every['joint'][j] or j}"
            limited = bool(m.jnt_limited[j])
            lo, hi = (float(m.jnt_range[j][0]), float(m.jnt_range[j][1])) if limited else (None, None)
            axis = np.asarray(m.jnt_axis[j], dtype=np.float64)
            joints.append(Joint(every["joint"][j] or f"joint_{j}", "revolute" if m.jnt_type[j] == 3 else "prismatic",
                                parent, inner, origin, axis / np.linalg.norm(axis), lo, hi,
                                pivot=np.asarray(m.jnt_pos[j], dtype=np.float64)))
            parent, origin = inner, np.eye(4)
    return Robot(path.stem, path, NAME, links, joints, names[0])
