"""How far MuJoCo's contact surface lies from each taxel, along its normal.

MuJoCo collides a mesh geom through its convex hull, not the mesh: over a UR10 forearm (a tube
between two bulging joints) the hull spans the tube up to 8 mm above the surface the taxels are
laid on. A touch sensor counts only the contacts whose point lies inside its site, so a site
that hugs the mesh reads nothing where a ball rests on the hull above it (0 N in the issue's
report). :func:`contact_reach` gives, per taxel, the distance along its normal line to where
the link's colliding geometry (each element's hull: MuJoCo's own surface) ends; the MJCF export
makes each site reach that far (:func:`vtcore.layout.io.mjcf.add_skin`, ``reach``).
"""

from __future__ import annotations

import numpy as np

from .model import Robot

#: metres: a contact surface farther than this along a taxel's normal is not that taxel's (the line
#: crosses another part of the link); its site keeps its own height
REACH_MAX = 0.012
#: taxels x hull faces compared at once (bounds the temporaries: ~100 MB of float64)
CHUNK = 2_000_000


def exit_distance(hull, origins, directions) -> np.ndarray:
    """(N,) metres: where the line ``origins + t directions`` (N, 3) each, unit) leaves the convex
    ``hull`` (a trimesh), as ``t`` (negative: the hull lies behind the origin); nan where the line
    misses it (:func:`crossing`)."""
    return crossing(hull, origins, directions)[1]


def crossing(hull, origins, directions) -> tuple[np.ndarray, np.ndarray]:
    """``(t_enter, t_exit)``, (N,) metres each: where the line ``origins + t directions`` ((N, 3) each,
    unit) enters and leaves the convex ``hull`` (a trimesh); nan where it misses. The hull as
    half-spaces n.x <= d, one per face (coplanar faces repeat a plane)."""
    n = np.asarray(hull.face_normals, dtype=np.float64)
    d = np.einsum("ij,ij->i", n, np.asarray(hull.triangles, dtype=np.float64)[:, 0])
    out, into = np.full(len(origins), np.nan), np.full(len(origins), np.nan)
    step = max(1, CHUNK // max(len(n), 1))
    for k in range(0, len(origins), step):
        a = origins[k:k + step] @ n.T - d  # > 0: outside that face's plane
        b = directions[k:k + step] @ n.T  # how fast the line crosses it
        with np.errstate(divide="ignore", invalid="ignore"):
            t = -a / b
        t_exit = np.where(b > 1e-12, t, np.inf).min(axis=1)
        t_enter = np.where(b < -1e-12, t, -np.inf).max(axis=1)
        parallel_out = ((np.abs(b) <= 1e-12) & (a > 1e-9)).any(axis=1)
        hit = (t_enter <= t_exit + 1e-9) & ~parallel_out & np.isfinite(t_exit)
        out[k:k + step] = np.where(hit, t_exit, np.nan)
        into[k:k + step] = np.where(hit, t_enter, np.nan)
    return into, out


def reach_to(parts, positions, normals) -> tuple[np.ndarray, np.ndarray]:
    """``(reach (N,) metres, met (N,) bool)``: where along each taxel's normal line (positions,
    normals (N, 3), the parts' frame) the convex ``parts`` (trimeshes) end: positive above the taxel,
    negative below it, the outermost where several overlap; ``met`` where some part ends within
    :data:`REACH_MAX` (elsewhere reach is 0)."""
    p = np.asarray(positions, dtype=np.float64).reshape(-1, 3)
    u = np.asarray(normals, dtype=np.float64).reshape(-1, 3)
    u = u / np.linalg.norm(u, axis=1, keepdims=True)
    reach = np.full(len(p), -np.inf)
    for part in parts:
        t = exit_distance(part, p, u)
        near = np.abs(t) <= REACH_MAX  # nan compares False
        reach[near] = np.maximum(reach[near], t[near])
    met = np.isfinite(reach)
    return np.where(met, reach, 0.0), met


def collision_hulls(robot: Robot, link: str) -> list:
    """The link's colliding geometry as MuJoCo collides it: each collision element's convex hull."""
    from .meshes import geometry_mesh

    return [geometry_mesh(g, robot).convex_hull for g in robot.link(link).collisions]


def contact_reach(robot: Robot, link: str, positions, normals, parts=None) -> np.ndarray:
    """(N,) metres: where along each taxel's normal line (positions, normals (N, 3) in the link
    frame) the link's colliding geometry ends as MuJoCo collides it (``parts``, convex trimeshes;
    default the convex hull of each collision element, :func:`collision_hulls`): positive above the
    taxel, negative below it (a taxel laid on a visual mesh outside the collision hull), the outermost
    where several overlap; 0 where none ends within :data:`REACH_MAX`."""
    return reach_to(collision_hulls(robot, link) if parts is None else parts, positions, normals)[0]


def ball_reach(parts, positions, normals, radius: float, rings=(0.35, 0.7, 0.95), rays: int = 8) -> np.ndarray:
    """(N,) metres: how far along each taxel's normal (positions, normals (N, 3), the parts' frame) the
    lowest point of a ball of ``radius`` m stops when it comes down the normal line onto the convex
    ``parts`` alone (not onto the skin): the highest of the parts' surface (:func:`reach_to`) less the
    ball's rise over its lowest point there, on the axis and on ``rays`` rays round it at each of
    ``rings`` (fractions of the radius); 0 where no part ends within :data:`REACH_MAX` of any ray.
    Positive where the link stands beside the taxel higher than the ball's underside: a ball coming
    down onto that taxel rests on the link there, not on the taxel's pad."""
    p = np.asarray(positions, dtype=np.float64).reshape(-1, 3)
    u = np.asarray(normals, dtype=np.float64).reshape(-1, 3)
    u = u / np.linalg.norm(u, axis=1, keepdims=True)
    a = np.cross(u, np.where(np.abs(u[:, :1]) < 0.9, [[1.0, 0.0, 0.0]], [[0.0, 1.0, 0.0]]))
    a /= np.linalg.norm(a, axis=1, keepdims=True)
    b = np.cross(u, a)
    reach, met = reach_to(parts, p, u)
    rest = np.where(met, reach, -np.inf)
    for frac in rings:
        rho = frac * radius
        lift = radius - np.sqrt(radius * radius - rho * rho)  # the ball's underside this far above its lowest point
        for ang in np.linspace(0, 2 * np.pi, rays, endpoint=False):
            r, m = reach_to(parts, p + rho * (np.cos(ang) * a + np.sin(ang) * b), u)
            rest = np.maximum(rest, np.where(m, r - lift, -np.inf))
    return np.where(np.isfinite(rest), rest, 0.0)


#: metres: a probe comes from this far out along a taxel's normal (a fingertip's reach over the skin); a
#: geom of another body on that line, or of the link itself farther out, takes the touch instead
PROBE_M = 0.02
#: metres: the probe is a ball this wide (a 20 g steel ball, 8.5 mm): rays round the axis at this radius find a
#: neighbour beside the taxel that the ball would rest on (a thin ray passed the G1 torso by an elbow taxel)
PROBE_RADIUS_M = 0.0085
#: rays round the axis, on rings at these fractions of the ball's radius
RING_RAYS = 8
RING_FRACTIONS = (0.5, 0.9)
#: the rays of :func:`_beside` in the order tried (ring by ring): (R, 2) in-plane offsets from the axis, metres,
#: and (R,) the ball's underside there above its lowest point (computed once: the per-ray numpy arithmetic was
#: half of the export's contact check, 4.4 CPU s for the G1 with 1,020 taxels)
_RING_ANGLES = np.linspace(0, 2 * np.pi, RING_RAYS, endpoint=False)
_RING_RHO = np.repeat(np.asarray(RING_FRACTIONS) * PROBE_RADIUS_M, RING_RAYS)
RING_OFFSETS = _RING_RHO[:, None] * np.column_stack([np.cos(_RING_ANGLES), np.sin(_RING_ANGLES)])[
    np.tile(np.arange(RING_RAYS), len(RING_FRACTIONS))]
RING_LIFTS = PROBE_RADIUS_M - np.sqrt(PROBE_RADIUS_M ** 2 - _RING_RHO ** 2)
#: MuJoCo geom group the check parks non-colliding geoms in, out of its rays' way
_IGNORED_GROUP = 5


def body_links(m) -> np.ndarray:
    """(nbody,) int: the link each body of the MuJoCo model ``m`` belongs to: itself, or its parent for a
    skin module's body (a robot export with pads, :func:`vtcore.layout.io.mjcf.module_body`: named
    ``<prefix>module_<id>``, holding sites named ``<prefix>...``) and for a tile's body (the ``"tile"``
    footprint: ``<site>_cell``, holding the site ``<site>``). Built once per model: the reach probe,
    the surface check and the drop ask it for every site and ray."""
    bodies, first = np.unique(np.asarray(m.site_bodyid), return_index=True)
    links = np.arange(m.nbody)
    for b, k in zip(bodies, first):
        name, site = m.body(int(b)).name, m.site(int(k)).name
        head, sep, tail = name.rpartition("module_")
        if (sep and tail.lstrip("-").isdigit() and site.startswith(head)) or name == f"{site}_cell":
            links[b] = m.body_parentid[b]
    return links


#: joint configurations (seeded, uniform within the limits, collision-free: :func:`free_qpos`) the export also
#: probes every site at
POSES = 8


def unreadable_sites(model_path, sites, poses: int = 0, seed: int = 0):
    """Which of the touch sites ``sites`` (names) of the MJCF at ``model_path`` cannot read, at the
    zero pose: site name -> why. Each site is probed by MuJoCo's own ray (``mj_ray``, colliding geoms
    only) from :data:`PROBE_M` out along its axis towards it; it reads when the first geom hit is of
    the site's own body and the hit lies within the site's height (a touch sensor counts the contacts
    of its body inside its volume). A miss: nothing of its link within its site, "covered by BODY",
    or the contact surface this far from the taxel.

    poses : also probe at this many seeded random configurations the robot can hold (:func:`free_qpos`:
    hinge and slide joints uniform within their limits, +-pi where unlimited, no body through another);
    then returns ``(at_zero, at_some)``: the zero pose's dict and site name -> why for the sites that
    read at the zero pose but not at some of those poses."""
    import mujoco

    m = mujoco.MjModel.from_xml_path(str(model_path))
    d = mujoco.MjData(m)
    colliding = (m.geom_contype != 0) | (m.geom_conaffinity != 0)
    m.geom_group[:] = np.where(colliding, 0, _IGNORED_GROUP)
    ids = np.array([m.site(name).id for name in sites], dtype=int)
    zero = _probe(m, d, ids, m.qpos0)
    if not poses:
        return zero
    some: dict = {}
    for q in free_qpos(m, poses, seed):
        some.update({k: v for k, v in _probe(m, d, ids, q).items() if k not in zero})
    return zero, {name: some[name] for name in sites if name in some}


#: metres: a configuration is self-colliding where MuJoCo finds two bodies interpenetrating deeper than
#: this (bodies it does not already find touching at the zero pose: parts that overlap by design)
SELF_DEPTH = 0.002
#: draws per wanted configuration before :func:`free_qpos` gives up on finding a collision-free one
SELF_TRIES = 100


def free_qpos(m, count: int, seed: int = 0, depth: float = SELF_DEPTH, tries: int = SELF_TRIES) -> list:
    """Up to ``count`` joint configurations (each (nq,) qpos) of the MuJoCo model ``m`` that the robot
    can hold, seeded: hinge and slide joints uniform within their limits (+-pi where unlimited), kept
    only where MuJoCo's own collision finds no pair of bodies interpenetrating by more than ``depth``
    metres, besides the pairs in contact at the zero pose (rejection sampling). Random configurations
    uniform within the limits often put a humanoid's arm through its own torso; a taxel covered only
    there is no taxel the robot covers. After ``tries`` draws per wanted pose without one, fewer come back."""
    import mujoco

    d = mujoco.MjData(m)
    exempt = _self_contacts(m, d, m.qpos0, depth=-np.inf)  # every contact at the zero pose: by design
    rng = np.random.default_rng(seed)
    out, draws = [], 0
    while len(out) < int(count) and draws < int(tries) * int(count):
        draws += 1
        q = _random_qpos(m, rng)
        if not _self_contacts(m, d, q, depth) - exempt:
            out.append(q)
    return out


def free_configurations(model_path, count: int, seed: int = 0) -> list:
    """:func:`free_qpos` of the MJCF at ``model_path`` as joint name -> value dicts (hinge and slide joints)."""
    import mujoco

    m = mujoco.MjModel.from_xml_path(str(model_path))
    moving = [j for j in range(m.njnt) if int(m.jnt_type[j]) in (int(mujoco.mjtJoint.mjJNT_HINGE),
                                                                 int(mujoco.mjtJoint.mjJNT_SLIDE))]
    return [{m.joint(j).name: float(q[m.jnt_qposadr[j]]) for j in moving} for q in free_qpos(m, count, seed)]


def _self_contacts(m, d, qpos, depth: float) -> set:
    """The pairs of bodies (frozensets of ids) MuJoCo finds in contact deeper than ``depth`` metres at ``qpos``."""
    import mujoco

    d.qpos[:] = qpos
    mujoco.mj_fwdPosition(m, d)  # kinematics and collision: MuJoCo's own contacts (parent-child pairs filtered)
    con = d.contact[:d.ncon]
    deep = np.asarray(con.dist) < -depth if d.ncon else np.zeros(0, bool)
    b1, b2 = m.geom_bodyid[np.asarray(con.geom1, dtype=int)], m.geom_bodyid[np.asarray(con.geom2, dtype=int)]
    return {frozenset((int(a), int(b))) for a, b, k in zip(b1, b2, deep) if k}


def _random_qpos(m, rng) -> np.ndarray:
    import mujoco

    q = m.qpos0.copy()
    for j in range(m.njnt):
        # int(): a numpy integer never equals a pybind11 enum, so every joint stayed at 0
        if int(m.jnt_type[j]) in (int(mujoco.mjtJoint.mjJNT_HINGE), int(mujoco.mjtJoint.mjJNT_SLIDE)):
            lo, hi = m.jnt_range[j] if m.jnt_limited[j] else (-np.pi, np.pi)
            q[m.jnt_qposadr[j]] = rng.uniform(lo, hi)
    return q


def _probe(m, d, ids, qpos) -> dict:
    """site name -> why it cannot read, at the joint positions ``qpos`` (see :func:`unreadable_sites`)."""
    import mujoco

    d.qpos[:] = qpos
    mujoco.mj_kinematics(m, d)
    groups = np.array([1, 0, 0, 0, 0, 0], dtype=np.uint8)
    hit = np.zeros(1, dtype=np.int32)
    links = body_links(m)
    out = {}
    for k in ids:  # one C call per site: mj_ray has no batch over origins
        name = m.site(k).name
        p, n = d.site_xpos[k], d.site_xmat[k].reshape(3, 3)[:, 2]
        dist = mujoco.mj_ray(m, d, p + PROBE_M * n, -n, groups, 1, -1, hit)
        if hit[0] < 0 or dist > PROBE_M + m.site_size[k][2]:  # mj_ray's line goes on past the taxel
            out[name] = "nothing of its link collides within its site along its normal"
            continue
        body = int(m.geom_bodyid[hit[0]])
        if body != int(m.site_bodyid[k]):
            out[name] = f"covered by {m.body(body).name}"
            continue
        s = PROBE_M - dist  # the contact surface's height over the taxel along its normal
        if abs(s) > m.site_size[k][2]:
            out[name] = f"its link's contact surface is {s * 1e3:.1f} mm along its normal, beyond its site"
            continue
        other = _beside(m, d, p, n, s, int(links[m.site_bodyid[k]]), groups, hit, links)
        if other is not None:
            out[name] = f"a ball {2e3 * PROBE_RADIUS_M:.0f} mm wide rests on {other} beside it"
    return out


def _beside(m, d, p, n, surface: float, body: int, groups, hit, links):
    """The name of another body a ball of radius :data:`PROBE_RADIUS_M` coming down the axis ``n`` onto
    the point ``p`` (its link's surface ``surface`` m along ``n``) meets before it reaches that surface,
    found by rays round the axis (a body at lateral distance rho blocks when it stands higher than the
    ball's underside there); None if none does. The link ``body`` and its skin's module bodies (their pads
    sense for the link; ``links``: :func:`body_links`) are passed through."""
    import mujoco

    a = np.cross(n, [1.0, 0.0, 0.0] if abs(n[0]) < 0.9 else [0.0, 1.0, 0.0])
    a /= np.linalg.norm(a)
    origins = p + PROBE_M * n + RING_OFFSETS @ np.vstack([a, np.cross(n, a)])  # (R, 3), the rays' starts
    down = np.ascontiguousarray(-n)
    for o, lift in zip(origins, RING_LIFTS):
        top = _first_other(m, d, o, down, groups, body, links, hit)
        if top is not None and PROBE_M - top[0] > surface + lift:
            return m.body(top[1]).name
    return None


def _first_other(m, d, o, u, groups, body: int, links, hit):
    """``(distance, body id)`` of the first geom along the ray ``o + t u`` (t >= 0, metres) of a body
    of another link than ``body`` (the link itself excluded by MuJoCo, its module bodies stepped over:
    ``links``, :func:`body_links`), or None."""
    import mujoco

    t = 0.0
    for _ in range(64):  # each step passes one pad at least; a ray meets a few
        dist = mujoco.mj_ray(m, d, o + t * u, u, groups, 1, body, hit)
        if hit[0] < 0:
            return None
        b = int(m.geom_bodyid[hit[0]])
        if links[b] != body:
            return t + dist, b
        t += dist + 1e-6
    return None
