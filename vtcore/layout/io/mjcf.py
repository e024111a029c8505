"""MuJoCo MJCF (export only): one site and one ``touch`` sensor per taxel.

A MuJoCo touch sensor sums the normal force of the contacts that involve *the body
its site belongs to* and whose contact point lies in the site's volume. So sites
sense only in a body that has collision geoms. Two ways to get there:

- ``model=ROBOT.xml, body=BODY`` (CLI ``--model --body``): the robot's MJCF with the
  sites added to ``BODY`` itself, placed by the layout's ``transform`` (the pose of
  the layout frame in ``BODY``; a CySkin ``tf_matrix``), and the sensors appended.
  BODY's own collision geoms are what the ball touches.
- the fragment (no ``model``): a ``<mujoco>`` file with one body named after the
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
  lands. The pads are the contact surface (``pad`` is implied).

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

import os
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np

from ..._io import atomic_write
from ...errors import InputError
from ...tolerances import ZERO_NORMAL
from ..model import Layout
from .common import default_faces, identifier, indent_added, read_robot_xml, refuse_clash, skin_prefix, taxel_labels

NAME = "mjcf"
SUFFIXES = (".xml", ".mjcf")
read = None  # export only
FOOTPRINTS = ("taxel", "tile")
SITE_MARGIN = 2e-3  # m, half-height of a site beyond its pad: contact points of soft contacts sit within it


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


def _body_frame(layout: Layout) -> tuple[np.ndarray, np.ndarray]:
    """Taxel positions and normals in the parent body (the layout's transform applied)."""
    t = layout.transform
    return layout.positions @ t[:3, :3].T + t[:3, 3], layout.normals @ t[:3, :3].T


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
        of the skin, :func:`cover_radii`; a robot export's pads stay under their own taxel, so that a wide
        pad on a curved link does not stand over its neighbours; the site then stays centred on its taxel,
        the taxel's frame on the link, and reaches over the pad).
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
    for k, name in enumerate(names):
        p, n = positions[k], normals[k]
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
        if pad_radius is not None and pad:  # a robot's taxel frame stays on its link: the site reaches the pad's top
            centre, half = p, half + h
        ET.SubElement(parent, "site", name=name, type="cylinder", pos=_vec(centre), zaxis=_vec(n),
                      size=f"{_fmt(r_taxel)} {_fmt(half)}", rgba=green)
    for name in names:
        ET.SubElement(sensor, "touch", name=f"{name}_touch", site=name)
    return names


def compiler_dirs(root: ET.Element) -> dict:
    """The ``meshdir``, ``texturedir`` and ``assetdir`` MuJoCo compiles ``root`` with (None where unset):
    ``<compiler>`` may repeat, and each one's attributes override the earlier ones' (a second
    ``<compiler meshdir=...>`` was read by MuJoCo but missed here: found by the robot export fuzz)."""
    dirs = dict.fromkeys(("meshdir", "texturedir", "assetdir"))
    for compiler in root.findall("compiler"):
        dirs.update({k: compiler.get(k) for k in dirs if compiler.get(k) is not None})
    return dirs


def rebase(root: ET.Element, src_dir: Path, out_dir: Path) -> None:
    """Keep the robot's relative file references valid from the output's folder."""
    if src_dir.resolve() == out_dir.resolve():
        return
    rel = lambda f: os.path.relpath(src_dir / f, out_dir)  # noqa: E731
    compilers = root.findall("compiler")
    if not compilers:
        compilers = [ET.Element("compiler")]
        root.insert(0, compilers[0])
        indent_added(root, compilers)
    unset_assetdir = compiler_dirs(root)["assetdir"] is None
    for compiler in compilers:  # every one: a later compiler's dirs override an earlier one's
        for key in ("meshdir", "texturedir", "assetdir"):
            v = compiler.get(key)
            if v is not None and not os.path.isabs(v):
                compiler.set(key, rel(v))
    if unset_assetdir:
        compilers[0].set("assetdir", rel("."))  # files without a dir were relative to the model
    for inc in root.iter("include"):
        f = inc.get("file")
        if f and not os.path.isabs(f):
            inc.set("file", rel(f))


def colliding_geoms(root: ET.Element, body: ET.Element) -> int:
    """How many of ``body``'s own geoms take part in collisions (``contype`` or ``conaffinity``
    non-zero after the default classes, ``childclass`` and the geom's own attributes)."""
    classes: dict[str, dict] = {}

    def visit(el, inherited):
        attrs = dict(inherited)
        g = el.find("geom")
        if g is not None:
            attrs.update({k: g.get(k) for k in ("contype", "conaffinity") if g.get(k) is not None})
        classes[el.get("class", "main")] = attrs
        for child in el.findall("default"):
            visit(child, attrs)

    for top in root.findall("default"):
        visit(top, {})
    parent = {c: p for p in root.iter() for c in p}
    child_class, el = None, body
    while el is not None and child_class is None:
        child_class = el.get("childclass")
        el = parent.get(el)
    n = 0
    for g in body.findall("geom"):
        attrs = dict(classes.get(g.get("class") or child_class or "main", {}))
        attrs.update({k: g.get(k) for k in ("contype", "conaffinity") if g.get(k) is not None})
        # MuJoCo reads a blank value as the default 1 (contype="": found by the robot export fuzz)
        n += any(int((attrs.get(k) or "1").strip() or "1") != 0 for k in ("contype", "conaffinity"))
    return n


def replace_contact(root: ET.Element, body: ET.Element, files, prefix: str) -> list[str]:
    """Make the convex meshes ``files`` (paths, in ``body``'s frame, metres) ``body``'s contact surface:
    its own colliding geoms stop colliding (``contype`` = ``conaffinity`` = 0; they stay, for their mass
    and looks), and one massless mesh geom per file is added (``<prefix><k>``, its asset too, file
    given as is; :func:`relative_contact_files` makes it relative later). Returns the geom names."""
    for g in body.findall("geom"):
        g.set("contype", "0")
        g.set("conaffinity", "0")
    asset = root.find("asset")
    if asset is None:
        asset = ET.Element("asset")
        root.insert(1 if root.find("compiler") is not None else 0, asset)
    added, names = [], []
    for k, f in enumerate(files):
        name = f"{prefix}{k}"
        added.append(ET.SubElement(asset, "mesh", name=name, file=str(f)))
        added.append(ET.SubElement(body, "geom", name=name, type="mesh", mesh=name, density="0",
                                   contype="1", conaffinity="1", group="3", rgba="0.6 0.6 0.9 0.3"))
        names.append(name)
    indent_added(root, added + ([asset] if len(asset) == len(files) else []))
    return names


def relative_contact_files(root: ET.Element, names, out_dir: Path) -> None:
    """Write the ``file`` of the mesh assets ``names`` relative to where MuJoCo looks for meshes of the
    model written in ``out_dir`` (the compiler's ``meshdir``, else ``assetdir``, else the model's folder)."""
    dirs = compiler_dirs(root)
    base = dirs["meshdir"] or dirs["assetdir"] or ""
    base_dir = Path(base) if os.path.isabs(base) else Path(out_dir) / base
    names = set(names)
    for mesh in root.iter("mesh"):
        if mesh.get("name") in names:
            mesh.set("file", os.path.relpath(Path(mesh.get("file")).resolve(), base_dir.resolve()))


def inline_includes(root: ET.Element, model_dir: Path, model) -> None:
    """Replace every ``<include file=...>`` under ``root`` by the children of the included
    file's ``<mujoco>`` (MuJoCo's own semantics: paths relative to the main model's folder,
    includes nested inside included files too), so a body an include defines can take sites."""
    seen = 0
    while True:
        parent_of = {c: p for p in root.iter() for c in p}
        inc = next((e for e in root.iter("include") if e in parent_of), None)
        if inc is None:
            return
        seen += 1
        if seen > 1000:
            raise InputError("more than 1000 <include>s: a file including itself?", file=model)
        f = inc.get("file") or ""
        sub = read_robot_xml(model_dir / f if not os.path.isabs(f) else Path(f), "mujoco").getroot()
        parent = parent_of[inc]
        k = list(parent).index(inc)
        parent.remove(inc)
        for j, child in enumerate(list(sub)):
            parent.insert(k + j, child)


def merge_into_model(layout: Layout, model, body: str | None = None, **options) -> ET.ElementTree:
    """The robot MJCF ``model`` (a path) with the skin added to its body ``body`` (default the
    layout's parent, else its frame). A body defined in an ``<include>``d file is found there:
    the includes are then written inline, every element as it was."""
    tree = read_robot_xml(model, "mujoco")
    merge_into_tree(layout, tree, body, model, **options)
    return tree


def merge_into_tree(layout: Layout, tree: ET.ElementTree, body: str | None, model, **options) -> list[str]:
    """Add the skin's sites (pads) and touch sensors to body ``body`` of the MJCF ``tree`` read from
    the file ``model``; returns the site names. See :func:`merge_into_model`."""
    body = body or layout.parent or layout.frame
    root = tree.getroot()
    find = lambda: next((b for b in root.iter("body") if b.get("name") == body), None)  # noqa: E731
    target = find()
    if target is None and root.find(".//include") is not None:
        inline_includes(root, Path(model).parent, model)
        target = find()
    if target is None:
        names = [b.get("name") for b in root.iter("body") if b.get("name")]
        raise InputError(f"no body named {body!r}; bodies: {', '.join(names[:40]) or 'none'}",
                         file=model, key="--body")
    if not options.get("pad") and options.get("footprint", "taxel") == "taxel" and not colliding_geoms(root, target):
        import warnings

        from ..mesh import LayoutWarning

        warnings.warn(f"{model}: body {body!r} has no colliding geom (none, or only contype=conaffinity=0): its "
                      "touch sensors would read 0; export with pad=True (--pad) to give the skin a contact surface",
                      LayoutWarning, stacklevel=3)
    taken = {e.get("name") for e in root.iter() if e.get("name")}
    prefix = skin_prefix(body, options.pop("prefix", None))
    labels = taxel_labels(layout)
    names = [f"{prefix}{lab}" for lab in labels]
    suffixes = ("", "_touch", "_pad", "_cell")
    refuse_clash(taken, [n + s for n in names for s in suffixes], model, "elements", prefix)
    pos, nrm = _body_frame(layout)
    sensor = root.find("sensor")
    if sensor is None:
        sensor = ET.SubElement(root, "sensor")
    before = {id(e) for e in root.iter()}
    out = add_skin(layout, target, sensor, positions=pos, normals=nrm, prefix=prefix, **options)
    indent_added(root, [e for e in root.iter() if id(e) not in before])
    return out


def write_tree(tree: ET.ElementTree, path) -> None:
    """Write an MJCF tree (written to a temporary file, then renamed)."""
    with atomic_write(path, "w", encoding="utf-8", newline="\n") as fh:
        tree.write(fh, encoding="unicode", xml_declaration=False)
        fh.write("\n")


def write(layout: Layout, path, *, model=None, body: str | None = None, footprint: str = "taxel",
          pad: bool | None = None, site_radius: float | None = None, pad_thickness: float = 1e-3,
          prefix: str | None = None) -> None:
    """Write the skin as MJCF: a fragment, or ``model`` with the skin added to ``body``.

    model : path of the robot's MJCF, or None for the self-contained fragment.
    body : with ``model``, the robot body the skin is on (default: the layout's ``parent``, else its
        ``frame``); the layout's ``transform`` is the pose of its frame in that body.
    footprint : ``"taxel"`` or ``"tile"`` (see the module docstring). pad : add
    covering contact pads (default: True for the fragment, False in a model).
    site_radius : m, overrides the module's taxel radius. pad_thickness : m.
    prefix : site name prefix (default ``taxel_`` in the fragment, ``BODY_vtskin_`` in a model).
    """
    opts = dict(footprint=footprint, site_radius=site_radius, pad_thickness=pad_thickness)
    if model is not None:
        tree = merge_into_model(layout, model, body, pad=bool(pad), prefix=prefix, **opts)
        rebase(tree.getroot(), Path(model).parent, Path(path).parent)
    else:
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
        tree = ET.ElementTree(root)
        ET.indent(tree, space="  ")
    write_tree(tree, path)
