"""Issue 12's speed goals in a fresh process, timed after the libraries are imported:

- ``--what fill`` / ``hexagon``: fill the side of the 72 mm x 200 mm link (``cadmeshes.full_cylinder``,
  region = side faces, the ``fill_faces`` row of ``vtcore bench layout``), or place one hexagon on it;
- ``--what big``: 1,000 modules asked on a 180 mm-radius, 700 mm link (``--faces``, default there
  100,000), filled within a radius of 395 mm (the ``fill_region`` row's largest case).

    .venv/bin/python benchmarks/bench_fill_read.py [--faces N] [--what fill|hexagon|big] [--no-open3d] [--profile]

``--no-open3d`` makes ``import open3d`` fail, as inside Blender (the extension does not bundle it):
the path the add-on's *Fill* operator takes.

Prints one JSON line: the mesh's build time and the call's time (wall: ``perf_counter``; CPU:
``process_time`` of this process, all its threads), both excluding Python and library imports;
the call includes everything it does to the mesh (cleaning, repairs, the log maps' preparation).
CPU time is what the shared machine's load inflates least; say the load (``uptime``) with wall
times. ``--profile`` adds cProfile's 40 costliest calls (cumulative). Measured, not asserted.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
import warnings
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))


def main(argv=None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--faces", type=int, default=None,
                    help="about this many faces (default 200,000; 100,000 for --what big)")
    ap.add_argument("--what", choices=("fill", "hexagon", "big"), default="fill")
    ap.add_argument("--no-open3d", action="store_true", help="as inside Blender: open3d cannot be imported")
    ap.add_argument("--profile", action="store_true")
    a = ap.parse_args(argv)
    if a.no_open3d:
        sys.modules["open3d"] = None  # import open3d -> ImportError
    else:
        import open3d  # noqa: F401  (every library the call uses, imported before the clock starts)
    import potpourri3d  # noqa: F401
    import scipy.sparse.csgraph  # noqa: F401
    import scipy.spatial  # noqa: F401
    import trimesh  # noqa: F401

    from vtcore.layout import cadmeshes
    from vtcore.layout.placement import place
    from vtcore.layout.tiling import fill

    R, L = (0.18, 0.7) if a.what == "big" else (0.072, 0.2)
    faces = a.faces or (100_000 if a.what == "big" else 200_000)
    w0, c0 = time.perf_counter(), time.process_time()
    mesh = cadmeshes.full_cylinder(R, L, float(np.sqrt(4 * np.pi * R * L / faces)))
    side = np.abs(mesh.face_normals[:, 2]) < 0.5
    w1, c1 = time.perf_counter(), time.process_time()
    prof = None
    if a.profile:
        import cProfile

        prof = cProfile.Profile()
        prof.enable()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        if a.what == "fill":
            lay, rep = fill(mesh, (R, 0, 0), (0, 1, 0), region=side)
        elif a.what == "big":  # a disc of about 1,000 module areas (490 mm2 each)
            lay, rep = fill(mesh, (R, 0, 0), (0, 1, 0), radius=float(np.sqrt(1000 * 490e-6 / np.pi)))
        else:
            lay, rep = place(mesh, "hexagon", (R, 0, 0), (0, 1, 0))
    w2, c2 = time.perf_counter(), time.process_time()
    if prof is not None:
        prof.disable()
    out = {"what": a.what, "faces": len(mesh.faces), "mesh_wall_s": round(w1 - w0, 3),
           "mesh_cpu_s": round(c1 - c0, 3), "wall_s": round(w2 - w1, 3), "cpu_s": round(c2 - c1, 3),
           "modules": lay.n_modules, "coverage": round(float(rep.coverage), 4),
           "charts": getattr(rep, "charts", None), "overlaps": len(rep.overlaps), "open3d": not a.no_open3d}
    print(json.dumps(out))
    if prof is not None:
        import pstats

        pstats.Stats(prof).sort_stats("cumulative").print_stats(40)
    return out


if __name__ == "__main__":
    main()
