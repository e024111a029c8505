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
    misses it. The hull as half-spaces n.x <= d, one per face (coplanar faces repeat a plane)."""
    n = np.asarray(hull.face_normals, dtype=np.float64)
    d = np.einsum("ij,ij->i", n, np.asarray(hull.triangles, dtype=np.float64)[:, 0])
    out = np.full(len(origins), np.nan)
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
    return out


def contact_reach(robot: Robot, link: str, positions, normals) -> np.ndarray:
    """(N,) metres: where along each taxel's normal line (positions, normals (N, 3) in the link
    frame) the link's colliding geometry ends as MuJoCo collides it (the convex hull of each
    collision element; primitives are convex): positive above the taxel, negative below it (a taxel
    laid on a visual mesh outside the collision hull), the outermost where several overlap; 0 where
    none ends within :data:`REACH_MAX`."""
    from .meshes import geometry_mesh

    p = np.asarray(positions, dtype=np.float64).reshape(-1, 3)
    u = np.asarray(normals, dtype=np.float64).reshape(-1, 3)
    u = u / np.linalg.norm(u, axis=1, keepdims=True)
    reach = np.full(len(p), -np.inf)
    for g in robot.link(link).collisions:
        t = exit_distance(geometry_mesh(g, robot).convex_hull, p, u)
        near = np.abs(t) <= REACH_MAX  # nan compares False
        reach[near] = np.maximum(reach[near], t[near])
    return np.where(np.isfinite(reach), reach, 0.0)
