"""The small example logs of ``scenes/data/`` (reproducible: ``python -m vtcore.can.examples DIR``).

- ``replay_cyskin16_slide.log``: candump log, cyskin16 codec, a 60-taxel hexagonal CySkin patch
  (cyskin10 modules, UIDs ``module << 4 | sensor``): a 20 mm sphere lands at 0.4 s, slides
  across it at 5 N and lifts at 2.7 s (3 s at 20 Hz); raw counts = a per-taxel baseline
  near 20000 + 0.5 count/Pa x pressure
  + noise. Faults a real bus shows are injected and must appear in the replay summary:
  3 garbage lines, 2 duplicated frames, 1 frame lost, 1 frame with a timestamp 1 s back.
- ``replay_icub_press.asc``: Vector ASC log, iCub codec, a 72-slot patch of 6 iCub triangles
  (board 0, ``icub12`` modules) pressed by a 25 mm sphere rising to 4 N and released (3 s);
  triangle 5 reports error 2 (not connected) in rows 30..32.

The contact model is ``vtcore.contact.press`` (finite-layer elastic model of a 3 mm Ecoflex
00-20 layer, force-controlled, one solve per period, warm-started along the trajectory).
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

from ..layout import make_patch
from .codecs import Cyskin16Codec, IcubCodec, icub_counts_to_wire
from .encode import encode
from .logs import write_log


def plane_patch(kind: str, module: str):
    """A flat patch at z = 0 with normals +z (what ``[layout] patch/module`` on a plane gives)."""
    p = make_patch(kind, module)
    pos = np.column_stack([p.flat, np.zeros(len(p.flat))])
    nrm = np.tile([0.0, 0.0, 1.0], (len(p.flat), 1))
    return p.to_layout(pos, nrm, {"placement_method": "analytic", "end_effector": "plane"})


def _pressure(layout, centres, radius, forces):
    """Taxel pressure ``(T, N)`` Pa: a sphere of ``radius`` m over ``centres (T, 2)`` m pressed with
    ``forces (T,)`` N through a 3 mm Ecoflex 00-20 layer (``vtcore.contact.press_sequence``; the
    numpy proximity back-end, so the logs do not depend on open3d's threading)."""
    from ..contact import SoftLayer, make_object, placement_pose, press_sequence

    layer = SoftLayer(thickness=0.003, material="ecoflex_00_20")
    sphere = make_object("sphere", radius=radius)
    top = float(layout.positions[:, 2].max()) + layer.thickness
    poses = np.stack([placement_pose(sphere, xy=c, top=top, gap=0.0005) for c in np.asarray(centres)])
    res = press_sequence(layout, sphere, poses, layer, force=np.asarray(forces, float), backend="numpy")
    return np.array([r.pressure for r in res])


def make_cyskin16_slide(path: Path, seed: int = 1) -> dict:
    rng = np.random.default_rng(seed)
    layout = plane_patch("hexagon", "cyskin10")
    t = 60
    x = np.linspace(-0.035, 0.035, t)
    force = np.where((np.arange(t) >= 8) & (np.arange(t) < 54), 5.0, 0.0)   # lands, slides, lifts
    pressure = _pressure(layout, np.column_stack([x, 0.004 * np.ones(t)]), 0.02, force)
    baseline = rng.normal(20000, 400, len(layout))
    counts = baseline + 0.5 * pressure + rng.normal(0, 15, pressure.shape)
    ts = 1763700000.0 + np.arange(t) * 0.05
    batch = encode(ts, np.clip(np.rint(counts), 0, 65535), layout.taxel_ids, Cyskin16Codec())
    # faults: one frame lost, two duplicated, one with a timestamp 1 s back
    n = len(batch)
    lost = 400
    keep = np.r_[np.arange(lost), np.arange(lost + 1, n)]
    dup_at = [120, 777]
    order = np.sort(np.r_[keep, dup_at])
    b = batch.take(order)
    b.timestamps[600] -= 1.0
    write_log(path, b)
    lines = path.read_text().splitlines(keepends=True)
    for k, junk in ((50, "(garbage) ???\n"), (300, "can0 18000011#\n"), (900, "\x7f\x00ERR\n")):
        lines.insert(k, junk)
    path.write_text("".join(lines))
    return {"frames": len(b), "garbage_lines": 3, "duplicates": 2, "lost": 1, "out_of_order": 1}


def make_icub_press(path: Path, seed: int = 2) -> dict:
    rng = np.random.default_rng(seed)
    layout = plane_patch("hexagon", "icub12")
    t = 60
    force = 4.0 * np.clip(np.sin(np.linspace(-0.3, np.pi + 0.3, t)), 0, None)
    pressure = _pressure(layout, np.tile([0.002, -0.003], (t, 1)), 0.025, force)
    counts = 0.015 * pressure + rng.normal(0, 2.0, pressure.shape)          # compensated counts
    wire = icub_counts_to_wire(counts)
    ts = 1763700000.0 + np.arange(t) * 0.05
    errors = {(r, 5): 2 for r in (30, 31, 32)}
    write_log(path, encode(ts, wire, layout.taxel_ids, IcubCodec(), errors=errors))
    _fix_asc_dates(path, ts[0])
    return {"rows": t, "error_rows": 3}


def _fix_asc_dates(path: Path, t0: float) -> None:
    """python-can's ASC writer stamps the file with the writing time (and the trigger block with
    the first frame's local time): write both as the first frame's UTC time, so the example log
    is byte-for-byte reproducible on any machine. Frame times are relative to it anyway."""
    from datetime import datetime, timezone

    stamp = datetime.fromtimestamp(t0, timezone.utc).strftime("%a %b %d %H:%M:%S.%f")[:-3] + \
        datetime.fromtimestamp(t0, timezone.utc).strftime(" %Y")
    lines = path.read_text().splitlines(keepends=True)
    for i, ln in enumerate(lines[:6]):
        if ln.startswith("date "):
            lines[i] = f"date {stamp}\n"
        elif ln.startswith("Begin Triggerblock"):
            lines[i] = f"Begin Triggerblock {stamp}\n"
    path.write_text("".join(lines))


def main(out: str) -> None:
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    print(make_cyskin16_slide(out / "replay_cyskin16_slide.log"))
    print(make_icub_press(out / "replay_icub_press.asc"))


if __name__ == "__main__":  # pragma: no cover
    main(sys.argv[1] if len(sys.argv) > 1 else "scenes/data")
