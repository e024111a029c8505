"""Local compliance from probing (seed 000, Sect. 2.1, Eq. 1) and the tactile point cloud.

A probe pushes the end-effector along the surface normal at a visual point
``v`` until the mean taxel response reaches ``p_mean`` (p̄* = 4000 counts in
the paper); at steady state the end-effector is at ``v_ss``. Eq. 1:

    c = p̄ / ||v_ss - v||           (counts per metre; larger c = stiffer)

The displacement is that of the end-effector, i.e. the object's local
deformation in series with the soft layer's. Recorded probes are read from CSV
or NPZ (:func:`load_probes`).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import FormatError, InputError
from ..tolerances import EPS, LENGTH_TOL

#: Displacements at or below this (metres) count as zero: no deformation was measured.
MIN_DISPLACEMENT = LENGTH_TOL


def compliance(p_mean, v_ss, v, direction=None, *, min_displacement: float = MIN_DISPLACEMENT):
    """Eq. 1 of seed 000: ``c = p̄ / ||v_ss - v||``.

    Parameters
    ----------
    p_mean : float or (n,) float, steady-state mean taxel response, counts (> 0).
    v_ss : (3,) or (n, 3) float, metres, end-effector position at steady state.
    v : (3,) or (n, 3) float, metres, the probed point (where the push started).
    direction : None or (3,) / (n, 3) float, the push direction (into the object,
        normally minus the surface normal). When given, the displacement is the
        signed projection ``(v_ss - v) . direction``, so an end-effector that
        ended *behind* its start (negative displacement) is caught instead of
        being hidden by the norm.
    min_displacement : float, metres; smaller displacements are an error.

    Returns
    -------
    c : float or (n,) float, counts per metre.

    Raises
    ------
    InputError if a displacement is zero, negative or not finite, or p̄ <= 0;
    the message names the probe index. No inf or NaN is ever returned.
    """
    scalar = np.ndim(p_mean) == 0 and np.ndim(v_ss) == 1
    p = np.atleast_1d(np.asarray(p_mean, dtype=np.float64))
    a = np.atleast_2d(np.asarray(v_ss, dtype=np.float64))
    b = np.atleast_2d(np.asarray(v, dtype=np.float64))
    if a.shape[-1] != 3 or b.shape[-1] != 3:
        raise InputError(f"v_ss and v must be (3,) or (n, 3) metres, got {a.shape} and {b.shape}", key="v_ss")
    n = max(len(p), len(a), len(b))
    try:
        p, a, b = np.broadcast_to(p, (n,)), np.broadcast_to(a, (n, 3)), np.broadcast_to(b, (n, 3))
    except ValueError:
        raise InputError(f"p_mean {p.shape}, v_ss {a.shape} and v {b.shape} do not have matching rows",
                         key="p_mean") from None
    delta = a - b
    if direction is None:
        disp = np.linalg.norm(delta, axis=1)
    else:
        d = np.atleast_2d(np.asarray(direction, dtype=np.float64))
        norm = np.linalg.norm(d, axis=1, keepdims=True)
        if d.shape[-1] != 3 or np.any(~np.isfinite(norm)) or np.any(norm < EPS):
            raise InputError("must be non-zero (3,) or (n, 3) vectors", key="direction")
        disp = np.einsum("ij,ij->i", delta, np.broadcast_to(d / norm, (n, 3)))
    bad = ~np.isfinite(disp) | (disp <= min_displacement)
    if np.any(bad):
        i = int(np.flatnonzero(bad)[0])
        what = "negative" if disp[i] < 0 else "zero" if np.isfinite(disp[i]) else "not finite"
        raise InputError(
            f"probe {i}: the end-effector displacement is {what} ({disp[i]:.3g} m): Eq. 1 "
            f"(c = p̄ / ||v_ss - v||) needs the end-effector to have moved into the object by more "
            f"than {min_displacement:g} m; check that v is the start of the push and v_ss the steady state",
            key="displacement")
    badp = ~np.isfinite(p) | (p <= 0)
    if np.any(badp):
        i = int(np.flatnonzero(badp)[0])
        raise InputError(f"probe {i}: the mean response must be a positive number of counts, got {p[i]}",
                         key="p_mean")
    c = p / disp
    return float(c[0]) if scalar else c


@dataclass
class TactilePointCloud:
    """The tactile point cloud T = {(v_i, c_i)} of seed 000.

    points : (n, 3) float, metres, the probed points v_i.
    values : (n,) or (n, k) float, the tactile colours (c in counts per metre,
        then any further channels such as friction).
    p_mean : (n,) float, counts; displacement : (n,) float, metres (when probed).
    channels : names of the value channels.
    """

    points: np.ndarray
    values: np.ndarray
    p_mean: np.ndarray | None = None
    displacement: np.ndarray | None = None
    channels: tuple[str, ...] = ("compliance",)

    @classmethod
    def from_probes(cls, v, v_ss, p_mean, direction=None) -> "TactilePointCloud":
        """Eq. 1 at every probe. v, v_ss : (n, 3) metres; p_mean : (n,) counts."""
        v = np.atleast_2d(np.asarray(v, dtype=np.float64))
        v_ss = np.atleast_2d(np.asarray(v_ss, dtype=np.float64))
        c = np.atleast_1d(compliance(p_mean, v_ss, v, direction))
        if direction is None:
            disp = np.linalg.norm(v_ss - v, axis=1)
        else:
            d = np.atleast_2d(np.asarray(direction, float))
            disp = np.einsum("ij,ij->i", v_ss - v, d / np.linalg.norm(d, axis=1, keepdims=True))
        return cls(points=v, values=c, p_mean=np.broadcast_to(np.asarray(p_mean, float), c.shape).copy(),
                   displacement=disp)

    def with_channel(self, name: str, values) -> "TactilePointCloud":
        """A copy with one more value channel (e.g. friction) per touch."""
        extra = np.asarray(values, dtype=np.float64).reshape(len(self.points), 1)
        base = self.values.reshape(len(self.points), -1)
        return TactilePointCloud(self.points, np.concatenate([base, extra], axis=1), self.p_mean,
                                 self.displacement, tuple(self.channels) + (name,))

    def __len__(self) -> int:
        return len(self.points)


_CSV_COLUMNS = ("x", "y", "z", "p_mean", "x_ss", "y_ss", "z_ss")


def load_probes(path) -> TactilePointCloud:
    """Recorded probes -> :class:`TactilePointCloud` (Eq. 1 applied to each).

    CSV: a header naming at least ``x, y, z, p_mean, x_ss, y_ss, z_ss`` (metres,
    counts), optionally ``nx, ny, nz`` (outward normal: the push direction is
    its opposite, so a negative displacement is detected). NPZ: arrays
    ``contact_points (n, 3)``, ``p_mean (n,)``, ``steady_state (n, 3)``,
    optionally ``normals (n, 3)``.
    """
    path = Path(path)
    if not path.exists():
        raise FormatError("probe file not found", file=path)
    if path.suffix.lower() == ".npz":
        try:
            with np.load(path, allow_pickle=False) as z:
                data = {k: np.asarray(z[k], dtype=np.float64) for k in z.files}
        except Exception as exc:  # noqa: BLE001 - any unreadable archive is a format error
            raise FormatError(f"not a readable .npz: {exc}", file=path) from None
        for k in ("contact_points", "p_mean", "steady_state"):
            if k not in data:
                raise FormatError(f"missing array {k!r}; needs contact_points, p_mean, steady_state", file=path,
                                  key=k)
        v, p, vss = data["contact_points"], data["p_mean"], data["steady_state"]
        nrm = data.get("normals")
    elif path.suffix.lower() == ".csv":
        lines = path.read_text(encoding="utf-8").splitlines()
        if not lines:
            raise FormatError("empty file; expected a header line", file=path, line=1)
        header = [h.strip() for h in lines[0].split(",")]
        missing = [c for c in _CSV_COLUMNS if c not in header]
        if missing:
            raise FormatError(f"header lacks columns {', '.join(missing)}; needs {', '.join(_CSV_COLUMNS)}"
                              " [, nx, ny, nz]", file=path, line=1)
        rows = []
        for i, line in enumerate(lines[1:], start=2):
            if not line.strip() or line.lstrip().startswith("#"):
                continue
            cells = line.split(",")
            if len(cells) != len(header):
                raise FormatError(f"has {len(cells)} fields, header has {len(header)}", file=path, line=i)
            try:
                rows.append([float(c) for c in cells])
            except ValueError:
                raise FormatError(f"non-numeric field in {line!r}", file=path, line=i) from None
        if not rows:
            raise FormatError("no probe rows after the header", file=path, line=2)
        arr = np.asarray(rows)
        col = {h: arr[:, j] for j, h in enumerate(header)}
        v = np.stack([col["x"], col["y"], col["z"]], axis=1)
        vss = np.stack([col["x_ss"], col["y_ss"], col["z_ss"]], axis=1)
        p = col["p_mean"]
        nrm = np.stack([col["nx"], col["ny"], col["nz"]], axis=1) if all(k in col for k in ("nx", "ny", "nz")) \
            else None
    else:
        raise FormatError(f"unknown probe file type {path.suffix!r}; use .csv or .npz", file=path)
    try:
        return TactilePointCloud.from_probes(v, vss, p, None if nrm is None else -nrm)
    except InputError as exc:
        raise FormatError(exc.reason, file=path, key=exc.key) from None


# ---------------------------------------------------------------------------
# a self-contained probe model
# ---------------------------------------------------------------------------

@dataclass
class ProbeModel:
    """Force-controlled probing of a compliant object through the skin's soft layer.

    The end-effector pushes along ``-normal`` until the mean response reaches
    ``target`` counts. The response is proportional to the contact force
    (``counts_per_newton``), and the displacement is the object's local
    deflection in series with the layer's: ``u = F / k_object(x) + F / k_layer``.

    target : float, counts (paper: 4000). counts_per_newton : float.
    layer_stiffness : float, N/m, of the soft layer under the sensor patch.
    response_noise : float, counts, standard deviation of the averaged steady-state p̄.
    position_noise : float, metres, standard deviation of the measured v_ss along the push.
    """

    target: float = 4000.0
    counts_per_newton: float = 2000.0
    layer_stiffness: float = 5000.0
    response_noise: float = 5.0
    position_noise: float = 2e-5

    def true_c(self, stiffness) -> np.ndarray:
        """Noise-free Eq. 1 for object stiffness (N/m): ``counts_per_newton / (1/k + 1/k_layer)``."""
        k = np.asarray(stiffness, dtype=np.float64)
        return self.counts_per_newton / (1.0 / k + 1.0 / self.layer_stiffness)

    def probe(self, points, normals, stiffness, rng=None):
        """Probe at ``points`` (n, 3) metres with outward ``normals`` (n, 3), object stiffness (n,) N/m.

        Returns ``(p_mean (n,) counts, v_ss (n, 3) metres)``.
        """
        rng = np.random.default_rng(rng)
        v = np.atleast_2d(np.asarray(points, float))
        nrm = np.atleast_2d(np.asarray(normals, float))
        nrm = nrm / np.linalg.norm(nrm, axis=1, keepdims=True)
        k = np.asarray(stiffness, float).reshape(-1)
        if np.any(~np.isfinite(k)) or np.any(k <= 0):
            raise InputError("object stiffness must be positive and finite (N/m)", key="stiffness")
        p = self.target + rng.normal(0.0, self.response_noise, len(v))
        force = p / self.counts_per_newton
        u = force / k + force / self.layer_stiffness + rng.normal(0.0, self.position_noise, len(v))
        return p, v - u[:, None] * nrm
