"""The maps press by press: the slow, direct answer the linear shortcut is checked against.

Every value here comes from full contact solves (:func:`vtcore.contact.press`) of the probe on the
real layout at the point itself, read through the same estimator, noise draws and blob criterion as
the maps, so the difference is the shortcut's alone (translation invariance of the table, the
tangent-plane offsets, superposition of two probes). Slow: one solve per point and force.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import UnreachableTargetError
from .design import Settings, live_taxels
from .maps import Localisation, frames, localise, neighbours
from .noise import SensorNoise
from .two_point import BAND_SPACINGS, BLOB_FRACTION, separations, split_blobs, taxel_spacing


def probe_pose(mesh, point, normal, e1, e2, thickness: float, gap: float = 1e-4) -> np.ndarray:
    """(4, 4) pose of a probe mesh (resting on z = 0, pressed face up) turned over above ``point`` on the
    layer's outer surface (``thickness`` out along ``normal``), its x axis along ``e1``, ``gap`` m clear."""
    r = np.column_stack([e1, e2, normal]) @ np.diag([1.0, -1.0, -1.0])
    v = np.asarray(mesh.vertices, float) @ r.T
    low = float((v @ normal).min())
    pose = np.eye(4)
    pose[:3, :3] = r
    pose[:3, 3] = np.asarray(point, float) + (thickness + gap - low) * np.asarray(normal, float)
    return pose


def two_probes(mesh, separation: float):
    """One mesh of two copies of ``mesh`` side by side at ``-+ separation / 2`` along the object's y (across
    a finger pad's long axis, x)."""
    import trimesh

    d = np.array([0.0, 0.5 * separation, 0.0])
    a, b = mesh.copy(), mesh.copy()
    a.apply_translation(-d)
    b.apply_translation(d)
    return trimesh.util.concatenate([a, b])


@dataclass
class Reference:
    """Press-by-press values at M points: threshold (M,) N (nan where not computed), localisation,
    two_point (M,) m (nan where not computed), presses (solves run), readings (M, K) counts: the mean
    readings at the reference force of the neighbour taxels (:func:`maps.neighbours` order)."""

    threshold: np.ndarray
    localisation: Localisation
    two_point: np.ndarray
    presses: int
    readings: np.ndarray


def _press_kw(settings: Settings, grid_spacing: float, margin: float):
    from ..contact import ContactGrid

    return {"model": settings.model, "spread": settings.spreading is not None,
            "spreading": settings.spreading or "layer", "samples_per_taxel": 19,
            "grid": ContactGrid(spacing=grid_spacing, margin=margin)}


#: taxels whose normal is within this cosine of the press direction make the pressed surface (the
#: plane solve's own cut, :func:`vtcore.contact.press`)
FACING = 0.1


class _Prober:
    """Presses of the probe (or a pair of probes) at the sample points on the live taxels, counted.

    Each press sees only the live taxels within ``reach`` m of its point (``reach`` plus half the
    pair's separation for two probes) that face its press direction: the plane solve makes one
    height field of every taxel it is given, and a skin wrapped round a link (a fill covering
    +-110 degrees of a 72 mm link, its modules apart) put taxels of the far flanks into that field,
    whose fit between them rose above the real surface where the probe was pressed: the press found
    contact there, not on the taxels under it (the --quick link_1000 rows, 1,643 % off). A taxel
    beyond ``reach`` reads nothing in the maps either (their table ends there)."""

    def __init__(self, live, mesh, layer, kw: dict, points, normals, e1s, e2s, reach: float):
        from ..contact import press

        self._press = press
        self.live, self.mesh, self.layer, self.kw = live, mesh, layer, kw
        self.points, self.normals, self.e1s, self.e2s = points, normals, e1s, e2s
        self.reach = float(reach)
        self.presses = 0

    def _near(self, i: int, radius: float) -> np.ndarray:
        """(N_live,) bool: the live taxels within ``radius`` m of point ``i`` facing its normal."""
        d = np.linalg.norm(self.live.positions - self.points[i], axis=1)
        return (d <= radius) & (self.live.normals @ self.normals[i] > FACING)

    def _pressed(self, i: int, mesh, pose, force: float, radius: float, **extra) -> np.ndarray:
        """(N_live,) Pa: ``mesh`` at ``pose`` pressed along ``-normal`` of point ``i`` on its near taxels
        (:meth:`_near`), zero elsewhere."""
        self.presses += 1
        near = self._near(i, radius)
        out = np.zeros(len(self.live))
        if not near.any():
            return out
        res = self._press(self.live.subset(near), mesh, pose, self.layer, force=force, direction=-self.normals[i],
                          **self.kw, **extra)
        out[near] = res.pressure
        return out

    def read(self, i: int, force: float) -> np.ndarray:
        """(N_live,) Pa: the probe pressed at point ``i`` along ``-normal`` to ``force`` N."""
        pose = probe_pose(self.mesh, self.points[i], self.normals[i], self.e1s[i], self.e2s[i], self.layer.thickness)
        return self._pressed(i, self.mesh, pose, force, self.reach)

    def read_pair(self, i: int, separation: float, e1, e2, force: float) -> np.ndarray:
        """(N_live,) Pa: two probes ``separation`` m apart along ``e2`` pressed at point ``i``."""
        pair = two_probes(self.mesh, separation)
        pose = probe_pose(pair, self.points[i], self.normals[i], e1, e2, self.layer.thickness)
        # overlapping copies are no closed mesh; the press needs only the surface facing
        # the skin along the press direction (its lower envelope)
        return self._pressed(i, pair, pose, force, self.reach + 0.5 * separation, open_mesh="envelope")


def reference_points(layout, points, normals, layer, settings: Settings, noise: SensorNoise, *,
                     threshold_points=(), two_point_points=(), two_point_directions=(0.0,),
                     grid_spacing: float = 5e-4, margin: float = 0.02, rel_tol: float = 0.01) -> Reference:
    """Press-by-press maps at ``points (M, 3)`` / ``normals (M, 3)``: localisation at every point, the
    detection threshold at ``threshold_points`` (indices; bisection on the force to ``rel_tol``), the
    two-point distance at ``two_point_points`` for the pair's orientations ``two_point_directions``
    (radians from the point's first tangent, worst taken)."""
    from ..layout import skin_mesh
    from .design import table_for

    points = np.asarray(points, float).reshape(-1, 3)
    normals = np.asarray(normals, float).reshape(-1, 3)
    normals = normals / np.linalg.norm(normals, axis=1, keepdims=True)
    alive = live_taxels(layout, settings.dead)
    live = layout.subset(alive)
    mesh = settings.probe.mesh()
    kw = _press_kw(settings, grid_spacing, margin)
    e1s, e2s = frames(normals, settings.probe.yaw, settings.probe_axis)
    reach = table_for(settings, layer).reach
    nb = neighbours(live.positions, live.normals, points, normals, reach, settings.probe.yaw,
                    axis=settings.probe_axis)
    probe = _Prober(live, mesh, layer, kw, points, normals, e1s, e2s, reach)

    mean = np.zeros(nb.index.shape)
    for i in range(len(points)):
        try:
            p = probe.read(i, settings.reference_force)
        except UnreachableTargetError:  # the probe bottoms out here (a curved patch's crest): reads nothing
            continue
        ok = nb.index[i] >= 0
        mean[i, ok] = noise.counts(p[nb.index[i, ok]])
    loc = localise(mean, nb, noise, draws=settings.draws, seed=settings.seed, error_cap=settings.error_cap)

    thr = np.full(len(points), np.nan)
    for i in threshold_points:
        thr[i] = _threshold_force(probe, i, noise.threshold_pa, settings.force_max, rel_tol)

    tp = np.full(len(points), np.nan)
    if len(two_point_points):
        adj = skin_mesh(live).adjacency
        band = BAND_SPACINGS * taxel_spacing(live.positions)
        seps = separations(settings.probe.width(), settings.two_point_step, settings.max_separation)
        for i in two_point_points:
            worst = 0.0
            for a in two_point_directions:
                worst = max(worst, _two_point_distance(probe, i, a, seps, band, adj, settings, noise))
            tp[i] = worst
    return Reference(thr, loc, tp, probe.presses, mean)


def _threshold_force(probe: _Prober, i: int, need: float, force_max: float, rel_tol: float) -> float:
    """The least force (N) at point ``i`` whose largest reading reaches ``need`` Pa, by bisection
    on a log scale to ``rel_tol`` (inf when ``force_max`` does not reach it; a force the probe
    cannot reach because it bottoms out counts as felt)."""
    lo, hi = 1e-3, force_max
    try:
        if probe.read(i, hi).max() < need:
            return np.inf
    except UnreachableTargetError:
        hi = force_max / 2
    while hi / lo > 1 + rel_tol:
        mid = np.sqrt(lo * hi)
        try:
            ok = probe.read(i, mid).max() >= need
        except UnreachableTargetError:
            ok = True
        lo, hi = (lo, mid) if ok else (mid, hi)
    return np.sqrt(lo * hi)


def _two_point_distance(probe: _Prober, i: int, a: float, seps, band: float, adj, settings: Settings,
                        noise: SensorNoise) -> float:
    """The least separation (m) among ``seps`` at which two probes at point ``i``, their pair turned
    by ``a`` radians from the point's first tangent, read as two blobs (``max_separation`` if none)."""
    normal = probe.normals[i]
    e1 = np.cos(a) * probe.e1s[i] + np.sin(a) * probe.e2s[i]
    e2 = np.cross(normal, e1)
    rel = probe.live.positions - probe.points[i]
    for s in seps:
        p = probe.read_pair(i, s, e1, e2, 2 * settings.reference_force)
        p = np.where(np.abs(rel @ e1) <= band, noise.counts(p), 0.0)
        level = max(noise.threshold_counts, BLOB_FRACTION * p.max())
        if split_blobs((p > level)[None], np.arange(len(p))[None], (rel @ e2)[None], adj)[0]:
            return s
    return settings.max_separation
