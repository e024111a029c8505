"""Render docs/img/mujoco_touch.png (MuJoCo touch readings of an exported skin under a dropped ball)
and docs/img/urdf_frames.png (the taxel frames of the URDF export, as yourdfpy reads them).

A 60-taxel CySkin hexagon is conformed to the top of a forearm-like cylinder (radius 40 mm),
merged into a one-link robot MJCF with :func:`vtcore.robot.mjcf_tree.write_skinned` (taxel
footprint, then tile footprint), and a 0.1 kg ball is dropped onto it; after 2 s the touch
sensors are read. Run: ``.venv/bin/python scripts/render_mujoco_skin.py`` (needs mujoco).
Prints the numbers the picture shows.
"""

from __future__ import annotations

import sys
import tempfile
import warnings
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import mujoco  # noqa: E402
import numpy as np  # noqa: E402
import trimesh  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
from vtcore.layout import place, save  # noqa: E402
from vtcore.robot import mjcf_tree  # noqa: E402

R, L, MASS, G = 0.04, 0.2, 0.1, 9.81


def skin():
    mesh = trimesh.creation.cylinder(radius=R, height=L, sections=256)
    mesh.apply_transform(trimesh.transformations.rotation_matrix(np.pi / 2, [0, 1, 0]))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        lay, _ = place(mesh, "hexagon", [0.01, 0, R], [1, 0, 0])
    return lay


def drop(lay, folder: Path, footprint: str, xy) -> np.ndarray:
    robot = folder / "robot.xml"
    robot.write_text(f"""<mujoco><option timestep="0.001"/><worldbody>
<body name="forearm" pos="0 0 0.5"><geom type="cylinder" size="{R} {L / 2}" quat="0.70710678 0 0.70710678 0"/></body>
<body name="ball" pos="0 0 1"><joint type="slide" axis="0 0 1" damping="0.5"/>
<geom type="sphere" size="0.01" mass="{MASS}" rgba="0.8 0.3 0.2 1"/></body></worldbody></mujoco>""")
    out = folder / f"skinned_{footprint}.xml"
    mjcf_tree.write_skinned(lay, out, robot, body="forearm", footprint=footprint)
    m = mujoco.MjModel.from_xml_path(str(out))
    m.body_pos[m.body("ball").id] = [xy[0], xy[1] * (R + 0.01) / R, 0.5 + R + 0.03]
    d = mujoco.MjData(m)
    for _ in range(2000):
        mujoco.mj_step(m, d)
    return d.sensordata.copy()


def main() -> int:
    lay = skin()
    on_taxel = lay.positions[np.argmin(np.abs(lay.positions[:, 1]) + np.abs(lay.positions[:, 0] - 0.01))]
    between = (lay.positions[30] + lay.positions[31]) / 2
    cases = [("taxel", on_taxel[:2], "footprint taxel: ball on a taxel"),
             ("taxel", between[:2], "footprint taxel: ball between taxels"),
             ("tile", between[:2], "footprint tile: ball between taxels")]
    fig, axes = plt.subplots(1, 3, figsize=(13, 4.4), constrained_layout=True)
    with tempfile.TemporaryDirectory() as tmp:
        for ax, (fp, xy, title) in zip(axes, cases):
            s = drop(lay, Path(tmp), fp, xy)
            print(f"{title}: sum {s.sum():.4f} N (m g = {MASS * G:.4f} N), {int((s > 0).sum())} taxels read > 0")
            uv = lay.flat * 1e3
            sc = ax.scatter(uv[:, 0], uv[:, 1], c=s, s=140, cmap="YlOrRd", vmin=0, vmax=MASS * G,
                            edgecolors="0.4", linewidths=0.5)
            k = np.argmin(np.linalg.norm(lay.positions[:, :2] - xy, axis=1))
            ax.plot(*(lay.flat[k] * 1e3 + (xy - lay.positions[k, :2]) * 1e3), "b+", ms=14, mew=2)
            ax.set_title(f"{title}\nsum {s.sum():.3f} N, m g {MASS * G:.3f} N", fontsize=10)
            ax.set_aspect("equal")
            ax.set_xlabel("u (mm, unrolled skin)")
        axes[0].set_ylabel("v (mm)")
    fig.colorbar(sc, ax=axes, label="touch sensor (N)", shrink=0.9)
    out = ROOT / "docs" / "img" / "mujoco_touch.png"
    fig.savefig(out, dpi=110)
    print(f"wrote {out}")
    urdf_picture(lay)
    return 0


def urdf_picture(lay) -> None:
    import yourdfpy

    with tempfile.TemporaryDirectory() as tmp:
        save(lay, Path(tmp) / "skin.urdf", "urdf", parent="l_forearm")
        robot = yourdfpy.URDF.load(str(Path(tmp) / "skin.urdf"), load_meshes=False)
        frames = np.array([robot.get_transform(n, "l_forearm") for n in robot.link_map if "_vtskin_" in n])
    fig = plt.figure(figsize=(6.5, 5))
    ax = fig.add_subplot(projection="3d")
    th = np.linspace(-0.9, 0.9, 40)
    X, T = np.meshgrid(np.linspace(-0.03, 0.05, 2), th)
    ax.plot_surface(X * 1e3, R * np.sin(T) * 1e3, R * np.cos(T) * 1e3, color="0.85", alpha=0.5)
    o = frames[:, :3, 3] * 1e3
    for axis, colour in ((0, "r"), (1, "g"), (2, "b")):
        d = frames[:, :3, axis] * 4
        ax.quiver(o[:, 0], o[:, 1], o[:, 2], d[:, 0], d[:, 1], d[:, 2], color=colour, linewidth=0.8)
    ax.set_xlabel("x (mm)")
    ax.set_ylabel("y (mm)")
    ax.set_zlabel("z (mm)")
    ax.set_box_aspect((80, 72, 20))
    ax.view_init(38, -60)
    ax.set_title(f"{len(frames)} links l_forearm_vtskin_<id> read by yourdfpy\n(x red, y green, z blue = normal)",
                 fontsize=10)
    out = ROOT / "docs" / "img" / "urdf_frames.png"
    fig.savefig(out, dpi=110)
    print(f"wrote {out}")


if __name__ == "__main__":
    sys.exit(main())
