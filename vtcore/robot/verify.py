"""Check a skinned robot the way its consumers load it: every taxel frame on its link's surface.

:func:`check_urdf` loads the exported URDF with yourdfpy (its own mesh loading, origins, scales and
forward kinematics), :func:`check_mjcf` the exported MJCF with MuJoCo; at each joint configuration
every taxel frame (a ``*_vtskin_*`` link, or a touch sensor's site) is compared, in world
coordinates, with its link's mesh placed by that consumer: the distance of its origin to the mesh
and the angle between its z axis and the normal of the nearest face. The tests hold these under
0.5 mm and 5 degrees (issue 25) and ``vtcore bench robot`` reports them. yourdfpy and mujoco are
imported here only (test and benchmark dependencies, not the add-on's).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..errors import InputError
from ..layout.modules import TAXEL_DIAMETER

SKIN_MARK = "_vtskin_"


#: metres: the radius of a taxel's footprint (the CySkin taxel's 4 mm sensing disc)
FOOTPRINT_M = TAXEL_DIAMETER / 2
#: points round the footprint's rim that find the faces under it (with the centre: 13 per taxel)
FOOTPRINT_RIM = 12


def surface_errors(mesh, origins, z_axes, footprint: float = FOOTPRINT_M, frame=None):
    """Per taxel: ``(mm, facet_deg, footprint_deg)``, each (N,): the distance of its origin (N, 3)
    to ``mesh``; the angle between its z axis (N, 3) and the normal of the nearest face; and the
    angle between its z axis and the nearest normal the surface has under the taxel's footprint
    (a disc of radius ``footprint`` metres round the origin in its tangent plane, brought onto the
    mesh: the faces under its centre and 12 rim points, and the arcs between their normals, which
    is where a flexible module lying across a facet edge points). Same frame for all, metres.

    The facet angle alone cannot be small where a taxel lies across two facets meeting at an angle
    (a coarse collision hull's 20 to 30 degrees): no normal is within half that angle of both. The
    footprint angle still flags any taxel turned away from the surface under it (a wrong frame
    shows as tens of degrees). The rim's pairs give an upper bound on the angle to the normal cone
    (three or more faces meet at a vertex: the arcs between pairs are its edges, not its inside).
    frame : (3, 3) the rotation of the mesh's own frame in the frame of the points (default identity):
    the rim points start from its x axis, so the result does not depend on where the link is."""
    from ..layout.surface import closest_points, footprint_faces, nearest_in_footprint

    z = np.asarray(z_axes, dtype=np.float64)
    z = z / np.linalg.norm(z, axis=1, keepdims=True)
    origins = np.asarray(origins, dtype=np.float64)
    _, face, dist = closest_points(mesh, origins)
    fn = np.asarray(mesh.face_normals)
    facet = np.degrees(np.arccos(np.clip(np.einsum("ij,ij->i", fn[face], z), -1, 1)))
    rot = np.eye(3) if frame is None else np.asarray(frame, dtype=np.float64)
    under = footprint_faces(mesh, origins, z, footprint, FOOTPRINT_RIM, rot[:, 0], rot[:, 1])
    best = nearest_in_footprint(fn[under], z)[1]
    return dist * 1e3, facet, np.degrees(np.arccos(np.clip(best, -1, 1)))


def fine(geom):
    """A copy of a yourdfpy scene geometry as a mesh; a primitive (cylinder, capsule, sphere) tessellated
    finely, so that its facets' normals (32 round by default) are not mistaken for a taxel's error."""
    import trimesh

    p = getattr(geom, "primitive", None)
    if isinstance(geom, trimesh.primitives.Cylinder):
        return trimesh.creation.cylinder(radius=p.radius, height=p.height, sections=720, transform=p.transform)
    if isinstance(geom, trimesh.primitives.Capsule):
        return trimesh.creation.capsule(radius=p.radius, height=p.height, count=[720, 360], transform=p.transform)
    if isinstance(geom, trimesh.primitives.Sphere):
        return trimesh.creation.icosphere(subdivisions=6, radius=p.radius).apply_transform(p.transform)
    return geom.copy()


def _merge(stats: dict, link: str, errors) -> None:
    d, a, f = errors
    old = stats.get(link, {"taxels": len(d), "max_mm": 0.0, "max_deg": 0.0, "footprint_deg": 0.0})
    stats[link] = {"taxels": len(d), "max_mm": max(old["max_mm"], float(d.max())),
                   "max_deg": max(old["max_deg"], float(a.max())),
                   "footprint_deg": max(old["footprint_deg"], float(f.max()))}


def yourdfpy_robot(path, geometry: str = "visual", packages: dict | None = None):
    """The URDF at ``path`` as yourdfpy loads it, with its ``geometry`` meshes and scene graph; a
    ``package://NAME/`` path resolves in ``packages[NAME]`` as a ROS user's package path would."""
    import yourdfpy

    def handler(fname):
        for name, folder in (packages or {}).items():
            if fname.startswith(f"package://{name}/"):
                return str(Path(folder) / fname[len(f"package://{name}/"):])
        return yourdfpy.filename_handler_magic(fname, dir=str(Path(path).parent))

    collision = geometry == "collision"
    return yourdfpy.URDF.load(str(path), build_scene_graph=True, load_meshes=not collision,
                              build_collision_scene_graph=collision, load_collision_meshes=collision,
                              filename_handler=handler)


def check_urdf(path, configs, geometry: str = "visual", packages: dict | None = None) -> dict:
    """Per skinned link of the URDF at ``path``: ``{"taxels", "max_mm", "max_deg"}`` over every
    configuration of ``configs`` (dicts joint -> value; yourdfpy applies mimic joints itself).
    packages : package name -> folder, given to yourdfpy as a ROS user's package path would be."""
    import trimesh

    u = yourdfpy_robot(path, geometry, packages)
    collision = geometry == "collision"
    parent_of = {j.child: j.parent for j in u.joint_map.values()}
    taxels: dict = {}
    for name in u.link_map:
        if SKIN_MARK in name:
            taxels.setdefault(parent_of[name], []).append(name)
    stats: dict = {}
    for q in configs:
        u.update_cfg({k: v for k, v in q.items() if k in u.actuated_joint_names})
        scene = u.collision_scene if collision else u.scene
        g = scene.graph
        parents = g.transforms.parents
        for link, names in taxels.items():
            parts = []
            for node in g.nodes_geometry:
                if parents.get(node) == link:
                    t, geom = g[node]
                    m = fine(scene.geometry[geom])
                    m.apply_transform(t)
                    parts.append(m)
            if not parts:
                raise InputError(f"yourdfpy loaded no {geometry} mesh of link {link!r}", file=path)
            mesh = trimesh.util.concatenate(parts)
            frames = np.array([u.get_transform(n, u.base_link) for n in names])
            _merge(stats, link, surface_errors(mesh, frames[:, :3, 3], frames[:, :3, 2],
                                               frame=u.get_transform(link, u.base_link)[:3, :3]))
    return stats


def check_mjcf(path, link_meshes: dict, configs) -> dict:
    """Per skinned body of the MJCF at ``path``: ``{"taxels", "max_mm", "max_deg"}`` over every
    configuration (dicts joint name -> qpos value, mimic joints already expanded), each site
    against ``link_meshes[body]`` (a trimesh in the body's frame) placed where MuJoCo puts the body."""
    import mujoco

    from .reach import body_links

    m = mujoco.MjModel.from_xml_path(str(path))
    d = mujoco.MjData(m)
    sites: dict = {}
    links = body_links(m)  # a module's site lies on its body's parent link
    for s in range(m.nsite):
        if SKIN_MARK in m.site(s).name:
            sites.setdefault(m.body(int(links[m.site_bodyid[s]])).name, []).append(s)
    stats: dict = {}
    for q in configs:
        d.qpos[:] = m.qpos0
        for name, v in q.items():
            j = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_JOINT, name)
            if j >= 0:
                d.qpos[m.jnt_qposadr[j]] = v
        mujoco.mj_kinematics(m, d)
        for body, ids in sites.items():
            b = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, body)
            r, p = d.xmat[b].reshape(3, 3), d.xpos[b]
            mesh = link_meshes[body].copy()
            t = np.eye(4)
            t[:3, :3], t[:3, 3] = r, p
            mesh.apply_transform(t)
            _merge(stats, body, surface_errors(mesh, d.site_xpos[ids], d.site_xmat[ids].reshape(-1, 3, 3)[:, :, 2],
                                               frame=r))
    return stats


def clearance_urdf(path, packages: dict | None = None, q: dict | None = None, geometry: str = "visual") -> dict:
    """Per skinned link of the merged URDF at ``path``, as yourdfpy loads it (its ``geometry`` meshes) at
    joint values ``q`` (default the zero pose): ``{"taxels", "min_mm", "near", "inside", "nearest"}``:
    each taxel frame's distance to every *other* link's visual surface (trimesh's closest point,
    inside by trimesh's ``contains`` on a closed mesh), the smallest in mm, how many taxels lie within
    2 mm of or inside another link, and which link came nearest. Independent of
    :mod:`vtcore.robot.exposure` (which decided where the skin may go)."""
    import trimesh

    u = yourdfpy_robot(path, geometry, packages)
    collision = geometry == "collision"
    u.update_cfg({k: v for k, v in (q or {}).items() if k in u.actuated_joint_names})
    parent_of = {j.child: j.parent for j in u.joint_map.values()}
    taxels: dict = {}
    for name in u.link_map:
        if SKIN_MARK in name:
            taxels.setdefault(parent_of[name], []).append(name)
    scene = u.collision_scene if collision else u.scene
    g = scene.graph
    parts: dict = {}
    for node in g.nodes_geometry:
        link = g.transforms.parents.get(node)
        if link is None or SKIN_MARK in link:
            continue
        t, geom = g[node]
        m = fine(scene.geometry[geom])
        m.apply_transform(t)
        parts.setdefault(link, []).append(m)
    others = {k: trimesh.util.concatenate(v) for k, v in parts.items()}
    out = {}
    for link, names in taxels.items():
        p = np.array([u.get_transform(n, u.base_link)[:3, 3] for n in names])
        best, who = np.full(len(p), np.inf), np.full(len(p), "", dtype=object)
        inside = np.zeros(len(p), bool)
        for other, m in others.items():
            if other == link:
                continue
            lo, hi = m.bounds[0] - 0.01, m.bounds[1] + 0.01
            near = np.flatnonzero(np.all((p >= lo) & (p <= hi), axis=1))
            if not len(near):
                continue
            d = trimesh.proximity.closest_point(m, p[near])[1]
            ins = m.contains(p[near]) if m.is_watertight else np.zeros(len(near), bool)
            inside[near] |= ins
            d = np.where(ins, 0.0, d)
            closer = d < best[near]
            best[near[closer]], who[near[closer]] = d[closer], other
        k = int(np.argmin(best))
        out[link] = {"taxels": len(p), "min_mm": float(1e3 * best[k]), "near": int(((best < 0.002) | inside).sum()),
                     "inside": int(inside.sum()), "nearest": who[k] or None}
    return out
