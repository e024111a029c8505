"""Render docs/img/robot_forearm_frames.png: the humanoid forearm (a CAD mesh in millimetres placed
in link ``l_forearm`` by a visual origin) with a skin laid on its loose CAD mesh, exported into the
robot's URDF without and with the frame's pose, as yourdfpy reads the file back (left: the taxels
~0.2 m off the link, as the issue found them; right: on it), and the same skin laid through the
robot (``vtcore layout place ROBOT --link``), which needs no pose at all.

Run: ``.venv/bin/python scripts/render_robot_docs.py`` (needs yourdfpy). Prints the distances.
``--exposure``: only docs/img/robot_exposure_g1.png (issue 33: the G1 arm's exposed surface and the
left wrist's fill before and after).
The skinned UR10 picture is the benchmark's (``vtcore bench robot``, ``skinned_robot_collision.png``).
"""

from __future__ import annotations

import sys
import tempfile
import warnings
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
from vtcore.layout import place  # noqa: E402
from vtcore.layout.io import in_link  # noqa: E402
from vtcore.layout.io.urdf import taxel_poses  # noqa: E402,F401  (the writer's own frames)
from vtcore.robot import export_skinned, lay_on_link, link_mesh, load_robot  # noqa: E402
from vtcore.robot import urdf_tree  # noqa: E402
from vtcore.robot.model import pose  # noqa: E402
from vtcore.robot.samples import FOREARM_VISUAL_ORIGIN, humanoid_arm  # noqa: E402
from vtcore.robot.verify import surface_errors  # noqa: E402


def frames_in_link(path):
    import yourdfpy

    u = yourdfpy.URDF.load(str(path), load_meshes=False)
    names = [n for n in u.link_map if "_vtskin_" in n]
    return np.array([u.get_transform(n, "l_forearm") for n in names])


def main():
    import trimesh

    with tempfile.TemporaryDirectory() as tmp, warnings.catch_warnings():
        warnings.simplefilter("ignore")
        tmp = Path(tmp)
        urdf = humanoid_arm(tmp)
        robot = load_robot(urdf)
        mesh = link_mesh(robot, "l_forearm")
        cad = trimesh.load(urdf.parents[1] / "meshes" / "forearm_cad.stl", process=False)
        cad.apply_scale(1e-3)
        loose, _ = place(cad, "hexagon", (0.0, -0.036, -0.04), (0, 0, 1))  # in the CAD frame
        loose.frame = "forearm_cad"
        t = pose(*FOREARM_VISUAL_ORIGIN)
        urdf_tree.write_skinned(loose, tmp / "wrong.urdf", urdf, parent="l_forearm")  # the frame's pose not given
        urdf_tree.write_skinned(in_link(loose, t), tmp / "right.urdf", urdf, parent="l_forearm")
        born, _ = lay_on_link(robot, "l_forearm", "fill", (pose(*FOREARM_VISUAL_ORIGIN) @ [0, -0.036, -0.04, 1])[:3])
        export_skinned(urdf, [born], tmp / "born.urdf")
        panels = [("exported without the frame's pose", frames_in_link(tmp / "wrong.urdf")),
                  ("exported with --transform (the visual origin)", frames_in_link(tmp / "right.urdf")),
                  ("laid through the robot: born in the link", frames_in_link(tmp / "born.urdf"))]
        fig = plt.figure(figsize=(13, 4.6))
        for k, (title, f) in enumerate(panels):
            d, a, _ = surface_errors(mesh, f[:, :3, 3], f[:, :3, 2])
            print(f"{title}: {len(f)} taxels, distance to the link mesh median {np.median(d):.1f} mm, "
                  f"max {d.max():.2f} mm; normal angle max {a.max():.1f} deg")
            ax = fig.add_subplot(1, 3, k + 1, projection="3d")
            ax.plot_trisurf(*mesh.vertices.T, triangles=mesh.faces, color=(0.8, 0.8, 0.82, 0.3), linewidth=0)
            ax.quiver(*f[:, :3, 3].T, *(0.012 * f[:, :3, 2]).T, color="tab:blue", linewidth=0.6)
            ax.scatter(*f[:, :3, 3].T, s=3, color="tab:red")
            pts = np.vstack([mesh.vertices, f[:, :3, 3]])
            c, r = (pts.min(0) + pts.max(0)) / 2, np.ptp(pts, axis=0).max() / 2
            ax.set_xlim(c[0] - r, c[0] + r)
            ax.set_ylim(c[1] - r, c[1] + r)
            ax.set_zlim(c[2] - r, c[2] + r)
            ax.set_box_aspect((1, 1, 1))
            ax.set_title(f"{title}\nmedian {np.median(d):.1f} mm off the link", fontsize=9)
            ax.set_axis_off()
        fig.suptitle("Taxel frames of link l_forearm as yourdfpy reads the exported URDF (CAD mesh in mm, "
                     "placed by its visual origin)", fontsize=10)
        out = ROOT / "docs" / "img" / "robot_forearm_frames.png"
        fig.savefig(out, dpi=110, bbox_inches="tight")
        print(out)


def exposure_picture(out=None):
    """docs/img/robot_exposure_g1.png: the G1's left arm at the zero pose, each link's faces coloured
    by its exposure (left), and the left wrist's fill before (anywhere: taxels on the face mating with
    the elbow, red where within 2 mm of or inside another link) and after (right). Prints the numbers."""
    from mpl_toolkits.mplot3d.art3d import Poly3DCollection
    from matplotlib.patches import Patch

    from vtcore.robot.exposure import (COLOURS, REASONS, RobotSurfaces, configurations, exposed_faces, face_colours,
                                       taxel_reasons)
    from vtcore.robot.samples import example_robot_data

    robot = load_robot(example_robot_data() / "g1_description/urdf/g1_29dof_with_hand_rev_1_0.urdf")
    arm = ["left_shoulder_yaw_link", "left_elbow_link", "left_wrist_roll_link", "left_wrist_pitch_link",
           "left_wrist_yaw_link"]
    surfaces, configs = RobotSurfaces(robot), configurations(robot)
    poses = configs[0]
    fig = plt.figure(figsize=(12, 6))
    ax = fig.add_subplot(1, 2, 1, projection="3d")
    lo, hi = np.full(3, np.inf), np.full(3, -np.inf)
    for name in arm:
        mesh = surfaces.mesh(name)
        e = exposed_faces(robot, name, mesh=mesh, surfaces=surfaces, configs=configs)
        print(e.excluded_text())
        t = poses[name]
        v = mesh.vertices @ t[:3, :3].T + t[:3, 3]
        lo, hi = np.minimum(lo, v.min(0)), np.maximum(hi, v.max(0))
        ax.add_collection3d(Poly3DCollection(v[mesh.faces], facecolors=face_colours(e.reason),
                                             edgecolor="none"))
    c, r = (lo + hi) / 2, (hi - lo).max() / 2
    for set_lim, k in ((ax.set_xlim, 0), (ax.set_ylim, 1), (ax.set_zlim, 2)):
        set_lim(c[k] - r, c[k] + r)
    ax.set_box_aspect((1, 1, 1))
    ax.view_init(elev=15, azim=-30)
    ax.set_axis_off()
    ax.set_title("G1 left arm: exposed surface (zero pose, 32 sampled poses, 8 mm probe)", fontsize=9)
    ax.legend(handles=[Patch(color=COLOURS[k][0], label=REASONS[k]) for k in COLOURS],
              fontsize=7, loc="lower left")
    link = "left_wrist_roll_link"
    mesh = link_mesh(robot, link)
    cases = ((False, "before: fill anywhere"), (True, "after: fill the exposed surface"))
    for k, (exposure, title) in enumerate(cases):
        lay, _ = lay_on_link(robot, link, "fill", mesh=mesh, exposure=exposure)
        bad = taxel_reasons(robot, link, lay.positions, lay.normals) == 1
        print(f"{link} {title}: {len(lay)} taxels, {int(bad.sum())} within 2 mm of or inside another link")
        axk = fig.add_subplot(2, 2, 2 + 2 * k, projection="3d")
        axk.add_collection3d(Poly3DCollection(mesh.vertices[mesh.faces], facecolor=(0.8, 0.8, 0.82, 0.3),
                                              edgecolor="none"))
        axk.scatter(*lay.positions[~bad].T, s=6, color="tab:green", depthshade=False)
        axk.scatter(*lay.positions[bad].T, s=6, color="tab:red", depthshade=False)
        lo, hi = mesh.bounds
        c, r = (lo + hi) / 2, (hi - lo).max() / 2
        for set_lim, j in ((axk.set_xlim, 0), (axk.set_ylim, 1), (axk.set_zlim, 2)):
            set_lim(c[j] - r, c[j] + r)
        axk.set_box_aspect((1, 1, 1))
        axk.set_axis_off()
        axk.set_title(f"{link}, {title}: {len(lay)} taxels, {int(bad.sum())} (red) within 2 mm of or inside "
                      "another link", fontsize=8)
    out = Path(out or ROOT / "docs" / "img" / "robot_exposure_g1.png")
    fig.tight_layout()
    fig.savefig(out, dpi=110)
    plt.close(fig)
    print(f"wrote {out}")


if __name__ == "__main__":
    if "--exposure" in sys.argv:  # the G1 exposure picture only (slow: the G1's meshes)
        exposure_picture()
    else:
        main()
