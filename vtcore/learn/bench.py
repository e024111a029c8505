"""``vtcore bench learn``: classification accuracy against time (seed 000, Sect. 4.1, Table 1).

Six objects seen by two virtual D415s and probed with the closed-form series probe
(the contact probe of ``scenes/classify_touches.toml`` costs ~2 s an object more and
changes no timing below); data sets as in Sect. 4.1 at a reduced size; PointNet
trained and tested for each G and colouring. Each row: data-set generation time
(the colouring of every cloud), training time, inference time per cloud, and the test
accuracy. The plain GP of the appendix is the third colouring. Needs torch (the
optional extra ``vtcore[learn]``); without it (the Python 3.13 lane) the table and the
plot say that it did not run and why, so ``vtcore bench`` over every area still reports.
"""

from __future__ import annotations

import time
from pathlib import Path

from .._bench import save_png, write_table
from .datasets import ObjectScan, c_scale, make_dataset, object_subsamples
from .experiment import PAPER_TABLE1, train_and_test

#: What this benchmark measures its error against (the closing note of ``vtcore bench`` lists it).
REFERENCE = "the held-out test clouds' true labels (classification accuracy)"


def scans_series(points: int, seed: int = 0) -> list[ObjectScan]:
    """The six objects with the series probe (24 touches on the bottles, 17 on the others)."""
    from ..augment import OBJECTS, ProbeModel, make_seed000_object
    from ..augment.experiment import probe_object

    out = []
    for o, name in enumerate(OBJECTS):
        pb = probe_object(make_seed000_object(name), 24 if "bottle" in name else 17, ProbeModel(), n_points=points,
                          rng=[seed, o])
        out.append(ObjectScan(name, pb.points, pb.tactile.points, pb.tactile.values))
    return out


def run(out: Path, quick: bool = False) -> list[dict]:
    from .pointnet import MissingTorchError, require_torch
    from .train import TrainConfig

    out = Path(out)
    try:
        require_torch()
    except MissingTorchError as exc:
        rows = [{"colouring": "-", "touches": None, "status": f"not run: {exc}"}]
        write_table(out, rows, title="Classification: accuracy against time (seed 000 Table 1)",
                    notes=["Not run: torch is not installed in this environment."])
        save_png(_not_run(str(exc)), out / "accuracy_vs_time.png")
        return rows
    size = dict(per_object=6, epochs=2, cloud_points=128, points=3000) if quick else \
        dict(per_object=60, epochs=10, cloud_points=512, points=12000)
    touches = (3, 7, 13)  # >= 3 points per curve, quick or not
    scans = scans_series(size["points"])
    subs = object_subsamples(scans, 0, size=size["cloud_points"])
    scale = c_scale(scans)
    rows = []
    versions = [make_dataset(scans, 0, seed=0, subsamples=subs)]
    versions += [make_dataset(scans, g, prop, per_object=size["per_object"], seed=0, subsamples=subs)
                 for prop in ("cluster", "smooth", "gp") for g in touches]
    for i, ds in enumerate(versions):
        cfg = TrainConfig(epochs=size["epochs"], threads=1, seed=i, recalibrate_bn=True)
        t0 = time.perf_counter()
        r = train_and_test(ds, scans, subs, cfg, scale=scale)
        rows.append({"colouring": ds.propagation, "touches": ds.touches_g, "clouds": len(ds.labels),
                     "data_s": round(r.seconds_data, 3),
                     "data_ms_per_cloud": round(1e3 * r.seconds_data / len(ds.labels), 3),
                     "train_s": round(r.seconds_train, 2), "train_cpu_s": round(r.cpu_seconds_train, 2),
                     "infer_ms_per_cloud": round(r.infer_ms, 3), "accuracy_pct": round(100 * r.accuracy, 2),
                     "paper_pct": PAPER_TABLE1.get(ds.name), "total_s": round(time.perf_counter() - t0, 2)})
    notes = [f"{'Quick' if quick else 'Reduced'} sizes: {size['per_object']} clouds per object (paper 500), "
             f"{size['epochs']} epochs (paper 20), {size['cloud_points']} points per cloud (paper 512), series "
             "probe, one torch thread, batch norm recalibrated each epoch. The full run is "
             "`vtcore run scenes/classify_touches.toml` (docs/augment.md). Times are wall clock on a shared "
             "machine; train_cpu_s is this process's CPU time. The paper's numbers (Table 1, %) are in paper_pct; "
             "at these sizes ours are not comparable to them, the columns show what each colouring costs."]
    write_table(out, rows, title="Classification: accuracy against time (seed 000 Table 1)", notes=notes)
    save_png(_plot(rows), out / "accuracy_vs_time.png")
    return rows


def _plot(rows):
    from ..plots import pyplot

    plt = pyplot()
    fig, ax = plt.subplots(figsize=(6.4, 4.2))
    for colouring, marker in (("none", "s"), ("cluster", "o"), ("smooth", "^"), ("gp", "D")):
        sel = [r for r in rows if r["colouring"] == colouring]
        if not sel:
            continue
        x = [r["data_s"] + r["train_s"] for r in sel]
        y = [r["accuracy_pct"] for r in sel]
        ax.plot(x, y, marker=marker, ls="", label=colouring if colouring != "none" else "geometry only")
        for xi, yi, r in zip(x, y, sel):
            ax.annotate(f"G={r['touches']}", (xi, yi), fontsize=7, xytext=(3, 3), textcoords="offset points")
    ax.set_xscale("log")
    ax.set_xlabel("data set + training time (s, wall)")
    ax.set_ylabel("test accuracy (%)")
    ax.legend(fontsize=8)
    fig.tight_layout()
    return fig


def _not_run(reason: str):
    from ..plots import pyplot

    fig, ax = pyplot().subplots(figsize=(6.4, 2.0))
    ax.axis("off")
    ax.text(0.5, 0.5, "classification benchmark not run:\n" + reason, ha="center", va="center", wrap=True)
    return fig
