"""``vtcore bench robot``: skin every link of a real robot from its URDF, export it, load it back.

UR10 from example-robot-data: a fill of each link's outer shell (:func:`vtcore.robot.lay_on_link`,
collision geometry: the closed outer shells; and the visual COLLADA meshes, whose open and sharp
edges a fill has to step round), each link in a forked child (its own wall and CPU seconds and peak
resident memory); the merged URDF and MJCF export of all skins; and the accuracy as the consumers
load them (yourdfpy, MuJoCo: largest taxel distance to its link's mesh and angle to its normal over
the zero pose and 5 random configurations). Writes ``table.md``, ``table.csv``,
``accuracy_vs_time.png`` and ``skinned_robot.png`` (the skinned UR10 at a pose).
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np

from .._bench import best_time, in_child, save_png, write_table

#: What this benchmark measures its error against (the closing note of ``vtcore bench`` lists it).
REFERENCE = ("the exported skins as two other libraries load and pose them (yourdfpy for the URDF, MuJoCo for "
             "the MJCF; zero pose and 5 random configurations): each taxel's distance to its link's mesh (max_mm) "
             "and its z's angle to the surface normal, on every per-link row (3 links at --quick, every link in "
             "full) and on the export rows (the worst taxel of the file that row wrote)")

GOALS = ("Goals (issue 25): every UR10 link skinned from its URDF in < 60 s in all; merged URDF and MJCF export < 5 s. "
         "(issue 33): exposure of every G1 link (visual) at the zero pose and 32 sampled configurations < 20 s; "
         "adds < 20 % to a link's fill; MJCF export of a robot with 1,000 taxels including the contact-geometry "
         "step < 10 s (export_mjcf_g1_cold).")

#: the G1 links filled (visual, exposed surface) for the 1,000-taxel export: 1,020 taxels (head 630,
#: left shoulder yaw 190, left shoulder roll 100, left elbow 100); the quick run fills the first only
G1_EXPORT_LINKS = ("left_shoulder_yaw_link", "head_link", "left_shoulder_roll_link", "left_elbow_link")


def _robot():
    from .export import load_robot
    from .samples import example_robot_data

    return load_robot(example_robot_data() / "ur_description" / "urdf" / "ur10_robot.urdf")


def _skin_links(robot, geometry, links, rows, patch="fill"):
    from ..layout.report import DEFAULT_MAX_STRAIN, PLACE_MAX_STRAIN
    from .meshes import link_mesh
    from .skin import lay_on_link

    layouts = []
    for link in links:
        sec, cpu, mb, res, err = in_child(lambda link=link: lay_on_link(robot, link, patch, geometry=geometry))
        lay, rep = res if res is not None else (None, None)
        # what the CLI and the add-on would say of it: refused unless forced, or kept
        problems = [] if rep is None else rep.problems(DEFAULT_MAX_STRAIN if patch == "fill" else PLACE_MAX_STRAIN)
        rows.append({"case": "fill_link" if patch == "fill" else f"{patch}_link", "geometry": geometry, "link": link,
                     "faces": len(link_mesh(robot, link, geometry).faces),
                     "modules": 0 if lay is None else lay.n_modules, "taxels": 0 if lay is None else len(lay),
                     "coverage": None if rep is None else rep.coverage, "seconds": sec, "cpu_seconds": cpu,
                     "peak_mb": mb, "max_mm": None, "max_deg": None, "footprint_deg": None,
                     "extra": err or ("refused unless forced: " + "; ".join(problems) if problems else "")})
        if lay is not None:
            layouts.append(lay)
    return layouts


def _export_rows(robot, layouts, geometry, out, rows, quick):
    from .export import export_skinned
    from .meshes import link_mesh
    from .samples import example_robot_data
    from .verify import check_mjcf, check_urdf

    # the MJCF export's contact geometry (CoACD of each rebuilt link) is cached beside the output: the first
    # export into a fresh folder pays it, the timed repeats below read it back
    import time

    cold = out / f"cold_{geometry}"
    cold.mkdir(parents=True, exist_ok=True)
    start = time.perf_counter()
    records = export_skinned(robot.path, layouts, cold / f"ur10_skinned_{geometry}.xml")
    rows.append({"case": "export_mjcf_cold", "geometry": geometry, "link": "all",
                 "taxels": sum(len(x) for x in layouts), "seconds": time.perf_counter() - start,
                 "extra": f"{sum(len(r['unreadable']) for r in records)} taxels cannot read"})
    # the cache is '<out stem>_meshes/' beside each output: the timed exports below write elsewhere,
    # so they get the cold export's decompositions (without them the first timed MJCF export paid CoACD
    # again: 52 s of the 175 s --quick run at a load of 11)
    import shutil

    cached = cold / f"ur10_skinned_{geometry}_meshes"
    if cached.is_dir():
        shutil.copytree(cached, out / cached.name, dirs_exist_ok=True)
    for fmt, ext in (("urdf", "urdf"), ("mjcf", "xml")):
        path = out / f"ur10_skinned_{geometry}.{ext}"
        sec, _ = best_time(lambda path=path: export_skinned(robot.path, layouts, path), repeat=1 if quick else 3)
        rows.append({"case": f"export_{fmt}", "geometry": geometry, "link": "all",
                     "taxels": sum(len(x) for x in layouts), "seconds": sec, "extra": path.name})
    rng = np.random.default_rng(0)
    configs = [{}] + [robot.random_configuration(rng) for _ in range(5)]
    configs = [{j.name: robot.joint_value(j, q) for j in robot.joints if j.type != "fixed"} for q in configs]
    urdf = check_urdf(out / f"ur10_skinned_{geometry}.urdf", configs, geometry,
                      packages={"example-robot-data": example_robot_data().parent})
    mj = check_mjcf(out / f"ur10_skinned_{geometry}.xml", {x.frame: link_mesh(robot, x.frame, geometry)
                                                           for x in layouts}, configs)
    # each export row's error is the worst taxel of the file it wrote, as its consumer loads it
    for r in rows:
        if r["geometry"] == geometry and r["case"] in ("export_urdf", "export_mjcf"):
            stats = urdf if r["case"] == "export_urdf" else mj
            for key in ("max_mm", "max_deg", "footprint_deg"):
                r[key] = max((s.get(key, 0.0) for s in stats.values()), default=None)
    for r in rows:
        if r["case"].endswith("_link") and r["geometry"] == geometry and r["link"] in urdf:
            u, m = urdf[r["link"]], mj.get(r["link"], {})
            r["max_mm"] = max(u["max_mm"], m.get("max_mm", 0.0))
            r["max_deg"] = max(u["max_deg"], m.get("max_deg", 0.0))
            r["footprint_deg"] = max(u["footprint_deg"], m.get("footprint_deg", 0.0))


def exposure_rows(rows, quick: bool = False) -> None:
    """Issue 33's rows: the exposure of every link of a robot (the G1's visual meshes; the quick run:
    the UR10's collision hulls) at the zero pose and 32 sampled configurations, in a forked child
    (wall, CPU, peak MB); and one link's fill without and with the exposure (what it adds)."""
    from .export import load_robot
    from .exposure import robot_exposure
    from .samples import example_robot_data

    if quick:
        robot, geometry, link = _robot(), "collision", "forearm_link"
    else:
        robot = load_robot(example_robot_data() / "g1_description" / "urdf" / "g1_29dof_with_hand_rev_1_0.urdf")
        geometry, link = "visual", "left_wrist_roll_link"
    sec, cpu, mb, res, err = in_child(lambda: {k: e.summary() for k, e in robot_exposure(robot, geometry).items()})
    rows.append({"case": "exposure_all_links", "geometry": geometry, "link": f"{robot.name}: {len(res or {})} links",
                 "faces": sum(s["faces"] for s in (res or {}).values()), "seconds": sec, "cpu_seconds": cpu,
                 "peak_mb": mb, "coverage": None if not res else sum(s["exposed_m2"] for s in res.values())
                 / max(sum(s["area_m2"] for s in res.values()), 1e-30),
                 "extra": err or "zero pose + 32 configurations; coverage column: exposed fraction of the area"})
    from .skin import lay_on_link

    for exposure in (False, True):
        sec, cpu, mb, res, err = in_child(lambda e=exposure: lay_on_link(robot, link, "fill", geometry=geometry,
                                                                         exposure=e))
        lay = None if res is None else res[0]
        rows.append({"case": "fill_exposed" if exposure else "fill_anywhere", "geometry": geometry,
                     "link": f"{robot.name}: {link}", "modules": None if lay is None else lay.n_modules,
                     "taxels": None if lay is None else len(lay), "seconds": sec, "cpu_seconds": cpu,
                     "peak_mb": mb, "extra": err or ""})


def _g1():
    from .export import load_robot
    from .samples import example_robot_data

    return load_robot(example_robot_data() / "g1_description" / "urdf" / "g1_29dof_with_hand_rev_1_0.urdf")


def g1_export_rows(out: Path, rows: list, quick: bool = False) -> None:
    """Issue 33's export goal: the merged MJCF of the G1 with about 1,000 taxels (fills of
    :data:`G1_EXPORT_LINKS`, visual geometry, exposed surface; the quick run: the first link), each
    fill in a forked child (``g1_fill_link`` rows); the export into a fresh folder
    (``export_mjcf_g1_cold``: the contact-geometry step, a CoACD decomposition of each skinned link
    and of the links crowding a skin, and the contact check of every site at the zero pose and 8
    configurations), then again over it (``export_mjcf_g1``: the decompositions read back), each
    timed in this process (wall and CPU seconds, the machine's load: :func:`_g1_export_row`); accuracy side by side: the largest taxel
    distance to its link's mesh and angle to its normal in MuJoCo (zero pose and 5 random
    configurations) and how many taxels the export's contact check says cannot read."""
    import shutil

    from .skin import lay_on_link

    robot = _g1()
    layouts = []
    for link in G1_EXPORT_LINKS[:1] if quick else G1_EXPORT_LINKS:
        sec, cpu, mb, res, err = in_child(lambda link=link: lay_on_link(robot, link, "fill", geometry="visual"))
        if res is not None:
            layouts.append(res[0])
        rows.append({"case": "g1_fill_link", "geometry": "visual", "link": link,
                     "modules": None if res is None else res[0].n_modules, "taxels": None if res is None else
                     len(res[0]), "seconds": sec, "cpu_seconds": cpu, "peak_mb": mb, "extra": err or ""})
    if layouts:
        folder = out / "g1_export"
        shutil.rmtree(folder, ignore_errors=True)  # a fresh folder: the first export decomposes every link
        for case in ("export_mjcf_g1_cold", "export_mjcf_g1"):  # the second over the first: parts read back
            rows.append(_g1_export_row(robot, layouts, case, folder / "g1_skinned.xml"))


def _g1_export_row(robot, layouts, case: str, path: Path) -> dict:
    """One row of :func:`g1_export_rows`: ``export_skinned`` of ``layouts`` to ``path`` (wall and CPU
    seconds of this process, CoACD's threads included), then MuJoCo's reading of the file it wrote.

    In this process, not a forked child (:func:`vtcore._bench.in_child`): CoACD's OpenMP runtime
    (libgomp) hangs in a child forked after its parent has run CoACD, as the UR10 export rows do
    in this process (the quick run waited 13 minutes in ``coacd::Compute``)."""
    import os

    from .export import export_skinned
    from .meshes import link_mesh
    from .verify import check_mjcf

    path.parent.mkdir(parents=True, exist_ok=True)
    taxels = sum(len(x) for x in layouts)
    load0 = os.getloadavg()[0]
    t0, c0 = time.perf_counter(), time.process_time()
    try:
        res, err = export_skinned(robot.path, layouts, path), None
    except Exception as exc:  # noqa: BLE001  (reported in the row, as in_child does)
        res, err = None, f"{type(exc).__name__}: {exc}"
    row = {"case": case, "geometry": "visual", "link": f"{robot.name}: {len(layouts)} links", "taxels": taxels,
           "seconds": time.perf_counter() - t0, "cpu_seconds": time.process_time() - c0, "peak_mb": None,
           "load": f"{load0:.1f}-{os.getloadavg()[0]:.1f}", "extra": err or ""}
    if res is None:
        return row
    # the second export overwrites the first: its decompositions (the same meshes) are read back
    row["extra"] = ("contact parts decomposed (CoACD)" if case.endswith("_cold") else
                    "contact parts read back from the first export")
    row["extra"] += f"; {sum(len(r['unreadable']) for r in res)} of {taxels} taxels cannot read (contact check)"
    rng = np.random.default_rng(0)
    configs = [{}] + [robot.random_configuration(rng) for _ in range(5)]
    configs = [{j.name: robot.joint_value(j, q) for j in robot.joints if j.type != "fixed"} for q in configs]
    mj = check_mjcf(path, {x.frame: link_mesh(robot, x.frame, "visual") for x in layouts}, configs)
    for key in ("max_mm", "max_deg", "footprint_deg"):
        row[key] = max(v.get(key, 0.0) for v in mj.values())
    return row


def picture(robot, layouts, geometry, path, q=None) -> None:
    """The skinned robot at joint values ``q``: link meshes grey, taxels coloured by link."""
    import matplotlib.pyplot as plt
    from mpl_toolkits.mplot3d.art3d import Poly3DCollection

    from .meshes import link_mesh

    poses = robot.link_poses(q or {})
    fig = plt.figure(figsize=(7, 7))
    ax = fig.add_subplot(projection="3d")
    cmap = plt.get_cmap("tab10")
    lo, hi = np.full(3, np.inf), np.full(3, -np.inf)
    for name, ln in robot.links.items():
        if not ln.geometry(geometry):
            continue
        m = link_mesh(robot, name, geometry)
        t = poses[name]
        v = m.vertices @ t[:3, :3].T + t[:3, 3]
        lo, hi = np.minimum(lo, v.min(0)), np.maximum(hi, v.max(0))
        ax.add_collection3d(Poly3DCollection(v[m.faces], facecolor=(0.8, 0.8, 0.82, 0.25), edgecolor="none"))
    for k, lay in enumerate(layouts):
        t = poses[lay.frame]
        p = lay.positions @ t[:3, :3].T + t[:3, 3]
        ax.scatter(*p.T, s=2, color=cmap(k % 10), label=f"{lay.frame}: {len(lay)}", depthshade=False)
    c, r = (lo + hi) / 2, (hi - lo).max() / 2
    ax.set_xlim(c[0] - r, c[0] + r)
    ax.set_ylim(c[1] - r, c[1] + r)
    ax.set_zlim(c[2] - r, c[2] + r)
    ax.set_box_aspect((1, 1, 1))
    ax.set_title(f"{robot.name} skinned from its URDF ({geometry} geometry): "
                 f"{sum(len(x) for x in layouts)} taxels")
    ax.legend(fontsize=7, markerscale=4, loc="upper left")
    ax.set_axis_off()
    save_png(fig, path, dpi=120)
    plt.close(fig)


def _command_rows(out: Path, geometries, rows: list, workers_tried=(1, 2)) -> None:
    """``skin_command`` rows (2 workers; ``skin_command_1worker``: 1): ``vtcore robot skin``
    (:func:`.skin_robot.skin_robot`) of every UR10 link: one row per link (its own wall and CPU seconds,
    peak memory, what its fill lost where) and one for the command, each with the machine's load."""
    import os

    from .skin_robot import lost_text, skin_robot

    urdf = _robot().path
    for geometry in geometries:
        for workers in workers_tried:
            case = "skin_command" if workers > 1 else "skin_command_1worker"
            load0 = os.getloadavg()[0]
            t0 = time.perf_counter()
            rep = skin_robot(urdf, out / f"skin_{geometry}_{workers}", geometry=geometry, workers=workers, bars=False)
            wall = time.perf_counter() - t0
            load = f"{load0:.1f}-{os.getloadavg()[0]:.1f}"
            done = [r for r in rep["links"] if r["status"] != "skipped"]
            for r in done:
                rows.append({"case": case, "geometry": geometry, "link": f"{r['link']} ({workers} workers)",
                             "faces": r.get("faces"), "modules": r.get("modules"), "taxels": r.get("taxels"),
                             "coverage": r.get("coverage"), "seconds": r.get("seconds"),
                             "cpu_seconds": r.get("cpu_seconds"), "peak_mb": r.get("peak_mb"), "load": load,
                             "extra": r["status"] + (f": {r['reason']}" if r.get("reason") else "")
                             + (f"; lost: {lost_text(r['lost'])}" if r.get("lost") else "")})
            rows.append({"case": case, "geometry": geometry, "link": f"whole command, {workers} workers",
                         "modules": rep["modules"], "taxels": sum(r.get("taxels") or 0 for r in done),
                         "seconds": wall, "cpu_seconds": sum(r.get("cpu_seconds") or 0 for r in done),
                         "peak_mb": max([r.get("peak_mb") or 0 for r in done] + [0]), "load": load,
                         "extra": "merged URDF + MJCF written" if rep.get("robot_files") else ""})


def _command_plot(rows: list, path: Path) -> None:
    """Each link's wall and CPU seconds in ``vtcore robot skin`` (one panel per geometry and worker
    count) against the goals: 20 s a collision link, 2 minutes a visual one (issue 36)."""
    import matplotlib.pyplot as plt

    runs = sorted({(r["geometry"], r["case"]) for r in rows})
    fig, axes = plt.subplots(1, len(runs), figsize=(6 * len(runs), 4.2), squeeze=False)
    for ax, (geometry, case) in zip(axes[0], runs):
        rr = [r for r in rows if r["geometry"] == geometry and r["case"] == case]
        y = np.arange(len(rr))
        ax.barh(y - 0.2, [r.get("seconds") or 0 for r in rr], 0.4, label="wall s")
        ax.barh(y + 0.2, [r.get("cpu_seconds") or 0 for r in rr], 0.4, label="CPU s")
        ax.axvline(20 if geometry == "collision" else 120, color="k", ls="--", lw=0.8, label="goal per link")
        ax.set_yticks(y, [f"{r['link']}: {int(r.get('modules') or 0)}" for r in rr], fontsize=7)
        ax.invert_yaxis()
        ax.set_xscale("log")
        ax.set_xlabel("seconds")
        ax.set_title(f"{geometry}, {rr[-1]['link'].split(', ')[-1]}, load {rr[-1].get('load', '')}", fontsize=9)
        ax.legend(fontsize=7)
    fig.suptitle("UR10: vtcore robot skin, per link (modules after the colon)")
    fig.tight_layout()
    save_png(fig, path, dpi=110)


def _wanted(cases: str | None, *names: str) -> bool:
    """Whether one of ``names`` matches one of the comma-separated fnmatch ``cases`` (None: all)."""
    from fnmatch import fnmatch

    pats = [c.strip() for c in (cases or "*").split(",") if c.strip()]
    return any(fnmatch(n, p) for n in names for p in pats)


def run(out: Path, quick: bool = False, geometries=None, cases: str | None = None) -> list[dict]:
    """Run the robot benchmark into ``out``; ``geometries``: which of the links' "collision" and
    "visual" meshes to skin (default: both; the quick run: collision); ``cases``: only the groups of
    rows whose case matches (``fill_link``: the per-link fills and the exports; ``exposure_all_links``;
    ``skin_command``, ``skin_command_1worker``: the whole-robot command with 2 and 1 workers;
    ``export_mjcf_g1``: the G1's MJCF export with about 1,000 taxels, :func:`g1_export_rows`)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    robot = _robot()
    rows: list = []
    t0 = time.perf_counter()
    kinds = tuple(geometries) if geometries else (("collision",) if quick else ("collision", "visual"))
    skins = {}
    for geometry in (kinds if _wanted(cases, "fill_link", "all_links", "export_urdf", "export_mjcf") else ()):
        links = [n for n, ln in robot.links.items() if ln.geometry(geometry)]
        if quick:  # the command's smoke run: one hexagon on each of three links (three settings with an error)
            links = links[:3]
        start = time.perf_counter()
        skins[geometry] = _skin_links(robot, geometry, links, rows, "hexagon" if quick else "fill")
        rows.append({"case": "all_links", "geometry": geometry, "link": f"{len(links)} links",
                     "modules": sum(x.n_modules for x in skins[geometry]),
                     "taxels": sum(len(x) for x in skins[geometry]), "seconds": time.perf_counter() - start,
                     "cpu_seconds": sum(r["cpu_seconds"] for r in rows if r["case"].endswith("_link")
                                        and r["geometry"] == geometry),
                     "peak_mb": max((r["peak_mb"] for r in rows if r["case"].endswith("_link")
                                     and r["geometry"] == geometry), default=None)})
        if skins[geometry]:
            _export_rows(robot, skins[geometry], geometry, out, rows, quick)
    if _wanted(cases, "exposure_all_links", "fill_exposed", "fill_anywhere"):
        exposure_rows(rows, quick)
    if _wanted(cases, "export_mjcf_g1", "export_mjcf_g1_cold", "g1_fill_link"):
        g1_export_rows(out, rows, quick)
    tried = tuple(w for w, c in ((1, "skin_command_1worker"), (2, "skin_command")) if _wanted(cases, c))
    if not quick and tried:  # the whole-robot command, the same links filled in parallel
        _command_rows(out, kinds, rows, tried)
    import os

    write_table(out, rows, title="Robot benchmark: the UR10 skinned from its URDF" + (" (quick)" if quick else ""),
                notes=[GOALS, f"Machine load (1, 5, 15 min) at the end: {os.getloadavg()}; the whole run took "
                       f"{time.perf_counter() - t0:.0f} s.",
                       "fill_link: one fill per link in a forked child (wall and CPU seconds, the child's peak "
                       "resident MB including the imported libraries); max_mm: the largest taxel distance to its "
                       "link's mesh; max_deg: the largest angle between a taxel's z and the normal of the nearest "
                       "face; footprint_deg: the largest angle between a taxel's z and the nearest normal of the "
                       "faces under its 4 mm disc (and the arcs between them): yourdfpy and MuJoCo, zero pose and "
                       "5 random configurations. extra: why a link carries no module, or what the CLI and the "
                       "add-on would refuse the fill for unless forced."],
                columns=["case", "geometry", "link", "faces", "modules", "taxels", "coverage", "seconds",
                         "cpu_seconds", "peak_mb", "load", "max_mm", "max_deg", "footprint_deg", "extra"])
    fig, ax = plt.subplots(figsize=(6, 4))
    for geometry, mk in (("collision", "o"), ("visual", "s")):
        rr = [r for r in rows if r["case"].endswith("_link") and r["geometry"] == geometry
              and r.get("max_mm") is not None]
        if rr:
            ax.scatter([r["seconds"] for r in rr], [r["max_mm"] for r in rr], marker=mk, label=geometry)
            for r in rr:
                ax.annotate(r["link"].replace("_link", ""), (r["seconds"], r["max_mm"]), fontsize=6)
    ax.set_xlabel("fill seconds (one link)")
    ax.set_ylabel("largest taxel distance to the link mesh (mm)")
    ax.set_title("UR10: fill time and placement accuracy per link")
    ax.legend()
    fig.tight_layout()
    save_png(fig, out / "accuracy_vs_time.png", dpi=110)
    plt.close(fig)
    if any(r["case"].startswith("skin_command") for r in rows):
        _command_plot([r for r in rows if r["case"].startswith("skin_command")], out / "skin_command.png")
    for geometry, layouts in skins.items():
        if layouts:
            picture(robot, layouts, geometry, out / f"skinned_robot_{geometry}.png",
                    {"shoulder_lift_joint": -1.0, "elbow_joint": 1.2, "wrist_1_joint": -0.6})
    return rows
