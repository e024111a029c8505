"""What both press solvers share (the plane solve in :mod:`vtcore.contact.press`, the unrolled one in
:mod:`vtcore.contact.curved`): the press frame, the object's footprint, and the finish of a press once
the pressure is solved (the bottom-out check and its message, travel and indentation, the readings,
the contact point, the object's own deflection) building the :class:`PressResult` they return.
"""

from __future__ import annotations

from dataclasses import dataclass
from dataclasses import field as dc_field

import numpy as np

from ..errors import InputError, UnreachableTargetError
from ..geometry import tangent_basis
from .grid import ContactField, taxel_readings

#: the 8 corners of the unit box, for an object's bounding box
CORNERS = np.array([[a, b, c] for a in (0, 1) for b in (0, 1) for c in (0, 1)], float)


@dataclass
class PressResult:
    """Outcome of one press.

    pressure : (N,) Pa, stress at the taxels (base of the layer), mean over each
        taxel's disc (after spreading through the layer when ``spread=True``;
        equal to ``surface_pressure`` otherwise).
    surface_pressure : (N,) Pa on the layer's outer surface above each taxel (disc mean).
    force : N, total normal force. indentation : m, travel of the object beyond first
        contact. contact_area : m^2. pose : (4, 4), the object's pose at the solution.
    travel : m, distance moved along ``direction`` from the given pose.
    displacement : m, end-effector displacement from first contact, = indentation +
        the object's own deflection (object compliance; seed 000 Eq. 1).
    bottomed_out : bool, the layer would be compressed by more than its thickness.
    max_compression : m. model : str. iterations, converged : solver report.
    field : ContactField on the grid. contact_point, contact_point_object : (3,) m,
    the force-weighted centre of the contact in the end-effector / object frame (NaN without contact).
    """

    pressure: np.ndarray
    surface_pressure: np.ndarray
    force: float
    indentation: float
    contact_area: float
    pose: np.ndarray
    travel: float = 0.0
    displacement: float = 0.0
    object_deflection: float = 0.0
    bottomed_out: bool = False
    max_compression: float = 0.0
    model: str = "finite_layer"
    iterations: int = 0
    converged: bool = True
    direction: np.ndarray = dc_field(default_factory=lambda: np.array([0.0, 0.0, -1.0]))
    field: ContactField | None = None
    spread: bool = True
    contact_point: np.ndarray = dc_field(default_factory=lambda: np.full(3, np.nan))
    contact_point_object: np.ndarray = dc_field(default_factory=lambda: np.full(3, np.nan))
    #: largest kernel value the compliance operator dropped, relative to its peak (0: the exact,
    #: fully padded convolution; see vtcore.contact.fft)
    kernel_truncation: float = 0.0


def press_frame(layout, direction):
    """(u, n, e1, e2) (3,) each: the press direction ``u`` (default: minus the mean taxel normal), the
    grid normal ``n = -u`` and two unit tangents completing a right-handed frame."""
    nrm = np.asarray(layout.normals, float)
    if direction is None:
        m = nrm.mean(axis=0)
        if np.linalg.norm(m) < 1e-9:
            raise InputError("taxel normals cancel out; give the press direction explicitly", key="direction")
        u = -m / np.linalg.norm(m)
    else:
        u = np.asarray(direction, float).reshape(3)
        if not np.all(np.isfinite(u)) or np.linalg.norm(u) < 1e-12:
            raise InputError(f"must be a non-zero 3-vector, got {direction}", key="direction")
        u = u / np.linalg.norm(u)
    n = -u
    e1, e2 = tangent_basis(n)
    return u, n, e1, e2


def object_stiffness(compliance, mesh_local, pose, point_world):
    """Stiffness (N/m) of the object at a contact point; None when no compliance is given."""
    if compliance is None:
        return None
    inv = np.linalg.inv(pose)
    p_obj = inv[:3, :3] @ point_world + inv[:3, 3]
    if callable(compliance):
        k = float(np.asarray(compliance(p_obj[None, :]), float).reshape(-1)[0])
    elif np.ndim(compliance) == 0:
        k = float(compliance)
    else:
        vals = np.asarray(compliance, float).reshape(-1)
        if len(vals) != len(mesh_local.vertices):
            raise InputError(f"per-vertex compliance has {len(vals)} values but the mesh has "
                             f"{len(mesh_local.vertices)} vertices", key="compliance")
        from scipy.spatial import cKDTree

        _, i = cKDTree(np.asarray(mesh_local.vertices, float)).query(p_obj, k=min(4, len(vals)))
        k = float(np.mean(vals[np.atleast_1d(i)]))
    if not (k > 0 and np.isfinite(k)):
        raise InputError(f"object stiffness must be > 0 N/m, got {k}", key="compliance")
    return k


def footprint(local, pose, e1, e2, origin=np.zeros(3)):
    """The posed object's bounding box projected on the grid's tangents: (b1 (8,), b2 (8,)) m.

    local : the object mesh in its own frame. pose : (4, 4). e1, e2 (3,) unit tangents;
    origin (3,) m, subtracted first. Only grid cells inside [b1.min(), b1.max()] x [b2.min(),
    b2.max()] (plus a cell) can meet the object: rays are cast there alone.
    """
    box = local.bounds[0] + CORNERS * (local.bounds[1] - local.bounds[0])
    box = box @ pose[:3, :3].T + pose[:3, 3] - origin
    return box @ e1, box @ e2


def require_contact(finite, force, u):
    """Raise UnreachableTargetError when a target ``force`` > 0 (N) is asked but no grid cell meets the
    object (``finite`` (mx, my) bool: the cells with a finite gap) along the press direction ``u`` (3,)."""
    if force is not None and force > 0 and not finite.any():
        raise UnreachableTargetError(
            f"the object never meets the skin along the press direction {np.round(u, 3).tolist()}: "
            f"no force can be reached (target {force} N)")


def check_compression(compression, h, force, model, where=""):
    """Largest compression (m) of the layer over the contact cells and whether it exceeds the
    thickness ``h`` (m); raises UnreachableTargetError when a target ``force`` > 0 would need it.

    compression : (mx, my) m, 0 outside the contact. where : how the solve measures it, for the
    message (e.g. " along its normal (unrolled)").
    """
    max_c = float(compression.max()) if compression.any() else 0.0
    bottomed = max_c > h * (1 + 1e-9)
    if force is not None and force > 0 and bottomed:
        raise UnreachableTargetError(
            f"{force} N would compress the {h * 1e3:.3g} mm layer by {max_c * 1e3:.3g} mm{where} (model {model}): "
            "the object bottoms out on the end-effector before reaching the target force; use a thicker or "
            "stiffer layer or a lower force (docs/contact.md, 'The mug rim at 15 N')")
    return max_c, bottomed


def travel_and_indentation(d, gmin, force, indentation):
    """(travel, indentation) m: the object's move along the press from the given pose (0 when neither
    a force nor an indentation is asked: the pose is used as it is) and its travel beyond first
    contact (``gmin`` m, the smallest gap; for a pose used as it is, the interference ``-gmin``)."""
    posed = force is None and indentation is None
    travel = float(d) if not posed and np.isfinite(d) else 0.0
    indent = max(travel - gmin, 0.0) if np.isfinite(gmin) else 0.0
    if posed and np.isfinite(gmin):
        indent = max(-gmin, 0.0)
    return travel, indent


def moved(pose, travel, u):
    """(4, 4): ``pose`` translated by ``travel`` (m) along the unit direction ``u`` (3,)."""
    new_pose = np.asarray(pose, float).copy()
    new_pose[:3, 3] += travel * u
    return new_pose


def finish_press(layout, fld: ContactField, weights, points, *, pose, u, layer, force, indent, travel,
                 contact_area, max_compression, bottomed, model, iterations, converged, spread, spreading,
                 samples_per_taxel, taxel_radius, compliance=None, local=None, truncation=0.0) -> PressResult:
    """Read the solved contact and build the :class:`PressResult`.

    fld : the ContactField with its surface pressure (Pa) set. weights : (mx, my) >= 0, the force
    each cell carries along the press (any unit), > 0 exactly on the contact; points (mx, my, 3) m:
    the cells' outer-surface points, so the contact point is their force-weighted mean.
    pose : (4, 4) at the solution. force : N, the total along the press. compliance, local: the
    object's stiffness spec and its mesh (:func:`object_stiffness`), for its own deflection.
    truncation : what the compliance operator dropped (:attr:`PressResult.kernel_truncation`).
    """
    surf, taxel = taxel_readings(layout, fld, fld.pressure, layer, spread, spreading, samples_per_taxel,
                                 taxel_radius)
    cpt = np.full(3, np.nan)
    cpt_obj = np.full(3, np.nan)
    defl = 0.0
    if force > 0:
        on = weights > 0  # the contact cells only: the grid can be large and the contact small
        w = weights[on]
        cpt = np.einsum("m,mi->i", w, points[on]) / w.sum()
        cpt_obj = pose[:3, :3].T @ (cpt - pose[:3, 3])  # rigid inverse
        if compliance is not None:
            defl = force / object_stiffness(compliance, local, pose, cpt)
    return PressResult(
        pressure=taxel, surface_pressure=surf, force=force, indentation=indent, contact_area=contact_area,
        pose=pose, travel=travel, displacement=indent + defl, object_deflection=defl, bottomed_out=bool(bottomed),
        max_compression=max_compression, model=model, iterations=iterations, converged=bool(converged),
        direction=u, field=fld, spread=spread, contact_point=cpt, contact_point_object=cpt_obj,
        kernel_truncation=float(truncation))


class ResolutionWarning(UserWarning):
    """The contact grid does not resolve the contact or resolves the object's facets (a warning, the run goes on)."""


#: Fewest grid cells a contact should cover for its pressure (peak and shape) to be resolved.
MIN_CONTACT_CELLS = 16
#: Largest width of an object's curved facets, in grid cells, before the pressure follows the facets.
MAX_FACET_CELLS = 4.0
#: Angles (rad) between neighbouring faces that approximate a curved surface: flat (0) and sharp
#: (a cube's 90 degree) edges are the shape itself, not a tessellation.
FACET_ANGLES = (np.radians(0.5), np.radians(20.0))


def curved_facet_width(mesh) -> float:
    """Median width (m) of the facets that tessellate the object's curved surfaces; 0 if it has none.

    Over the pairs of faces meeting at a small angle (:data:`FACET_ANGLES`): the distance from their
    shared edge to the first face's other vertex (a sphere's triangle: its height; a cylinder's
    strip, whose shared edges run along the axis: the strip's width, not its length)."""
    ang = np.asarray(mesh.face_adjacency_angles, float)
    sel = (ang > FACET_ANGLES[0]) & (ang < FACET_ANGLES[1])
    if not sel.any():
        return 0.0
    v = np.asarray(mesh.vertices, float)
    e = np.asarray(mesh.face_adjacency_edges)[sel]
    u = np.asarray(mesh.face_adjacency_unshared)[sel, 0]
    a, b = v[e[:, 0]], v[e[:, 1]] - v[e[:, 0]]
    d = np.linalg.norm(np.cross(b, v[u] - a), axis=1) / np.maximum(np.linalg.norm(b, axis=1), 1e-300)
    return float(np.median(d))


def resolution_warnings(contact_area, spacing, mesh=None, *, grid_key="grid.spacing",
                        mesh_key="the object's mesh") -> list[str]:
    """What the grid does not resolve, one line each naming the key to change (empty when all is well).

    contact_area : (F,) m^2, the contact of each frame (0: no contact, not counted). spacing : grid
    cell side, m. mesh : the object's mesh (trimesh) or None. A contact of fewer than
    :data:`MIN_CONTACT_CELLS` cells has its peak and shape set by the grid, not the physics
    (E = 1e12 Pa put a sphere's contact in 4 cells: 2.5 MPa peak against Hertz's 1.5 GPa); curved
    facets wider than :data:`MAX_FACET_CELLS` cells print on the pressure (a 5,120-face sphere on a
    0.25 mm grid: 33 local maxima, a peak 21 % over Hertz's).
    """
    out = []
    area = np.asarray(contact_area, float)
    area = area[np.isfinite(area) & (area > 0)]
    if len(area):
        cells = float(area.min()) / spacing ** 2
        if cells < MIN_CONTACT_CELLS:
            need = spacing * np.sqrt(cells / MIN_CONTACT_CELLS)
            out.append(f"the contact covers only {cells:.3g} grid cells of {spacing * 1e3:.3g} mm (fewer than "
                       f"{MIN_CONTACT_CELLS}): its peak pressure and shape are the grid's, not the contact's; "
                       f"set {grid_key} below {need:.2g} m (finer still if the contact, sized by the grid here, "
                       "is smaller)")
    width = curved_facet_width(mesh) if mesh is not None else 0.0
    if width > MAX_FACET_CELLS * spacing:
        out.append(f"the object's curved facets are {width * 1e3:.3g} mm wide, {width / spacing:.3g} grid cells "
                   f"of {spacing * 1e3:.3g} mm: the pressure follows the facets (local maxima, peaks over the "
                   f"smooth shape's); refine {mesh_key} or set {grid_key} to {width / MAX_FACET_CELLS:.2g} m "
                   "or more")
    return out
