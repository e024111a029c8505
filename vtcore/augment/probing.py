"""Probing with the contact simulator (seed 000, Sect. 2.1 and 3).

The paper's sensor is one CySkin module (10 transducers, 4 mm, 7.5 mm pitch)
on the end-effector. For each contact point ``v`` of the visual cloud the
end-effector is aligned with the normal at ``v`` and pushed until the mean
response reaches p̄* (``vtcore.contact.probe``: a soft-layer contact solve
inside a monotone force bracket); the end-effector's displacement from first
contact is the layer's indentation plus the object's own deflection
``F / k(contact point)`` (the object-compliance effect). The steady-state
readings (optionally through the sensor effects: noise, quantisation...) are
averaged into p̄, and Eq. 1 gives the colour.
"""

from __future__ import annotations

from typing import Callable

import numpy as np

from ..errors import InputError, UnreachableTargetError
from ..geometry import tangent_basis


def cyskin_module_layout():
    """One flat CySkin module (10 taxels, 7.5 mm pitch) centred at the origin, facing +z."""
    from ..layout import Layout
    from ..layout.patches import make_patch

    patch = make_patch("triangle")
    flat = patch.flat - patch.flat.mean(axis=0)
    n = len(flat)
    return Layout(np.c_[flat, np.zeros(n)], np.tile([0.0, 0.0, 1.0], (n, 1)), patch.taxel_ids, patch.module_ids,
                  flat=flat, meta={"patch": "triangle", "module": "cyskin10"})


def probe_pose(v, n, top: float, gap: float = 0.0) -> np.ndarray:
    """4x4 pose of the object in the end-effector frame that puts ``v`` above the skin's centre.

    v : (3,) metres, the contact point on the object; n : (3,) its outward normal,
    turned to face the skin (-z); top : metres, height of the layer's outer
    surface; gap : metres left before contact.
    """
    v = np.asarray(v, float)
    z = -np.asarray(n, float) / np.linalg.norm(n)
    t1, t2 = tangent_basis(z)
    x, y = -t2, t1  # (helper x z, z x that): the frame this function has always used
    rot = np.vstack([x, y, z])                     # object frame -> end-effector frame; n -> -z
    pose = np.eye(4)
    pose[:3, :3] = rot
    pose[:3, 3] = -rot @ v + np.array([0.0, 0.0, top + gap])
    return pose


class ContactProber:
    """Callable ``(points (n, 3), normals (n, 3)) -> (p_mean (n,), v_ss (n, 3))`` for probe_object.

    obj : CompliantObject (mesh in metres, stiffness field N/m). layer : vtcore.contact.SoftLayer.
    target : counts (p̄*). counts_per_pa : the sensor gain the force control uses.
    stiffness : callable ``(obj_stiffness, mesh, press_result) -> k`` giving the
        object's stiffness at the contact (the scene's ``object_compliance``
        effect), or None for a rigid object (the displacement is then the layer's only).
    readout : callable ``pressure (T, N) Pa -> counts (T, N)`` applied to ``readings``
        copies of the steady-state pressure (the scene's sensor effects), or None
        for the noise-free gain. spread : spread through the layer (``soft_layer``).
    sensor : callable ``pressure (N,) Pa -> counts (N,)``, the noise-free transfer the
        force control inverts (the scene's ``gain`` effect), default ``counts_per_pa * p``.
    press_kw : further keywords for ``vtcore.contact.press`` (grid, backend, ...).
    on_unreachable : "nan" (default) marks a probe whose target cannot be reached
        (a sharp curvature where the flat module bottoms out the layer) with NaN
        and records it in ``failures``; "raise" raises UnreachableTargetError.
    """

    def __init__(self, obj, layer, *, target: float = 4000.0, counts_per_pa: float = 0.5,
                 stiffness: Callable | None = None, readout: Callable | None = None, readings: int = 10,
                 spread: bool = True, model: str = "finite_layer", grid=None, force_max: float = 100.0,
                 on_unreachable: str = "nan", sensor: Callable | None = None, press_kw: dict | None = None):
        self.obj, self.layer = obj, layer
        self.target, self.counts_per_pa = float(target), float(counts_per_pa)
        self.stiffness, self.readout, self.readings = stiffness, readout, int(readings)
        self.spread, self.model, self.grid, self.force_max = spread, model, grid, force_max
        self.layout = cyskin_module_layout()
        self.on_unreachable = on_unreachable
        self.sensor = sensor
        self.press_kw = dict(press_kw or {})
        self.results = []
        self.failures: list[tuple[np.ndarray, str]] = []

    def __call__(self, points, normals):
        from ..contact import probe

        pts = np.atleast_2d(np.asarray(points, float))
        nrm = np.atleast_2d(np.asarray(normals, float))
        p_mean = np.empty(len(pts))
        disp = np.empty(len(pts))
        kw = dict(self.press_kw)
        if self.grid is not None:
            kw["grid"] = self.grid
        for i in range(len(pts)):          # one contact solve per touch (24 on a bottle)
            pose = probe_pose(pts[i], nrm[i], self.layer.thickness)
            try:
                r = probe(self.layout, self.obj.mesh, pose, self.layer, target=self.target,
                          counts_per_pa=self.counts_per_pa, sensor=self.sensor, force_max=self.force_max,
                          model=self.model, spread=self.spread, **kw)
            except UnreachableTargetError as exc:
                if self.on_unreachable == "raise":
                    raise UnreachableTargetError(f"probe {i} at {np.round(pts[i], 4).tolist()} m: {exc}") from None
                # a real force controller would saturate there: no valid Eq. 1 sample at this point
                p_mean[i], disp[i] = np.nan, np.nan
                self.failures.append((pts[i].copy(), str(exc)))
                continue
            defl = 0.0
            if self.stiffness is not None and r.force > 0:
                k = float(self.stiffness(self.obj.stiffness, self.obj.mesh, r.result))
                if not (np.isfinite(k) and k > 0):
                    raise InputError(f"object stiffness at probe {i} must be > 0 N/m, got {k}", key="stiffness")
                defl = r.force / k
            disp[i] = r.result.indentation + defl
            if self.readout is None:
                p_mean[i] = r.mean_response
            else:
                frames = np.broadcast_to(r.result.pressure, (self.readings, len(r.result.pressure))).copy()
                p_mean[i] = float(np.mean(self.readout(frames)))
            self.results.append(r)
        # the end-effector moved ``disp`` into the object along -n from the first contact at v
        return p_mean, pts - disp[:, None] * nrm / np.linalg.norm(nrm, axis=1, keepdims=True)
