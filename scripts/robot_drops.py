"""Issue 33's check of exported skins: fill links of the G1 and the Allegro hand (example-robot-data),
export each robot as MJCF, drop a 20 g ball on random taxels at the zero pose and 3 random frozen
configurations the robot can hold (uniform within the joint limits, none with a body through another:
vtcore.robot.reach.free_configurations; vtcore.robot.drops) and count the drops whose skinned link reads m g within 5 %.

    python scripts/robot_drops.py OUT_DIR [--drops 24] [--robots g1,allegro]

Prints, per robot, the drops on any taxel of today's fills and on the taxels the export classes as
readable, and apart the draws where another link stood within a ball's width over the taxel at the drawn
configuration (the ball would start inside it: no drop; another is drawn); writes OUT_DIR/drops.json.
"""

from __future__ import annotations

import argparse
import json
import sys
import warnings
from pathlib import Path


ARM = ["shoulder_pitch", "shoulder_roll", "shoulder_yaw", "elbow", "wrist_roll", "wrist_pitch", "wrist_yaw"]
#: robot -> (URDF under example-robot-data, [(link, geometry)] skinned): the links issue 33 names, as
#: scripts/robot_exposure_check.py fills them (the G1's torso and both arms; every link of the Allegro hand
#: with geometry, fingertips on their collision spheres, whose visual meshes are far finer)
ROBOTS = {
    "g1": ("g1_description/urdf/g1_29dof_with_hand_rev_1_0.urdf",
           [("torso_link", "visual")] + [(f"{s}_{p}_link", "visual") for s in ("left", "right") for p in ARM]
           + [("left_hand_palm_link", "visual")]),
    "allegro": ("allegro_hand_description/urdf/allegro_right_hand.urdf", None),
}
TOLERANCE = 0.05


def run(name: str, out: Path, drops: int, seed: int = 0) -> dict:
    from vtcore.robot import export_skinned, lay_on_link, load_robot
    from vtcore.robot.drops import drop_many
    from vtcore.robot.reach import free_configurations
    from vtcore.robot.samples import example_robot_data

    erd = example_robot_data()
    packages = {"example-robot-data": erd.parent}
    rel, links = ROBOTS[name]
    robot = load_robot(erd / rel, packages)
    if links is None:
        links = [(n, "collision" if n.endswith("_tip") else "visual") for n, ln in robot.links.items()
                 if ln.visuals or ln.collisions]
    layouts = []
    for link, geometry in links:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            try:
                lay, _ = lay_on_link(robot, link, "fill", geometry=geometry)
            except ValueError as exc:
                print(f"{name}: {link}: {exc}", file=sys.stderr)
                continue
        layouts.append(lay)
        print(f"{name}: {link}: {len(lay)} taxels", file=sys.stderr)
    path = out / f"{name}.xml"
    records = export_skinned(robot.path, layouts, path, packages=packages)
    unreadable = {s for r in records for s in r.get("unreadable", [])}
    sometimes = {s for r in records for s in r.get("covered_at_some_poses", {})}
    # the zero pose and 3 random configurations the robot can hold: uniform within the joint limits, those
    # where MuJoCo finds a body through another (an arm through the torso) drawn again
    configs = [{}] + free_configurations(path, 3, seed)
    if len(configs) < 4:
        raise SystemExit(f"{name}: only {len(configs) - 1} collision-free random configurations found")
    skinned = [lay.frame for lay in layouts]
    every = drop_many(path, skinned, drops, configurations=configs, seed=seed)
    import mujoco

    m = mujoco.MjModel.from_xml_path(str(path))
    sites = {m.site(k).name for k in range(m.nsite)}
    readable = drop_many(path, skinned, drops, configurations=configs, seed=seed + 1,
                         readable=sites - unreadable - sometimes)
    ok = lambda rows: sum(r["blocked"] is None and abs(r["ratio"] - 1) <= TOLERANCE for r in rows)  # noqa: E731
    placed = lambda rows: sum(r["blocked"] is None for r in rows)  # noqa: E731
    blocked = lambda rows: sum(r["blocked"] is not None for r in rows)  # noqa: E731
    summary = {"robot": name, "seed": seed, "configurations": configs, "taxels": sum(len(x) for x in layouts), "unreadable": len(unreadable),
               "covered_at_some_poses": len(sometimes),
               "drops": drops, "ok_any_taxel": ok(every), "ok_readable": ok(readable),
               "placed_any_taxel": placed(every), "placed_readable": placed(readable),
               "blocked_any_taxel": blocked(every), "blocked_readable": blocked(readable),
               "rows_any": every, "rows_readable": readable}
    print(f"{name}: {summary['taxels']} taxels, {len(unreadable)} named unreadable by the export (and "
          f"{len(sometimes)} covered at some poses); m g within 5 % on "
          f"{ok(every)}/{placed(every)} drops on any taxel, {ok(readable)}/{placed(readable)} on readable taxels "
          f"(read at every probed pose); draws where another link stood over the taxel, so that no ball could "
          f"be placed (drawn again): {blocked(every)} and {blocked(readable)}")
    return summary


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("out")
    p.add_argument("--drops", type=int, default=24)
    p.add_argument("--robots", default="g1,allegro")
    p.add_argument("--seed", type=int, default=0)
    a = p.parse_args(argv)
    out = Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    res = [run(r, out, a.drops, a.seed) for r in a.robots.split(",")]
    (out / "drops.json").write_text(json.dumps(res, indent=1, default=float))
    return 0


if __name__ == "__main__":
    sys.exit(main())
