"""MuJoCo MJCF (export only): one site and one touch sensor per taxel."""

from __future__ import annotations

import numpy as np

from ..._io import atomic_write
from ..model import Layout

NAME = "mjcf"
SUFFIXES = (".xml", ".mjcf")
read = None  # export only


def write(layout: Layout, path, *, site_radius: float | None = None, site_depth: float = 1e-3) -> None:
    """MuJoCo MJCF: a body holding one cylinder site per taxel (axis along its normal)
    and a ``touch`` sensor on each site, in taxel order."""
    from xml.sax.saxutils import quoteattr

    r = site_radius if site_radius is not None else float(layout.meta.get("taxel_radius_m", 2e-3))
    fmt = lambda v: format(float(v), ".9g")  # noqa: E731
    name = str(layout.meta.get("name") or layout.meta.get("end_effector") or "skin")
    lines = [f'<mujoco model={quoteattr(name)}>',
             '  <!-- written by vtcore: one site per taxel, one touch sensor per site; metres -->',
             "  <worldbody>", f"    <body name={quoteattr(layout.frame)}>"]
    sites = []
    unique_ids = len(np.unique(layout.taxel_ids)) == len(layout)  # else name sites by row
    for k in range(len(layout)):
        sname = f"taxel_{int(layout.taxel_ids[k])}" if unique_ids else f"taxel_{k}"
        sites.append(sname)
        p = " ".join(fmt(v) for v in layout.positions[k])
        z = " ".join(fmt(v) for v in layout.normals[k])
        lines.append(f'      <site name="{sname}" type="cylinder" pos="{p}" zaxis="{z}" '
                     f'size="{fmt(r)} {fmt(site_depth / 2)}" rgba="0.2 0.8 0.2 0.5"/>')
    lines += ["    </body>", "  </worldbody>", "  <sensor>"]
    lines += [f'    <touch name="touch_{s[6:]}" site="{s}"/>' for s in sites]
    lines += ["  </sensor>", "</mujoco>"]
    with atomic_write(path, "w", encoding="utf-8", newline="\n") as fh:
        fh.write("\n".join(lines) + "\n")


