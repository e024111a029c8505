"""Task ``classify``: seed 000's visuo-tactile classification against the number of touches (Table 1).

Scan each object (two virtual D415s) and probe it (17 or 24 touches, the contact probe
of the augment scenes or the closed-form series probe), build the data sets of Sect. 4.1
(:mod:`vtcore.learn.datasets`), train and test PointNet for G = 0 and every G and
propagation listed, then compare active (farthest-point and coverage) and random touch selection
with the trained networks. Needs the optional extra ``vtcore[learn]`` (torch).
"""

from __future__ import annotations

import time

import numpy as np

from ...augment import make_seed000_object, two_cameras
from ...augment.experiment import probe_object
from ...augment.objects import OBJECTS, PAIRS, contrast_scales
from ...errors import InputError
from ...learn import datasets as D
from ...learn.experiment import PAPER_TABLE1, active_vs_random, touches_to_reach, train_and_test, train_mixed
from ...plots import png_writer
from ..registry import CONTACT_EFFECTS, SENSOR_EFFECTS, TaskSpec, register_task
from ..runner import TaskResult
from ..schema import Field, Section
from .augment import PARAMS as AUGMENT
from .augment import PROBE_NOISE_KEYS, contact_prober, probe_model, probe_noise

#: probing keys shared with the augment task (same meaning, same defaults)
SHARED = ("target_response", "probe", "counts_per_pa", "readings", "counts_per_newton", "layer_stiffness",
          "response_noise", *PROBE_NOISE_KEYS, "cameras", "depth_noise", "beta")

PARAMS = Section({
    "objects": Field("list", default=list(OBJECTS), item=Field("str", choices=OBJECTS),
                     doc="objects to tell apart (labels in this order)"),
    "stiffness_scales": Field("table", default={o: 1.0 for o in OBJECTS},
                              section=Section({o: Field("float", default=1.0, gt=0) for o in OBJECTS}),
                              doc="per object, multiplies its stiffness field (e.g. full_bottle = 0.2 makes the "
                                  "two bottles' bodies nearly alike: a harder problem)"),
    "contrast": Field("float", default=0.0, ge=0,
                      doc="body stiffness ratio of every same-shape pair (stiffer / softer: the full bottle, "
                          "the tennis ball, the high-shore cube scaled to it); 0: the objects as defined in "
                          "vtcore.augment.objects. The paper gives no stiffness, so no contrast either; "
                          "applied on top of stiffness_scales"),
    "probes_bottle": Field("int", default=24, ge=1, doc="|T_o| of the bottles (paper: 24)"),
    "probes_other": Field("int", default=17, ge=1, doc="|T_o| of the balls and cubes (paper: 17)"),
    "points": Field("int", default=33676, ge=1, doc="points of each visual cloud V_o (paper's bottle: 33,676)"),
    "touches": Field("list", default=list(D.TOUCHES), item=Field("int", ge=1), doc="G values (paper: 3, 7, 10, 13)"),
    "propagations": Field("list", default=list(D.PROPAGATIONS), item=Field("str", choices=D.COLOURINGS),
                          doc="colourings to train on (gp: the appendix baseline, not in Table 1)"),
    "geometry_only": Field("bool", default=True, doc="also train on the visual clouds alone (G = 0)"),
    "per_object": Field("int", default=D.PER_OBJECT, ge=1, doc="augmented clouds per object (paper: 500)"),
    "subsamples": Field("int", default=D.SUBSAMPLES, ge=1, doc="disjoint subsamples of V_o (paper: 15)"),
    "cloud_points": Field("int", default=D.POINTS, ge=8, doc="points per PointNet input (paper: 512)"),
    "epochs": Field("int", default=20, ge=1, doc="training epochs (paper: 20)"),
    "batch": Field("int", default=16, ge=2, doc="batch size (paper: 16)"),
    "learning_rate": Field("float", default=1e-3, gt=0, le=1e30, doc="Adam step"),
    "input_transform": Field("bool", default=False, doc="PointNet's input T-net (3x3)"),
    "feature_transform": Field("bool", default=False, doc="PointNet's feature T-net (64x64)"),
    # One thread by default: on this 2-core machine under load, one training step of 16 x 128
    # points took 1.9 s with one torch thread and 11.7 s with two (the second spins on a busy core).
    "recalibrate_bn": Field("bool", default=False,
                            doc="recompute batch norm statistics from the training set before each validation "
                                "(needed with few steps: the quick mode turns it on)"),
    "device": Field("str", default="cpu", choices=("cpu", "cuda", "auto"),
                    doc="where PointNet trains: cpu, cuda (an error if torch sees no CUDA GPU) or auto (cuda "
                        "when available, else cpu); result.json says which ran"),
    "threads": Field("int", default=1, ge=0, doc="torch threads, capped at the cores this process may use "
                                                  "(0: all of them)"),
    "active": Field("bool", default=True, doc="compare active (farthest-point, coverage) and random touch selection"),
    "active_touches": Field("list", default=[1, 2, 3, 5, 7, 10, 13], item=Field("int", ge=1),
                            doc="G values of that comparison (one network trained on random touches at all of them)"),
    "active_propagations": Field("list", default=["cluster"], item=Field("str", choices=D.COLOURINGS),
                                 doc="colourings of that comparison"),
    "active_seeds": Field("int", default=5, ge=1, doc="seeds of the active-vs-random comparison"),
    "active_clouds": Field("int", default=20, ge=1, doc="test clouds per object, seed and G in that comparison"),
    "quick": Field("bool", default=False,
                   doc="a smoke run: at most 16 clouds per object, 6 epochs, 128 points per cloud, 2 active "
                       "seeds of 4 clouds, batch norm recalibrated each epoch"),
    **{k: AUGMENT.fields[k] for k in SHARED},
})

QUICK = {"per_object": 16, "epochs": 6, "cloud_points": 128, "active_seeds": 2, "active_clouds": 4}
QUICK_ON = ("recalibrate_bn",)


def scan_objects(scene, ctx, names, p) -> list[D.ObjectScan]:
    """Visual cloud and probes of every object (seeded per object, independent of the others)."""
    probe = probe_model(p)
    noise, _, _ = probe_noise(scene, ctx)
    scans = []
    scales = dict(p["stiffness_scales"])
    if p["contrast"] > 0:
        scales = {o: scales[o] * f for o, f in contrast_scales(p["contrast"]).items()}
    for name in ctx.progress(names, desc="scanning and probing", total=len(names)):
        obj = make_seed000_object(name, scales[name])
        lo, hi = np.asarray(obj.mesh.bounds)
        cams = two_cameras(target=tuple((lo + hi) / 2), depth_noise=p["depth_noise"])[:p["cameras"]]
        n_touch = p["probes_bottle"] if "bottle" in name else p["probes_other"]
        prober = contact_prober(scene, ctx, obj) if p["probe"] == "contact" else None
        t0 = time.perf_counter()
        probed = probe_object(obj, n_touch, probe, cameras=cams, n_points=p["points"], rng=ctx.child_rng(f"scan.{name}"),
                              probe_fn=prober, noise=noise)
        c = probed.tactile.values
        scans.append(D.ObjectScan(name, probed.points, probed.tactile.points, c if c.ndim == 1 else c[:, 0],
                                  meta={"probe_seconds": time.perf_counter() - t0,
                                        "probes_unreachable": len(prober.failures) if prober else 0,
                                        "probes_repeated": probed.meta["probes_repeated"],
                                        "probes_rejected": probed.meta["probes_rejected"]}))
    return scans


def _checked_params(scene) -> dict:
    """The task's parameters (``task.quick`` applied), checked against each other: errors name the key."""
    p = dict(scene["task"])
    if p["quick"]:
        p.update({k: min(p[k], v) for k, v in QUICK.items()})
        p.update({k: True for k in QUICK_ON})
    names = list(p["objects"])
    if len(set(names)) != len(names) or len(names) < 2:
        raise scene.error("task.objects", f"needs two or more distinct objects, got {names}")
    if not p["touches"] and not p["geometry_only"] and not p["active"]:
        raise scene.error("task.touches", "is empty and geometry_only and active are false: nothing to train")
    for key in ("touches", "active_touches"):
        for g in p[key] if key == "touches" or p["active"] else ():
            few = [n for n in names if (p["probes_bottle"] if "bottle" in n else p["probes_other"]) < g]
            if few:
                raise scene.error(f"task.{key}", f"G = {g} touches per cloud but {', '.join(few)} "
                                                 f"{'has' if len(few) == 1 else 'have'} fewer probes "
                                                 f"(probes_bottle / probes_other)")
    return p


def _epoch_logger(say, name, t0):
    """A training ``progress`` callback that writes one line per epoch to the training log."""
    def progress(epoch, epochs, row):
        say(f"{name}: epoch {epoch}/{epochs} loss {row['train_loss']:.4f} "
            f"train {row['train_accuracy']:.3f} val {row['val_accuracy']:.3f} ({time.perf_counter() - t0:.0f} s)")

    return progress


def _train_all(scene, versions, scans, subs, cfg, scale, p, say, t0):
    """Train and test PointNet on every data set version; returns ({name: result}, metrics)."""
    from ...learn.train import TrainConfig

    results, metrics = {}, {}
    for i, ds in enumerate(versions):
        r = train_and_test(ds, scans, subs, TrainConfig(seed=scene.seed + i, **cfg), scale=scale, beta=p["beta"],
                           progress=_epoch_logger(say, ds.name, t0))
        results[ds.name] = r
        say(f"{ds.name}: test accuracy {r.accuracy:.4f}, {r.seconds_train:.1f} s training")
        metrics[f"accuracy_{ds.name}"] = r.accuracy
        metrics[f"train_seconds_{ds.name}"] = r.seconds_train
        metrics[f"train_cpu_seconds_{ds.name}"] = r.cpu_seconds_train
        metrics[f"data_seconds_{ds.name}"] = r.seconds_data
        metrics[f"infer_ms_per_cloud_{ds.name}"] = r.infer_ms
        metrics[f"best_epoch_{ds.name}"] = r.best_epoch
    return results, metrics


def _outputs(results, versions, scans, subs, p, names):
    """Figures (confusions, training curves) and arrays (confusions, curves, the scans, every data set's
    clouds) of the trained versions."""
    from ...learn.plots import confusion_figure, curves_figure

    figures, objects = {}, tuple(names)
    fig8 = {k: results[k].confusion for k in ("g0", f"cluster_g{max(p['touches'], default=0)}") if k in results}
    if fig8:
        figures["fig8_confusion"] = png_writer(confusion_figure, fig8, objects,
                                               "Fig. 8: test-set confusion (rows: true object)")
    if results:
        figures["confusion_all"] = png_writer(confusion_figure, {k: r.confusion for k, r in results.items()},
                                              objects)
        figures["training_curves"] = png_writer(curves_figure, {k: r.curves for k, r in results.items()})
    arrays = {f"confusion_{k}": r.confusion for k, r in results.items()}
    arrays.update({f"curve_val_accuracy_{k}": np.asarray(r.curves["val_accuracy"]) for k, r in results.items()})
    for o, s in enumerate(scans):
        arrays[f"visual_points_{s.name}"] = s.points          # V_o: with the indices below, every cloud
        arrays[f"probe_points_{s.name}"] = s.touch_points
        arrays[f"probe_values_{s.name}"] = s.touch_values
        arrays[f"subsamples_{s.name}"] = subs[o]
    for ds in versions:
        arrays[f"dataset_{ds.name}_labels"] = ds.labels
        arrays[f"dataset_{ds.name}_subsample"] = ds.subsample
        arrays[f"dataset_{ds.name}_touches"] = ds.touches
        arrays[f"dataset_{ds.name}_split"] = ds.split
    return figures, arrays


def _active_part(scene, scans, subs, cfg, scale, p, say, t0):
    """Active (farthest-point, coverage) against random touch selection with networks trained on mixed
    G; returns (metrics, arrays, figure, report section)."""
    from ...learn.plots import active_figure
    from ...learn.train import TrainConfig

    t1 = time.perf_counter()
    models, metrics, arrays = {}, {}, {}
    for j, prop in enumerate(p["active_propagations"]):
        model, acc_mixed, secs = train_mixed(scans, subs, p["active_touches"], prop,
                                             TrainConfig(seed=scene.seed + 100 + j, **cfg),
                                             per_object=p["per_object"], seed=scene.seed, scale=scale,
                                             beta=p["beta"], progress=_epoch_logger(say, f"active_{prop}", t0))
        metrics[f"active_network_accuracy_{prop}"] = acc_mixed
        metrics[f"active_network_train_seconds_{prop}"] = secs
        models.update({(prop, g): model for g in p["active_touches"]})
    av = active_vs_random(models, scans, subs, seeds=p["active_seeds"], per_object=p["active_clouds"],
                          seed=scene.seed, scale=scale, beta=p["beta"])
    metrics["active_seconds"] = time.perf_counter() - t1
    for (prop, policy), (gs, a) in av["accuracy"].items():
        for gi, g in enumerate(gs):
            metrics[f"active_accuracy_{prop}_{policy}_g{g}"] = float(np.mean(a[:, gi]))
            metrics[f"active_accuracy_std_{prop}_{policy}_g{g}"] = float(np.std(a[:, gi]))
        metrics[f"active_touches_to_95_{prop}_{policy}"] = touches_to_reach(gs, a)
        arrays[f"active_accuracy_{prop}_{policy}"] = a
    for (prop, policy), (gs, e) in av["map_error"].items():
        for gi, g in enumerate(gs):
            metrics[f"active_map_error_{prop}_{policy}_g{g}"] = float(np.nanmean(e[:, gi]))
        arrays[f"active_map_error_{prop}_{policy}"] = e
    acc = {f"{prop} {pol}": v for (prop, pol), v in av["accuracy"].items()}
    err = {f"{prop} {pol}": v for (prop, pol), v in av["map_error"].items()}
    figure = png_writer(active_figure, acc, err,
                        f"active (farthest, coverage) vs random touches, {p['active_seeds']} seeds")
    return metrics, arrays, figure, _active_table(av, p)


def run(scene, ctx) -> TaskResult:
    from ...learn.pointnet import require_torch, resolve_device

    p = _checked_params(scene)
    names = list(p["objects"])
    require_torch()                                   # before the scans: a missing extra fails in a second
    try:
        device = resolve_device(p["device"])          # ... and so does a GPU asked for and not there
    except InputError as exc:
        raise scene.error("task.device", exc.reason) from None
    log = (ctx.out / "training.log").open("w", encoding="utf-8")

    def say(text):
        log.write(text + "\n")
        log.flush()

    t0 = time.perf_counter()
    scans = scan_objects(scene, ctx, names, p)
    t_scan = time.perf_counter() - t0
    say(f"scanned and probed {len(scans)} objects in {t_scan:.1f} s")
    subs = D.object_subsamples(scans, scene.seed, subsets=p["subsamples"], size=p["cloud_points"])
    scale = D.c_scale(scans)
    versions = ([D.make_dataset(scans, 0, seed=scene.seed, subsamples=subs)] if p["geometry_only"] else [])
    versions += [D.make_dataset(scans, g, prop, per_object=p["per_object"], seed=scene.seed, subsamples=subs)
                 for prop in p["propagations"] for g in p["touches"]]
    cfg = dict(epochs=p["epochs"], batch=p["batch"], lr=p["learning_rate"], input_transform=p["input_transform"],
               feature_transform=p["feature_transform"], threads=p["threads"] or None,
               recalibrate_bn=p["recalibrate_bn"], device=device)
    say(f"training on {device} (task.device = {p['device']})")
    results, metrics = _train_all(scene, versions, scans, subs, cfg, scale, p, say, t0)
    metrics["scan_seconds"] = t_scan
    metrics["train_on_cuda"] = int(device.startswith("cuda"))
    metrics.update(scan_metrics(scans, p))
    metrics["clouds_per_object"] = int(p["per_object"])
    metrics["epochs"] = int(p["epochs"])
    figures, arrays = _outputs(results, versions, scans, subs, p, names)
    sections = [_table(results, versions, p)]
    if p["active"]:
        am, aa, figures["active_vs_random"], section = _active_part(scene, scans, subs, cfg, scale, p, say, t0)
        metrics.update(am)
        arrays.update(aa)
        sections.append(section)
    log.close()
    manifest = D.manifest(versions, scans, scale=scale, points=p["cloud_points"])
    from ..._io import write_json

    write_json(ctx.out / "manifest.json", manifest)
    return TaskResult(metrics=metrics, arrays=arrays, figures=figures, sections=sections,
                      files=["manifest.json", "training.log"],
                      extra={"datasets": manifest["datasets"], "device": device})


def scan_metrics(scans, p) -> dict:
    """What the probes measured: the contrast asked for, each same-shape pair's measured colour
    contrast (median probed colour of the stiffer over the softer), repeated and rejected touches."""
    by = {s.name: s for s in scans}
    out = {"contrast": float(p["contrast"])}
    for pair, (soft, stiff) in PAIRS.items():
        if soft in by and stiff in by:
            out[f"colour_contrast_{pair}"] = float(np.median(by[stiff].touch_values)
                                                   / np.median(by[soft].touch_values))
    for key in ("probes_repeated", "probes_rejected", "probes_unreachable"):
        out[key] = int(sum(s.meta.get(key, 0) for s in scans))
    return out


def _table(results, versions, p) -> str:
    lines = ["## Accuracy against touches (test split), beside seed 000's Table 1", "",
             f"{p['per_object']} clouds per object (G = 0: {p['subsamples']}), {p['cloud_points']} points, "
             f"{p['epochs']} epochs, batch {p['batch']}, probe `{p['probe']}`.", "",
             "| data set | ours (%) | paper (%) | test clouds | best epoch | data (s) | training (s) | "
             "inference (ms/cloud) |", "|---|---|---|---|---|---|---|---|"]
    for ds in versions:
        r = results[ds.name]
        paper = PAPER_TABLE1.get(ds.name)
        lines.append(f"| {ds.name} | {100 * r.accuracy:.2f} | {'-' if paper is None else f'{paper:.2f}'} | "
                     f"{r.counts['test']} | {r.best_epoch} | {r.seconds_data:.1f} | {r.seconds_train:.1f} | "
                     f"{r.infer_ms:.2f} |")
    return "\n".join(lines)


def _active_table(av, p) -> str:
    lines = ["## Active (farthest-point, coverage) vs random touches", "",
             f"One network per colouring trained on random touches at every G listed; {p['active_clouds']} "
             f"test clouds per object, seed and G whose touches each policy chose; mean ± std over "
             f"{p['active_seeds']} seeds.", "",
             "| propagation | policy | " + " | ".join(f"G={g}" for g in
                                                    next(iter(av["accuracy"].values()))[0]) + " |",
             "|---|---|" + "---|" * len(next(iter(av["accuracy"].values()))[0])]
    for (prop, policy), (gs, a) in av["accuracy"].items():
        cells = [f"{100 * np.mean(a[:, i]):.1f} ± {100 * np.std(a[:, i]):.1f}" for i in range(len(gs))]
        lines.append(f"| {prop} | {policy} | " + " | ".join(cells) + " |")
    return "\n".join(lines)


register_task(TaskSpec("classify", run, PARAMS, effects=CONTACT_EFFECTS + SENSOR_EFFECTS,
                       doc="seed 000: PointNet on augmented clouds against the number of touches (needs torch)"))
