"""The contact simulator's response along a path, tabulated for a control loop (seed 000, Fig. 9).

A force-controlled slide needs the skin's reading at every 2 ms step; a contact solve per
step would be too slow. :func:`contact_response_table` presses the sensor module at
stations along the planned path over a short force sweep (the object's compliance in
series) and :class:`ResponseTable` interpolates each taxel's reading p(s, u) between them.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import InputError
from ..tolerances import EPS


@dataclass
class ResponseTable:
    """The contact simulator's mean response along a path, tabulated for the control loop.

    s : (S,) metres, arc length of the stations. u : (S, U) metres, end-effector
    displacement beyond the planned path (increasing along each row; the first
    entry, at zero response, is the gap to the real surface). p : (S, U) counts,
    mean response p̄ at that displacement. taxels : optional (S, U, N) counts, each
    taxel's noise-free reading (its mean over N is ``p``): with it the control loop
    adds the skin's read noise per taxel and clips at 0 as the real read-out does.
    Between stations and displacements the response is interpolated linearly;
    beyond the last displacement it is extrapolated with the last slope (the
    stiffest the table saw).
    """

    s: np.ndarray
    u: np.ndarray
    p: np.ndarray
    taxels: np.ndarray | None = None

    def taxel_response(self, s_value: float, u: float) -> np.ndarray:
        """(N,) counts of each taxel at ``s_value`` and displacement ``u`` (needs ``taxels``)."""
        if len(self.s) == 1:
            return self._taxel_curve(0, u)
        j = int(np.clip(np.searchsorted(self.s, s_value) - 1, 0, len(self.s) - 2))
        w = float(np.clip((s_value - self.s[j]) / (self.s[j + 1] - self.s[j]), 0.0, 1.0))
        return (1.0 - w) * self._taxel_curve(j, u) + w * self._taxel_curve(j + 1, u)

    def _taxel_curve(self, j, u):
        uu, tt = self.u[j], self.taxels[j]
        if u <= uu[0]:
            return np.zeros(tt.shape[1])
        k = int(np.clip(np.searchsorted(uu, u) - 1, 0, len(uu) - 2))
        w = (u - uu[k]) / max(uu[k + 1] - uu[k], EPS)             # > 1 beyond the table: the last slope
        return np.clip(tt[k] + w * (tt[k + 1] - tt[k]), 0.0, None)

    def response(self, s_value: float, u: float) -> float:
        j = int(np.clip(np.searchsorted(self.s, s_value) - 1, 0, len(self.s) - 2)) if len(self.s) > 1 else 0
        if len(self.s) == 1:
            return self._curve(0, u)
        w = float(np.clip((s_value - self.s[j]) / (self.s[j + 1] - self.s[j]), 0.0, 1.0))
        return (1.0 - w) * self._curve(j, u) + w * self._curve(j + 1, u)

    def response_gap(self, s_value: float) -> float:
        """Displacement (m) at which the module first touches the surface at ``s_value``."""
        return float(np.interp(s_value, self.s, self.u[:, 0]))

    def displacement_for(self, s_value: float, p_target: float) -> float:
        """Displacement (m) giving ``p_target`` counts at ``s_value`` (inverse of the nearest curve)."""
        j = int(np.argmin(np.abs(self.s - s_value)))
        uu, pp = self.u[j], self.p[j]
        if p_target <= pp[-1]:
            return float(np.interp(p_target, pp, uu))
        slope = (pp[-1] - pp[-2]) / max(uu[-1] - uu[-2], EPS)
        return float(uu[-1] + (p_target - pp[-1]) / max(slope, EPS))

    def _curve(self, j, u):
        uu, pp = self.u[j], self.p[j]
        if u <= uu[-1]:
            return float(np.interp(u, uu, pp, left=0.0))
        slope = (pp[-1] - pp[-2]) / max(uu[-1] - uu[-2], EPS)
        return float(pp[-1] + slope * (u - uu[-1]))


def contact_response_table(mesh, start, end, normal, layer, *, stiffness=None, counts=None, stations=27,
                           forces=(0.02, 0.05, 0.1, 0.2, 0.4, 0.7, 1.0, 1.5, 2.5), layout=None,
                           **press_kw) -> ResponseTable:
    """Tabulate p̄(u) along a straight path with the contact simulator (one CySkin module).

    mesh : the object (metres). start, end : (3,) metres, the planned path.
    normal : (3,) or callable (P, 3) -> (P, 3), outward surface normal along it (the
    end-effector stays aligned with it). layer : vtcore.contact.SoftLayer.
    stiffness : callable ``(result) -> k`` N/m of the object at a press's contact
    (object compliance in series), or None for a rigid object. counts : callable
    pressure (N,) Pa -> counts (N,) (noise-free sensor transfer; default 0.1 counts/Pa).
    stations : how many, evenly spaced, or the arc lengths (m, increasing) where to press
    (denser where the surface has a feature the module can lose). Each station is pressed at
    ``forces`` (N); other keywords go to ``press``.
    """
    from ..augment.probing import cyskin_module_layout, probe_pose
    from ..contact import press

    layout = layout or cyskin_module_layout()
    a, b = np.asarray(start, float), np.asarray(end, float)
    length = float(np.linalg.norm(b - a))
    s = np.linspace(0.0, length, max(int(stations), 1)) if np.ndim(stations) == 0 \
        else np.asarray(stations, dtype=np.float64)
    if s.ndim != 1 or len(s) == 0 or np.any(np.diff(s) <= 0) or s[0] < 0 or s[-1] > length + 1e-12:
        raise InputError(f"stations must be a count or increasing arc lengths within 0..{length:g} m", key="stations")
    pts = a + s[:, None] * (b - a) / max(length, EPS)
    nrm = normal(pts) if callable(normal) else np.broadcast_to(np.asarray(normal, float), pts.shape)
    counts = counts or (lambda pr: 0.1 * pr)
    pre = 2e-3                                   # start 2 mm off the planned point, subtract it after
    us, ts = [], []
    for i in range(len(s)):                      # one short force sweep per station
        pose = probe_pose(pts[i], nrm[i], layer.thickness, gap=pre)
        u_row, t_row, prev, gap0 = [], [], None, None
        for f in forces:
            r = press(layout, mesh, pose, layer, force=float(f), warm_start=prev, **press_kw)
            prev = r
            if gap0 is None:
                # zero response where the module first touches the real surface: travel minus indentation
                gap0 = r.travel - pre - r.indentation
            defl = f / float(stiffness(r)) if stiffness is not None else 0.0
            u_row.append(r.travel - pre + defl)
            t_row.append(np.asarray(counts(r.pressure), dtype=np.float64))
        us.append([gap0] + u_row)
        ts.append([np.zeros_like(t_row[0])] + t_row)
    u, taxels = np.asarray(us), np.asarray(ts)
    u = np.maximum.accumulate(u, axis=1)         # guard against solver round-off: keep each row monotone
    return ResponseTable(s=s, u=u, p=taxels.mean(axis=2), taxels=taxels)
