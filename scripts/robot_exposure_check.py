"""Issue 33's check on real robots: fill every link that can carry a module (the G1's arms and torso,
every link of the Allegro hand) on its exposed surface, export the merged URDF, load it with
yourdfpy and measure each taxel's distance to every other link (trimesh), at the zero pose.

    PYTHONPATH=. python scripts/robot_exposure_check.py OUT_FOLDER [g1] [allegro] [--anywhere] [--collision]

Writes OUT_FOLDER/<robot>_skinned.urdf and prints one row per link; exit 1 when a taxel lies within
2 mm of, or inside, another link.
"""

from __future__ import annotations

import sys
import time
import warnings
from pathlib import Path


def links_of(robot, name):
    if name == "g1":
        arm = ["shoulder_pitch", "shoulder_roll", "shoulder_yaw", "elbow", "wrist_roll", "wrist_pitch", "wrist_yaw"]
        return ["torso_link"] + [f"{s}_{p}_link" for s in ("left", "right") for p in arm]
    return [n for n, ln in robot.links.items() if ln.visuals or ln.collisions]


def main(argv) -> int:
    from vtcore.errors import InputError
    from vtcore.robot import export_skinned, lay_on_link, load_robot
    from vtcore.robot.samples import example_robot_data
    from vtcore.robot.verify import clearance_urdf

    out = Path(argv[0])
    out.mkdir(parents=True, exist_ok=True)
    anywhere = "--anywhere" in argv
    geometry = "collision" if "--collision" in argv else "visual"
    erd = example_robot_data()
    robots = {"g1": erd / "g1_description/urdf/g1_29dof_with_hand_rev_1_0.urdf",
              "allegro": erd / "allegro_hand_description/urdf/allegro_right_hand.urdf"}
    only = [a for a in argv[1:] if not a.startswith("--")]
    bad = 0
    for name, path in robots.items():
        if only and name not in only:
            continue
        robot = load_robot(path)
        layouts = []
        for link in links_of(robot, name):
            t0 = time.perf_counter()
            try:
                with warnings.catch_warnings():
                    warnings.simplefilter("ignore")
                    lay, rep = lay_on_link(robot, link, "fill", geometry=geometry, exposure=not anywhere)
                layouts.append(lay)
                print(f"{name} {link}: {len(lay)} taxels, {lay.n_modules} modules, {time.perf_counter() - t0:.1f} s",
                      flush=True)
            except InputError as exc:
                print(f"{name} {link}: none ({exc.reason[:160]})", flush=True)
        urdf = out / f"{name}_{geometry}_skinned.urdf"
        export_skinned(path, layouts, urdf)
        stats = clearance_urdf(urdf, packages={"example-robot-data": erd.parent}, geometry=geometry)
        for link, s in stats.items():
            print(f"  {name} {link}: {s['taxels']} taxels, nearest other link {s['nearest']} at {s['min_mm']:.2f} mm; "
                  f"{s['near']} within 2 mm or inside ({s['inside']} inside)", flush=True)
            bad += s["near"]
        print(f"{name}: {sum(s['taxels'] for s in stats.values())} taxels on {len(stats)} links, "
              f"{sum(s['near'] for s in stats.values())} within 2 mm of or inside another link", flush=True)
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
