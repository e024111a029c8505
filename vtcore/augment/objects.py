"""The six objects of seed 000 as meshes with local stiffness fields.

Seed 000 (Sect. 3, Fig. 4, Fig. 7) describes: two bottles of identical shape,
one empty and one full, "stiffer closer to the cap because of the curvature,
more compliant in the central part of the body and slightly stiffer toward the
bottom where it is constrained" (by a stand), with a stiff plastic cap; a
tennis ball stiffer than a sponge ball, both uniform; two equal cubes wrapped
in low- and high-shore rubber, "stiffer toward the edges and the vertices and
this is more evident for the one wrapped with high-shore rubber".

The paper gives no stiffness numbers. The values below (N/m, the local
force/deflection of the surface under a ~2 N probe) are order-of-magnitude
choices that follow that description: a PET bottle wall ~0.4 kN/m empty and
~2.5 kN/m full, a tennis ball ~15 kN/m, a foam ball ~0.15 kN/m. Objects stand
with their base on z = 0, axis along +z, in metres.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable

import numpy as np

from ..errors import InputError

#: the object names of seed 000
OBJECTS = ("empty_bottle", "full_bottle", "tennis_ball", "sponge_ball", "cube_low_shore", "cube_high_shore")


@dataclass
class CompliantObject:
    """A closed mesh and its surface properties.

    mesh : trimesh.Trimesh, metres. stiffness : callable (M, 3) -> (M,) N/m, the
    local stiffness at surface points. friction : callable (M, 3) -> (M,), the
    Coulomb coefficient (a second tactile channel). meta : parameters used.
    """

    name: str
    mesh: object
    stiffness: Callable[[np.ndarray], np.ndarray]
    friction: Callable[[np.ndarray], np.ndarray]
    meta: dict = field(default_factory=dict)


def _sig(x):
    return 0.5 * (1.0 + np.tanh(0.5 * np.asarray(x, float)))   # logistic, overflow-free


# ---------------------------------------------------------------------------
# bottle
# ---------------------------------------------------------------------------

#: bottle profile (radius, height) in metres: a 0.5 l PET bottle, base on z = 0
BOTTLE = dict(radius=0.032, base_fillet=0.006, body_top=0.120, shoulder_top=0.162, neck_radius=0.0135,
              neck_top=0.172, cap_radius=0.0150, cap_top=0.194, groove_z=0.098, groove_depth=0.0012,
              groove_width=0.004, stand_height=0.055)


def bottle_profile(n: int = 160, groove_depth: float | None = None, groove_width: float | None = None) -> np.ndarray:
    """(r, z) profile of the bottle from the bottom centre to the top centre, (P, 2) metres.

    groove_depth, groove_width : metres, the body's ring at ``BOTTLE["groove_z"]`` (a Gaussian
    dip of that depth whose full width is about ``groove_width``); a negative depth is a rib
    standing out; None takes :data:`BOTTLE`'s. The ring is sampled every 0.25 mm.
    """
    b = dict(BOTTLE)
    if groove_depth is not None:
        b["groove_depth"] = float(groove_depth)
    if groove_width is not None:
        b["groove_width"] = float(groove_width)
    if not (b["groove_width"] > 0 and abs(b["groove_depth"]) < b["radius"] / 2):
        raise InputError(f"groove width must be > 0 and |depth| < {b['radius'] / 2} m, got "
                         f"{b['groove_width']} and {b['groove_depth']}", key="groove_depth")
    R, f = b["radius"], b["base_fillet"]
    pts = [(0.0, 0.0), (R - f, 0.0)]
    t = np.linspace(-np.pi / 2, 0.0, 9)[1:]
    pts += list(zip(R - f + f * np.cos(t), f + f * np.sin(t)))
    # body with one ring (moulded bottles have grooves and ribs): a probe that cannot bridge it loses contact
    z = np.linspace(f, b["body_top"], n // 2)[1:]
    ring = b["groove_z"] + np.arange(-3.0, 3.0 + 1e-9, 0.25e-3 / b["groove_width"]) * b["groove_width"]
    outside = (z < ring[0] - 1e-4) | (z > ring[-1] + 1e-4)     # the ring's own samples replace these
    z = np.sort(np.concatenate([z[outside], ring[(ring > f) & (ring < b["body_top"])]]))
    g = b["groove_depth"] * np.exp(-0.5 * ((z - b["groove_z"]) / (b["groove_width"] / 2.5)) ** 2)
    pts += list(zip(R - g, z))
    # shoulder: a quarter-cosine from the body radius to the neck radius
    s = np.linspace(0.0, 1.0, 24)[1:]
    rs = b["neck_radius"] + (R - b["neck_radius"]) * 0.5 * (1 + np.cos(np.pi * s))
    pts += list(zip(rs, b["body_top"] + s * (b["shoulder_top"] - b["body_top"])))
    pts += [(b["neck_radius"], b["neck_top"]), (b["cap_radius"], b["neck_top"]),
            (b["cap_radius"], b["cap_top"]), (0.0, b["cap_top"])]
    return np.asarray(pts, dtype=np.float64)


def bottle_mesh(sections: int = 96, **groove):
    """The bottle as a closed trimesh (revolved profile), metres; ``groove`` : see :func:`bottle_profile`."""
    import trimesh

    prof = bottle_profile(**groove)
    mesh = trimesh.creation.revolve(prof, sections=sections)
    mesh.merge_vertices()
    if mesh.volume < 0:
        mesh.invert()
    return mesh


def bottle_stiffness(points, body: float, shoulder_gain: float = 3.0, bottom_gain: float = 1.5,
                     cap: float = 60e3) -> np.ndarray:
    """Local stiffness of the bottle (N/m) at surface points (M, 3).

    body : N/m at the middle of the body; the shoulder (near the cap's curvature)
    is ``1 + shoulder_gain`` times stiffer, the bottom held by the stand
    ``1 + bottom_gain`` times; the plastic cap and neck are ``cap``.
    """
    b = BOTTLE
    z = np.asarray(points, float)[:, 2]
    k = body * (1.0 + shoulder_gain * _sig((z - (b["body_top"] - 0.004)) / 0.004)
                + bottom_gain * _sig((b["stand_height"] - z) / 0.005))
    return np.where(z >= b["shoulder_top"] - 1e-4, cap, k)


def bottle_friction(points) -> np.ndarray:
    z = np.asarray(points, float)[:, 2]
    return np.where(z >= BOTTLE["neck_top"] - 1e-4, 0.6, 0.35)   # ribbed cap grips more than PET


# ---------------------------------------------------------------------------
# balls and cubes
# ---------------------------------------------------------------------------

def ball_mesh(radius: float, subdivisions: int = 4):
    import trimesh

    m = trimesh.creation.icosphere(subdivisions=subdivisions, radius=radius)
    m.apply_translation([0.0, 0.0, radius])
    return m


def cube_mesh(size: float):
    import trimesh

    m = trimesh.creation.box(extents=[size, size, size])
    m.apply_translation([0.0, 0.0, size / 2])
    return m


def cube_stiffness(points, size: float, face: float, edge_gain: float, vertex_gain: float,
                   width: float = 0.008) -> np.ndarray:
    """Wrapped cube: stiffness rises towards the edges and more at the vertices (N/m).

    A point's distance to the nearest edge is ``h - |u|`` over its two in-face
    coordinates (the largest |coordinate| marks the face it lies on).
    """
    h = size / 2
    q = np.abs(np.asarray(points, float) - [0.0, 0.0, h])
    q.sort(axis=1)                                   # q[:, 2] ~ h: the face normal axis
    gaps = np.clip(h - q[:, :2], 0.0, None)           # distances to the two nearest edges
    d_edge = gaps.min(axis=1)
    d_vertex = np.linalg.norm(gaps, axis=1)
    return face * (1.0 + edge_gain * np.exp(-d_edge / width) + vertex_gain * np.exp(-d_vertex / width))


def _const(value):
    def f(points):
        return np.full(len(np.asarray(points).reshape(-1, 3)), float(value))
    return f


#: the nominal body (face, wall) stiffness of each object, N/m: our choices, the paper gives none
BODY_STIFFNESS = {"empty_bottle": 400.0, "full_bottle": 2500.0, "tennis_ball": 15e3, "sponge_ball": 150.0,
                  "cube_low_shore": 1500.0, "cube_high_shore": 5000.0}
#: the same-shape pairs of seed 000 (Fig. 4): (softer, stiffer)
PAIRS = {"bottle": ("empty_bottle", "full_bottle"), "ball": ("sponge_ball", "tennis_ball"),
         "cube": ("cube_low_shore", "cube_high_shore")}
#: the plastic cap and neck of both bottles, N/m (the same part on both: not scaled with the wall)
BOTTLE_CAP_STIFFNESS = 60e3


def contrast_scales(contrast: float) -> dict[str, float]:
    """Stiffness scales that give every same-shape pair the body stiffness ratio ``contrast``.

    The softer member of each pair keeps its stiffness; the stiffer one is scaled so that its
    body is ``contrast`` times the softer one's (1: equal bodies; the bottles then still differ
    at the shoulder and the bottom, where the liquid changes how much the curvature and the
    stand matter). The paper gives no stiffness, so it gives no contrast either. Returns
    ``{object: scale}`` for all six objects.
    """
    c = float(contrast)
    if not (np.isfinite(c) and c > 0):
        raise InputError(f"must be > 0, got {contrast}", key="contrast")
    scales = {o: 1.0 for o in OBJECTS}
    for soft, stiff in PAIRS.values():
        scales[stiff] = c * BODY_STIFFNESS[soft] / BODY_STIFFNESS[stiff]
    return scales


def make_seed000_object(name: str, stiffness_scale: float = 1.0, **groove) -> CompliantObject:
    """One of :data:`OBJECTS` with its stiffness field scaled by ``stiffness_scale``.

    On the bottles the scale applies to the wall (body, shoulder, bottom), not to the plastic
    cap and neck, which are the same part on both bottles. ``groove`` (bottles only):
    ``groove_depth``, ``groove_width`` of the body's ring (:func:`bottle_profile`).
    """
    if groove and name not in ("empty_bottle", "full_bottle"):
        raise InputError(f"{name} has no groove; groove_depth/groove_width are for the bottles", key="groove_depth")
    s = float(stiffness_scale)
    if not (np.isfinite(s) and s > 0):
        raise InputError(f"must be > 0, got {stiffness_scale}", key="stiffness_scale")
    if name in ("empty_bottle", "full_bottle"):
        body = BODY_STIFFNESS[name] * s
        # the full bottle's liquid supports the wall, so the curvature matters less
        gains = dict(shoulder_gain=3.0, bottom_gain=1.5) if name == "empty_bottle" \
            else dict(shoulder_gain=1.2, bottom_gain=0.6)
        cap = BOTTLE_CAP_STIFFNESS
        return CompliantObject(name, bottle_mesh(**groove), lambda p: bottle_stiffness(p, body, cap=cap, **gains),
                               bottle_friction, dict(body_stiffness=body, cap_stiffness=cap, **gains, **groove))
    if name == "tennis_ball":
        return CompliantObject(name, ball_mesh(0.0335), _const(BODY_STIFFNESS[name] * s), _const(0.7),
                               dict(radius=0.0335, stiffness=BODY_STIFFNESS[name] * s))
    if name == "sponge_ball":
        return CompliantObject(name, ball_mesh(0.035), _const(BODY_STIFFNESS[name] * s), _const(0.9),
                               dict(radius=0.035, stiffness=BODY_STIFFNESS[name] * s))
    if name in ("cube_low_shore", "cube_high_shore"):
        eg, vg = (0.8, 0.6) if name == "cube_low_shore" else (2.0, 1.5)
        face = BODY_STIFFNESS[name] * s
        return CompliantObject(name, cube_mesh(0.06), lambda p: cube_stiffness(p, 0.06, face, eg, vg),
                               _const(1.0 if name == "cube_low_shore" else 0.8),
                               dict(size=0.06, face_stiffness=face, edge_gain=eg, vertex_gain=vg))
    raise InputError(f"unknown object {name!r}; valid: {', '.join(OBJECTS)}", key="object")


def bottle_radius_at(z, **groove) -> np.ndarray:
    """Radius (m) of the bottle's surface of revolution at heights ``z`` (m); 0 above the top.
    ``groove`` : see :func:`bottle_profile`."""
    prof = bottle_profile(**groove)
    zz = np.asarray(z, float)
    # the profile is monotone in z except at the base and the cap step: interpolate over the side wall
    side = prof[1:-1]
    order = np.argsort(side[:, 1], kind="stable")
    r = np.interp(zz, side[order, 1], side[order, 0], left=0.0, right=0.0)
    return r
