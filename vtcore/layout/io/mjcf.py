"""MuJoCo MJCF (export only): one site and one ``touch`` sensor per taxel.

A MuJoCo touch sensor sums the normal force of the contacts that involve *the body
its site belongs to* and whose contact point lies in the site's volume. So sites
sense only in a body that has collision geoms. Two ways to get there:

- the robot's own MJCF with the sites (this module's :func:`add_skin`) added to the link's
  body itself, placed by the layout's ``transform`` (the pose of the layout frame in that
  body; a CySkin ``tf_matrix``), and the sensors appended: :func:`vtcore.robot.export_skinned`
  (``vtcore robot export``, ``vtcore layout export --model``; the merge is
  :mod:`vtcore.robot.mjcf_tree`). The body's own collision geoms are what the ball touches; where the
  export gives the skin pads, each module's pads and sites go into a welded child body
  (:func:`module_body`), so that a touch sensor counts only its own module's pads (MuJoCo's ray from a
  contact along its normal goes on through the link to sites on its far side).
- the fragment (this module's :func:`write`): a ``<mujoco>`` file with one body named after the
  layout frame, at the layout's ``transform``, holding the sites and, by default, its
  own contact pad (see ``pad``). Attach it to a robot link with
  ``<attach model="skin" body="FRAME" prefix="skin/"/>`` or ``MjSpec.attach_body``;
  it becomes a child body welded to the link, and its pad is the surface the
  sensors count.

Footprints (``footprint=``):

- ``"taxel"`` (default, taxel fidelity): each site is a cylinder of the module's
  taxel diameter (CySkin: a 4 mm disc; ``site_radius`` overrides), axis along the
  taxel normal. A contact that lands between taxels reads nothing, as on the real skin.
- ``"tile"`` (force coverage): every taxel gets its own welded child body
  ``<site>_cell`` with a pad disc that covers its share of the surface (radius: the
  largest circumradius of the triangles around it: the file's faces, else the skin mesh, so the discs cover every
  triangle) and a site of the same size. Each contact lands on some taxel's pad and is
  counted by that taxel alone, so the readings sum to the contact force wherever it
  lands. The pads are the contact surface (``pad`` is implied). A body per taxel costs MuJoCo arena
  memory: its collision step takes two lists of all body pairs (8 bytes a pair) from the arena's stack at
  every step, and its default arena (13-18 MiB) does not grow with bodies. A plate with a 1,500-taxel
  tile skin stepped; with 2,000 (2,004 bodies, 16 MB of pairs) it stopped at its first step with
  ``mj_stackAlloc: out of memory``, and the UR10 skinned all over (7,670 taxels) failed in the export's own
  MuJoCo check (its first 118 MB list asked of 17 MiB). So a tile export sizes the arena (:func:`size_arena`:
  ``<size memory>``, the robot's own value raised, never lowered). A fragment carries its own
  ``<size>``, but MuJoCo keeps the parent's on attach (it warns "Attach conflict ... memory"): the robot
  that attaches it needs a ``<size memory>`` at least the fragment's plus its own.

``pad=True`` (``"taxel"`` footprint) adds the same covering discs as geoms of the
sites' own body: the contact surface for a link without collision geoms, or for the
fragment. Pads are ``pad_thickness`` thick and sit on the surface (their top face is
``pad_thickness`` above the taxel along its normal) and massless (``density="0"``): the
robot's dynamics do not change; they collide as MuJoCo's defaults do (``contype``,
``conaffinity`` 1, written out so that a visual-only ``childclass`` cannot switch them off).

Sensors are written in taxel order: ``data.sensordata[k]`` is taxel row ``k``.
Site names: ``{prefix}{n}`` with ``n`` the taxel id when ids are unique and
non-negative, else the row; sensors ``{prefix}{n}_touch``.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET

import numpy as np

from ..._io import write_xml
from ...errors import InputError
from ...tolerances import ZERO_NORMAL
from ..model import Layout
from .common import default_faces, identifier, taxel_labels

NAME = "mjcf"
SUFFIXES = (".xml", ".mjcf")
read = None  # export only
FOOTPRINTS = ("taxel", "tile")
SITE_MARGIN = 2e-3  # m, half-height of a site beyond its pad: contact points of soft contacts sit within it
#: bytes of arena stack per pair of bodies at every collision step: two lists of one int a pair over
#: nbody (nbody - 1) / 2 pairs, mj_collision's and mj_broadphase's own (measured, MuJoCo 4.0: the UR10 with
#: 7,681 bodies asked 117,980,160 bytes in mj_collision, then 117,888,012 more in mj_broadphase)
PAIR_BYTES = 8
#: bytes of arena per tile for its contacts when every tile is pressed at once (measured, a plate lying on a
#: 1,000 / 3,000-tile skin, nv 12: 3.6 / 3.1 contacts a tile; the arena's peak use, 8.8 / 34.7 MB, less one
#: 4-byte pair list: 6.9 / 5.6 KB a tile)
TILE_CONTACT_BYTES = 8 << 10


def _fmt(v) -> str:
    return format(float(v), ".9g")


def _vec(a) -> str:
    return " ".join(_fmt(v) for v in np.asarray(a).ravel())


def taxel_radius(layout: Layout) -> float:
    """Radius (m) of one taxel's sensing disc: the layout's module type (a layout read from an
    iCub file: the current iCub triangle, ``icub10``), else 2 mm (the CySkin 4 mm disc)."""
    from ..modules import TAXEL_DIAMETER, get_module

    if layout.meta.get("taxel_radius_m"):
        return float(layout.meta["taxel_radius_m"])
    name = layout.meta.get("module_type") or ("icub10" if layout.meta.get("id_scheme") == "icub" else None)
    if name:
        try:
            return get_module(name).taxel_diameter / 2
        except InputError:
            pass
    return TAXEL_DIAMETER / 2


def cover_radii(layout: Layout) -> np.ndarray:
    """(N,) m: per taxel, the radius of a disc that covers its share of every triangle around it.

    Every point of an acute triangle lies within its circumradius of one of its corners;
    in an obtuse one within half its longest edge. The largest such radius over the
    taxel's triangles (the file's faces, else the skin mesh) makes discs that cover the
    whole triangulated skin. A taxel in no triangle gets the median spacing.
    """
    n = len(layout)
    if n < 3:
        return np.full(n, taxel_radius(layout))
    tri = default_faces(layout)
    p = layout.positions
    a, b, c = p[tri[:, 0]], p[tri[:, 1]], p[tri[:, 2]]
    sides = np.column_stack([np.linalg.norm(b - c, axis=1), np.linalg.norm(c - a, axis=1),
                             np.linalg.norm(a - b, axis=1)])
    area2 = np.linalg.norm(np.cross(b - a, c - a), axis=1)  # twice the area
    longest = sides.max(axis=1)
    obtuse = 2 * longest ** 2 > (sides ** 2).sum(axis=1)
    # circumradius abc / (4 K) = abc / (2 * area2); zero-area triangles take the obtuse bound
    with np.errstate(divide="ignore", invalid="ignore"):
        circ = np.where(obtuse | (area2 <= 1e-18), longest / 2, sides.prod(axis=1) / (2 * area2))
    r = np.zeros(n)
    for k in range(3):  # per corner: a max over the incident triangles (vectorised)
        np.maximum.at(r, tri[:, k], circ)
    lonely = r <= 0
    if lonely.any():
        from scipy.spatial import cKDTree

        d, _ = cKDTree(layout.positions).query(layout.positions, k=2)
        r[lonely] = float(np.median(d[:, 1]))
    return r


def _quat(r: np.ndarray) -> np.ndarray:
    """(w, x, y, z) of a rotation matrix (MuJoCo's order)."""
    from scipy.spatial.transform import Rotation

    x, y, z, w = Rotation.from_matrix(r).as_quat()
    return np.array([w, x, y, z])


def add_skin(layout: Layout, parent: ET.Element, sensor: ET.Element, *, positions: np.ndarray,
             normals: np.ndarray, prefix: str, footprint: str = "taxel", pad: bool = False,
             site_radius: float | None = None, pad_thickness: float = 1e-3, reach=None,
             pad_radius: float | None = None) -> list[str]:
    """Add sites (and pads) for every taxel to the MJCF body ``parent`` and touch sensors to ``sensor``.

    positions, normals : (N, 3) in ``parent``'s frame (metres, unit normals).
    reach : None or (N,) metres: where along each taxel's normal the body's contact surface lies as
        MuJoCo collides it (a mesh geom's convex hull, ``vtcore.robot.reach``; negative: below the
        taxel). Each site reaches that far either way, so a contact on that surface counts; a tile's
        pad (its own body's contact surface) is raised to just above it.
    pad_radius : m, the ``"taxel"`` footprint's pads at most this wide (None: each covers its share
        of the skin, :func:`cover_radii`). Given (a robot export, with ``pad``), each module's pads and
        sites go into a welded child body of ``parent`` at its origin (:func:`module_body`): a pad stays
        under its own taxel, so that a wide pad on a curved link does not stand over its neighbours, and
        rises over the link's contact surface where that lies above the taxel; the site stays centred on
        its taxel (the taxel's frame on the link) and reaches over the pad.
    Returns the site names in taxel order.
    """
    if footprint not in FOOTPRINTS:
        raise InputError(f"footprint must be one of {', '.join(FOOTPRINTS)}, got {footprint!r}", key="footprint")
    if not (pad_thickness > 0):
        raise InputError(f"pad thickness must be > 0 m, got {pad_thickness}", key="pad_thickness")
    nz = np.linalg.norm(normals, axis=1)
    if np.any(nz < ZERO_NORMAL):
        raise InputError(f"{int((nz < ZERO_NORMAL).sum())} taxels have a zero normal; a site needs an axis "
                         "(estimate the normals first)", key="normals")
    normals = normals / nz[:, None]
    names = [f"{prefix}{lab}" for lab in taxel_labels(layout)]
    r_taxel = float(site_radius) if site_radius is not None else taxel_radius(layout)
    cover = cover_radii(layout) if (pad or footprint == "tile") else None
    if pad and footprint == "taxel" and pad_radius is not None:
        cover = np.minimum(cover, float(pad_radius))
    h = pad_thickness / 2
    reach = np.zeros(len(names)) if reach is None else np.asarray(reach, dtype=np.float64).reshape(len(names))
    green = "0.2 0.8 0.2 0.5"
    modules: dict = {}
    for k, name in enumerate(names):
        p, n = positions[k], normals[k]
        if pad and pad_radius is not None and footprint == "taxel":
            # a module's own body: MuJoCo's touch sensor counts a contact of its site's body whose normal ray
            # crosses the site, and that ray goes on through the link: with the sites in the link itself, a
            # ball on one face of the G1's torso was also counted by the sites on the opposite face (2 to 3 m g
            # in the drop check). One body per module, not per taxel: MuJoCo's broadphase holds a pair list
            # over bodies (a G1 with a cell per taxel overflowed its 16 MB arena)
            mid = int(layout.module_ids[k])
            if mid not in modules:
                modules[mid] = ET.SubElement(parent, "body", name=module_body(prefix, mid))
            _robot_taxel(modules[mid], name, p, n, cover[k], h, reach[k])
            continue
        if footprint == "tile":  # the pad is the contact surface of its own body: on, or just over, the link's
            hk = h + max(reach[k], 0.0) / 2
            cell = ET.SubElement(parent, "body", name=f"{name}_cell", pos=_vec(p), zaxis=_vec(n))
            ET.SubElement(cell, "geom", name=f"{name}_pad", type="cylinder", pos=_vec([0, 0, hk]),
                          size=f"{_fmt(cover[k])} {_fmt(hk)}", density="0", contype="1", conaffinity="1",
                          rgba="0.85 0.85 0.8 1")
            ET.SubElement(cell, "site", name=name, type="cylinder", pos=_vec([0, 0, hk]),
                          size=f"{_fmt(cover[k])} {_fmt(hk + SITE_MARGIN)}", rgba=green)
            continue
        centre = p + h * n if pad else p
        if pad:
            ET.SubElement(parent, "geom", name=f"{name}_pad", type="cylinder", pos=_vec(centre), zaxis=_vec(n),
                          size=f"{_fmt(cover[k])} {_fmt(h)}", density="0", contype="1", conaffinity="1",
                          rgba="0.85 0.85 0.8 1")
        half = (h if pad else 0.0) + abs(reach[k]) + SITE_MARGIN  # the link's contact surface within it
        ET.SubElement(parent, "site", name=name, type="cylinder", pos=_vec(centre), zaxis=_vec(n),
                      size=f"{_fmt(r_taxel)} {_fmt(half)}", rgba=green)
    for name in names:
        ET.SubElement(sensor, "touch", name=f"{name}_touch", site=name)
    return names


def _robot_taxel(body: ET.Element, name: str, p, n, radius: float, h: float, reach: float) -> None:
    """A robot export's taxel in its module's body (:func:`module_body`): its pad (``radius`` m, raised
    to ``2 h`` over the link's contact surface where that lies ``reach`` > 0 m above the taxel ``p``,
    along ``n``) and its site, centred on the taxel (its frame on the link) and reaching the pad's top."""
    top = 2 * h + max(float(reach), 0.0)
    ET.SubElement(body, "geom", name=f"{name}_pad", type="cylinder", pos=_vec(p + top / 2 * n), zaxis=_vec(n),
                  size=f"{_fmt(radius)} {_fmt(top / 2)}", density="0", contype="1", conaffinity="1",
                  rgba="0.85 0.85 0.8 1")
    ET.SubElement(body, "site", name=name, type="cylinder", pos=_vec(p), zaxis=_vec(n),
                  size=f"{_fmt(radius)} {_fmt(top + SITE_MARGIN)}", rgba="0.2 0.8 0.2 0.5")


def default_arena(nv: int, nbody: int) -> int:
    """Bytes: an upper bound of the arena MuJoCo gives a model that sets no ``<size memory>`` (its guess:
    room for 100 contacts and 500 constraints; measured, MuJoCo 4.0: 13 MiB at nv 6, 14 at nv 12-24, 16 at
    48, 18 at 96; +1 MiB from 100 to 4,000 bodies), for ``nv`` degrees of freedom and ``nbody`` bodies."""
    return (16 << 20) + (64 << 10) * int(nv) + (1 << 10) * int(nbody)


def _memory_bytes(text: str) -> int:
    """Bytes of an MJCF ``memory`` value: digits, optionally followed by K, M, G, T, P or E (powers of 1024)."""
    t = str(text).strip()
    unit = "KMGTPE".find(t[-1:].upper()) + 1 if t and t[-1:].isalpha() else 0
    digits = t[:-1] if unit else t
    if not digits.isdigit():
        raise InputError(f"memory must be a byte count (digits, then K, M, G, T, P or E), got {text!r}",
                         key="size/memory")
    return int(digits) << (10 * unit)


def size_arena(root: ET.Element, tiles: int, file=None) -> int | None:
    """Size MuJoCo's arena (``<size memory>``) of the MJCF ``root`` for its ``tiles`` tile bodies (the
    ``"tile"`` footprint's welded child body per taxel); returns the bytes written, None where nothing was.

    MuJoCo's collision step takes two lists of all body pairs from the arena's stack at every step
    (:data:`PAIR_BYTES` x nbody (nbody - 1) / 2) and its default arena does not grow with them: a plate with
    a 2,000-taxel tile skin (2,004 bodies) stops at its first step with ``mj_stackAlloc: out of memory``.
    The arena written: the robot's own ``memory`` (else :func:`default_arena`, above MuJoCo's own guess), plus
    the pair list of every body in the file, plus :data:`TILE_CONTACT_BYTES` a tile, rounded up to a MiB;
    never below what the file asked for. A robot sizing its arena the legacy way (``njmax``/``nstack``, which
    MuJoCo refuses beside ``memory``) keeps its ``<size>``, with a warning. Bodies and joints are counted in
    ``root`` itself: those of an ``<include>``d or attached file that is not inlined are not (the tiles'
    pairs, 8 KiB a tile for contacts and the margin of :func:`default_arena` stand for a few of them).
    """
    if tiles <= 0:
        return None
    sizes = root.findall("size")
    legacy = [k for el in sizes for k in ("njmax", "nstack") if el.get(k) is not None]
    if legacy:
        import warnings

        from ..mesh import LayoutWarning

        warnings.warn(f"{file or 'the model'}: <size {legacy[0]}> sizes MuJoCo's arena the legacy way, and "
                      "MuJoCo refuses 'memory' beside it: the arena was left as it is; with "
                      f"{tiles} tile bodies it may run out at the first step (set <size memory> instead)",
                      LayoutWarning, stacklevel=3)
        return None
    own = [_memory_bytes(el.get("memory")) for el in sizes if el.get("memory") not in (None, "-1")]
    nbody = 1 + sum(1 for _ in root.iter("body"))  # and the world
    nv = sum({"free": 6, "ball": 3}.get(j.get("type", "hinge"), 1) for j in root.iter("joint")) \
        + 6 * sum(1 for _ in root.iter("freejoint"))
    base = own[-1] if own else default_arena(nv, nbody)
    need = base + PAIR_BYTES * nbody * (nbody - 1) // 2 + TILE_CONTACT_BYTES * int(tiles)
    mib = -(-need // (1 << 20))
    target = sizes[-1] if sizes else ET.Element("size")
    if not sizes:
        target.tail = root.text if (root.text or "").strip() == "" else None  # the file's own indentation
        root.insert(0, target)
    target.set("memory", f"{mib}M")
    return mib << 20


def module_body(prefix: str, module: int) -> str:
    """The name of the welded child body that holds one module's pads and sites in a robot export."""
    return f"{prefix}module_{int(module)}"


def write(layout: Layout, path, *, footprint: str = "taxel", pad: bool | None = None,
          site_radius: float | None = None, pad_thickness: float = 1e-3, prefix: str | None = None) -> None:
    """Write the skin as the self-contained MJCF fragment (a skin merged into a robot's own MJCF:
    :func:`vtcore.robot.export_skinned`).

    footprint : ``"taxel"`` or ``"tile"`` (see the module docstring). pad : add
    covering contact pads (default True). site_radius : m, overrides the module's taxel radius.
    pad_thickness : m. prefix : site name prefix (default ``taxel_``).
    """
    opts = dict(footprint=footprint, site_radius=site_radius, pad_thickness=pad_thickness)
    root = ET.Element("mujoco", model=str(layout.meta.get("name") or layout.meta.get("end_effector") or "skin"))
    root.append(ET.Comment(
        " written by vtcore (metres): one site and one touch sensor per taxel, in taxel order. "
        "Attach the body to a robot link: <attach model=\"skin\" body=\"" + identifier(layout.frame) + "\" prefix=\"skin/\"/> "
        "(or MjSpec.attach_body). Touch sensors count contacts of their own body's geoms only: "
        "this body senses through its pads; without pads, export the skin into the robot's own MJCF instead "
        "(vtcore layout export with the model and body options). "))
    wb = ET.SubElement(root, "worldbody")
    t = layout.transform
    frame = ET.SubElement(wb, "body", name=identifier(layout.frame), pos=_vec(t[:3, 3]), quat=_vec(_quat(t[:3, :3])))
    sensor = ET.SubElement(root, "sensor")
    add_skin(layout, frame, sensor, positions=layout.positions, normals=layout.normals,
             prefix=prefix or "taxel_", pad=True if pad is None else bool(pad), **opts)
    if footprint == "tile":  # a body per taxel: the broadphase's pair list over them needs the room
        size_arena(root, len(layout))
    tree = ET.ElementTree(root)
    ET.indent(tree, space="  ")
    write_xml(tree, path)
