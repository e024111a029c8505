"""Does an exported skin sense? Drop a ball on its taxels in MuJoCo and read the touch sensors.

The check of issue 33: the merged MJCF of a skinned robot, frozen at a configuration (every joint
removed, each body welded where forward kinematics puts it), a ball placed just above a taxel, gravity
against that taxel's normal and the ball free to move only along it (one slide joint). At rest the
skinned link's touch sensors must sum to the ball's weight m g: the contact landed on a site of that
link, not on another link, not between taxels, not nowhere.

:func:`frozen` builds the frozen model, :func:`drop` runs one drop and :func:`drop_many` a seeded
batch over taxels and configurations; ``scripts/robot_drops.py`` runs the issue's 20+ drops per robot.
"""

from __future__ import annotations

import numpy as np

from .reach import body_links

#: kg and m: the ball of the issue's check, 20 g; 8.5 mm is a 20 g steel ball's radius (7850 kg/m^3)
BALL_KG, BALL_RADIUS = 0.02, 0.0085
#: m/s^2
G = 9.81
#: m: the ball's lowest point starts this far above the taxel along its normal
GAP = 0.001


def frozen(spec, q: dict | None = None):
    """A copy of the MjSpec ``spec`` with every joint removed and every body welded at its pose for the
    joint values ``q`` (joint name -> radians or metres; missing: 0). Returns ``(spec, model, data)``
    of the frozen robot, kinematics done."""
    import mujoco

    spec = spec.copy()
    m = spec.compile()
    d = mujoco.MjData(m)
    for name, v in (q or {}).items():
        d.qpos[m.jnt_qposadr[m.joint(name).id]] = v
    mujoco.mj_kinematics(m, d)
    world = {}
    for b in range(1, m.nbody):
        t = np.eye(4)
        t[:3, :3] = d.xmat[b].reshape(3, 3)
        t[:3, 3] = d.xpos[b]
        world[m.body(b).name] = t
    for body in spec.bodies[1:]:  # every body relative to its parent at q: the joints' motion baked in
        parent = body.parent.name
        rel = np.linalg.inv(world[parent]) @ world[body.name] if parent in world else world[body.name]
        body.pos = rel[:3, 3]
        body.quat = _quat(rel[:3, :3])
        body.alt.euler = [0, 0, 0]  # an orientation given as euler would override quat
    for j in list(spec.joints):
        spec.delete(j)
    m = spec.compile()
    d = mujoco.MjData(m)
    mujoco.mj_kinematics(m, d)
    return spec, m, d


def _quat(r) -> np.ndarray:
    from scipy.spatial.transform import Rotation

    x, y, z, w = Rotation.from_matrix(r).as_quat()
    return np.array([w, x, y, z])


def drop(spec, site: str, sensors, *, mass: float = BALL_KG, radius: float = BALL_RADIUS, steps: int = 1500,
         settle: int = 1000):
    """The touch sensors ``sensors`` (names) summed at rest, newtons (mean over the steps after
    ``settle``), when a ball of ``mass`` kg and ``radius`` m is dropped on the site ``site`` of the
    frozen robot ``spec`` (:func:`frozen`) along the site's axis, gravity against it.

    Returns ``(force, blocked)``: ``blocked`` names the body of another link the ball would start inside
    (that link stands within a ball's width over the taxel at this configuration: no ball can be placed
    there, and ``force`` is None), else None."""
    import mujoco

    spec = spec.copy()
    m0 = spec.compile()
    d0 = mujoco.MjData(m0)
    mujoco.mj_kinematics(m0, d0)
    k = m0.site(site).id
    p, n = d0.site_xpos[k].copy(), d0.site_xmat[k].reshape(3, 3)[:, 2].copy()
    # from just above the site's top: the link's contact surface lies within the site's height
    ball = spec.worldbody.add_body(name="vtcore_drop_ball", pos=p + n * (m0.site_size[k][2] + radius + GAP))
    ball.add_joint(name="vtcore_drop_slide", type=mujoco.mjtJoint.mjJNT_SLIDE, axis=n)
    ball.add_geom(type=mujoco.mjtGeom.mjGEOM_SPHERE, size=[radius, 0, 0], mass=mass, contype=1, conaffinity=1)
    m = spec.compile()
    m.opt.timestep = 1e-3
    m.opt.gravity[:] = -G * n
    d = mujoco.MjData(m)
    links = body_links(m)
    blocked = _start_inside(m, d, m.body("vtcore_drop_ball").id, int(links[m.site_bodyid[m.site(site).id]]), links)
    if blocked is not None:
        return None, blocked
    ids = np.array([m.sensor(s).id for s in sensors])
    adr = m.sensor_adr[ids]
    total = 0.0
    for step in range(steps):
        mujoco.mj_step(m, d)
        if step >= settle:
            total += float(d.sensordata[adr].sum())
    return total / max(steps - settle, 1), None


def _start_inside(m, d, ball: int, link: int, links):
    """The name of a body of another link than ``link`` (``links``: :func:`.reach.body_links`) that the
    ball (body id) overlaps where it starts, or None."""
    import mujoco

    mujoco.mj_forward(m, d)
    for c in d.contact[:d.ncon]:
        bodies = {int(m.geom_bodyid[c.geom1]), int(m.geom_bodyid[c.geom2])}
        if ball not in bodies or c.dist >= 0:
            continue
        (other,) = bodies - {ball}
        if links[other] != link:
            return m.body(other).name
    return None


def drop_many(path, links, n_drops: int, *, configurations=((),), seed: int = 0, readable=None,
              tries: int = 4) -> list[dict]:
    """``n_drops`` drops on the merged MJCF at ``path``: each on a taxel drawn uniformly from all the
    taxels of ``links`` (site prefix ``<link>_vtskin_``), at a random one of ``configurations`` (dicts joint ->
    value; ``()``: the zero pose). readable : optional set of site names to draw from (the export's
    reach check). Returns one record per draw: ``link``, ``site``, ``config`` (index), ``force_n``,
    ``ratio`` (force / m g), ``blocked`` (None, or the other link the ball would start inside: that
    draw is no drop, its force and ratio are None, and another is drawn, at most ``tries`` x
    ``n_drops`` draws in all)."""
    import mujoco

    rng = np.random.default_rng(seed)
    spec = mujoco.MjSpec.from_file(str(path))
    m = spec.compile()
    every = {ln: [m.site(k).name for k in range(m.nsite) if m.site(k).name.startswith(f"{ln}_vtskin_")]
             for ln in links}
    sites = {ln: [s for s in v if readable is None or s in readable] for ln, v in every.items()}
    sites = {ln: v for ln, v in sites.items() if v}
    frozen_specs = [frozen(spec, dict(q))[0] for q in configurations]
    rows = []
    pool = [(ln, s) for ln, v in sites.items() for s in v]  # every taxel as likely: a big link is hit more
    draws = 0
    while sum(r["blocked"] is None for r in rows) < n_drops and draws < tries * n_drops:
        draws += 1
        ln, site = pool[int(rng.integers(len(pool)))]
        c = int(rng.integers(len(frozen_specs)))
        f, blocked = drop(frozen_specs[c], site, [s + "_touch" for s in every[ln]])
        rows.append({"link": ln, "site": site, "config": c, "force_n": f, "blocked": blocked,
                     "ratio": None if f is None else f / (BALL_KG * G)})
    return rows
