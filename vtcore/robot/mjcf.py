"""Read an MJCF robot through MuJoCo's own compiler (``mujoco.MjModel.from_xml_path``).

MuJoCo resolves what an MJCF reader must get right and we should not redo: ``<include>``,
``meshdir``/``assetdir``, default classes, ``childclass``, mesh ``scale`` and its re-centring
of every mesh at its centroid (compensated in the geom's pose). We read the compiled model:
bodies are links, hinge and slide joints are joints (ball and free joints are held at the
model's reference pose), geoms are geometry: colliding ones (``contype`` or ``conaffinity``
non-zero) collision, the rest visual. Mesh vertices come as MuJoCo compiled them, already in
metres and in the geom's frame. Joint values are MuJoCo's ``qpos`` minus the reference ``qpos0``.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..errors import FormatError, InputError
from .model import Geometry, Joint, Link, Robot

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


def compile_model(path):
    """``mujoco.MjModel`` of the file, or a FormatError naming it with MuJoCo's own message."""
    try:
        import mujoco
    except ImportError:  # e.g. inside Blender: the extension does not bundle MuJoCo
        raise InputError("reading an MJCF robot needs the mujoco package (pip install mujoco, or vtcore[robot]); "
                         "URDF robots are read without it", file=path) from None

    try:
        return mujoco.MjModel.from_xml_path(str(path))
    except ValueError as exc:
        raise FormatError(f"MuJoCo cannot compile it: {str(exc).strip().splitlines()[0]}", file=path) from None


def _geometry(m, g: int) -> Geometry:
    kind = "collision" if (m.geom_contype[g] or m.geom_conaffinity[g]) else "visual"
    origin = _pose(m.geom_pos[g], m.geom_quat[g])
    name = m.geom(g).name or None
    t = int(m.geom_type[g])
    if t == _MESH:
        k = int(m.geom_dataid[g])
        v0, nv = int(m.mesh_vertadr[k]), int(m.mesh_vertnum[k])
        f0, nf = int(m.mesh_faceadr[k]), int(m.mesh_facenum[k])
        return Geometry(kind, origin, vertices=np.array(m.mesh_vert[v0:v0 + nv], dtype=np.float64),
                        faces=np.array(m.mesh_face[f0:f0 + nf], dtype=np.int64), name=name,
                        filename=m.mesh(k).name)
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
    m = compile_model(path)
    names = [m.body(b).name or f"body_{b}" for b in range(m.nbody)]
    if len(set(names)) != len(names):
        raise FormatError("two bodies have the same name", file=path)
    links = {n: Link(n) for n in names}
    for g in range(m.ngeom):
        geom = _geometry(m, g)
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
            inner = child if k == len(chain) - 1 else f"{child}::{m.joint(j).name or j}"
            limited = bool(m.jnt_limited[j])
            lo, hi = (float(m.jnt_range[j][0]), float(m.jnt_range[j][1])) if limited else (None, None)
            axis = np.asarray(m.jnt_axis[j], dtype=np.float64)
            joints.append(Joint(m.joint(j).name or f"joint_{j}", "revolute" if m.jnt_type[j] == 3 else "prismatic",
                                parent, inner, origin, axis / np.linalg.norm(axis), lo, hi,
                                pivot=np.asarray(m.jnt_pos[j], dtype=np.float64)))
            parent, origin = inner, np.eye(4)
    return Robot(path.stem, path, NAME, links, joints, names[0])
