"""Task ``validate``: the scene's indenter, layer and sensor effects against real recordings.

``task.recordings`` (CySkin text files or glob patterns, relative to the scene file) on the
scene's layout (``[layout] file``, the recorded skin's own calibration); every contact frame is
simulated with a matched press (:mod:`vtcore.calibrate.validate`: pose from the recorded footprint,
the force that reproduces the recorded peak, the recording's own idle baseline) and read through
the listed ``gain``, ``noise``, ``saturation`` and ``quantisation`` effects. Writes ``arrays.npz``
with ``positions (N, 3)`` m, ``real (K, N)`` and ``sim (K, N)`` counts (NaN: not recorded),
``noise_sigma (N,)``, ``pressure (K, N)`` Pa, ``force (K,)`` N, ``compression (K,)``,
``recording (K,)``, ``frame (K,)``, ``held_out (K,)``, ``baselines (R, N)``; the footprint
statistics' quartiles in ``result.json`` (all frames, and each recording's peak frame apart:
``peak_*``); ``footprints.png``, ``metrics.png`` and ``by_force.png`` (each statistic against force).
"""

from __future__ import annotations

import glob
import warnings
from pathlib import Path

import numpy as np

from ..registry import TaskSpec, register_task
from ..runner import TaskResult
from ..schema import Field, Section
from ..sections.layer import build_layer, layer_options
from ..sections.layout import build_layout

PARAMS = Section({
    "recordings": Field("list", default=[], item=Field("str"),
                        doc="CySkin text recordings or glob patterns (relative to the scene file)"),
    "held_out": Field("list", default=None, item=Field("str"),
                      doc="recordings (path endings, e.g. 1_finger/sample_12.txt) the calibration did not see "
                          "(default: the gain profile's [response] held_out)"),
    "object": Field("int", default=0, ge=0, doc="which [[objects]] entry is the indenter"),
    "conform": Field("bool", default=True, doc="a finger pad's axis follows the skin's curvature along it"),
    "wrap": Field("float", default=None, ge=0, le=1,
                  doc="how far a conforming finger pad wraps the skin: 1 its full curvature, 0 straight "
                      "(default: the profile's fitted indenter's, else 1)"),
    "indenter_from_profile": Field("bool", default=False,
                                   doc="press with the finger pad the gain profile was fitted with ([response] "
                                       "indenter) instead of the [[objects]] entry"),
    "k": Field("float", default=None, gt=0, doc="detection threshold in noise deviations (default: the noise "
                                                "profile's, else 5)"),
})


def _expand(patterns, base: Path, scene) -> list[str]:
    out = []
    for i, pat in enumerate(patterns):
        p = Path(pat).expanduser()
        p = p if p.is_absolute() else base / p
        hits = sorted(glob.glob(str(p))) if any(ch in pat for ch in "*?[") else ([str(p)] if p.exists() else [])
        if not hits:
            raise scene.error(f"task.recordings[{i}]", f"no file matches {pat} (looked at {p})")
        out += hits
    if not out:
        raise scene.error("task.recordings", "validate needs at least one recording")
    return out


def run(scene, ctx) -> TaskResult:
    from ...calibrate.plots import footprints_figure, force_figure, metrics_figure
    from ...calibrate.validate import Sensor, validate
    from ...contact.materials import LargeDeformationWarning
    from ...contact.objects import DEFAULTS

    task = scene["task"]
    gain, noise = ctx.pipeline.get("gain"), ctx.pipeline.get("noise")
    if gain is None or noise is None:
        raise scene.error("effects", "task 'validate' needs [effects.gain] and [effects.noise] (the transfer "
                                     "curve, and the noise that both detects contact and is simulated)")
    spread = ctx.pipeline.get("soft_layer")
    if spread is None or spread.kernel != "layer":
        # every simulated press spreads the stress with the layer's own kernel, as the gain was fitted
        raise scene.error("effects.soft_layer", "task 'validate' reads the stress spread through the layer (the "
                                                "gain is fitted so): list [effects.soft_layer] with kernel = \"layer\"")
    layout = build_layout(scene)
    prof = getattr(gain, "profile_obj", None)
    if task["indenter_from_profile"]:
        if prof is None or prof.response is None or not prof.response.indenter:
            raise scene.error("task.indenter_from_profile", "[effects.gain] has no profile with a fitted indenter")
        indenter = prof.response.press_indenter()
    else:
        if not scene["objects"] or task["object"] >= len(scene["objects"]):
            raise scene.error("objects", "task 'validate' needs an [[objects]] table for the indenter")
        obj = scene["objects"][task["object"]]
        if obj["kind"] == "mesh":
            raise scene.error(f"objects[{task['object']}].kind", "validate presses a primitive indenter")
        indenter = {"kind": obj["kind"], **{k: obj[k] for k in DEFAULTS[obj["kind"]] if obj.get(k) is not None}}
    indenter.pop("bend_radius", None)            # conform decides the bend per frame
    if task["wrap"] is not None:
        if indenter["kind"] != "fingerpad":
            raise scene.error("task.wrap", f"applies to a finger pad; the indenter is a {indenter['kind']}")
        indenter["wrap"] = task["wrap"]
    sigma = np.asarray(noise.sigmas(len(layout)), float) * np.ones(len(layout))
    sat = ctx.pipeline.get("saturation")
    quant = ctx.pipeline.get("quantisation")
    sensor = Sensor(gain=gain.counts, sigma=sigma, clip=(sat.lo, sat.hi) if sat is not None else (-np.inf, np.inf),
                    step=quant.step if quant is not None else 0.0)
    for name, fx in (("saturation", sat), ("quantisation", quant)):
        if fx is not None:  # applied inside the validation's sensor model (their time is the validation's)
            ctx.pipeline.add_time(name, 0.0)
    held = task["held_out"]
    if held is None:
        held = list(prof.response.fields.get("held_out", [])) if prof is not None and prof.response else []
    k = task["k"] or (noise.profile.detection_k if noise.profile is not None else 5.0)
    paths = _expand(task["recordings"], Path(scene.path).resolve().parent, scene)
    layer = build_layer(scene)
    opts = layer_options(scene)
    notes: list[str] = []
    v = validate(paths, layout, layer=layer, indenter=indenter, sensor=sensor, rng=ctx.child_rng("validate-noise"),
                 k=k, conform=task["conform"], held_out=held, grid=opts["grid"],
                 samples_per_taxel=spread.samples or opts["samples_per_taxel"], warn=notes.append)
    arrays = {"positions": layout.positions, "normals": layout.normals, "taxel_ids": layout.taxel_ids,
              "real": v.real, "sim": v.sim, "noise_sigma": sigma, "pressure": v.pressure, "force": v.force,
              "compression": v.compression, "recording": v.recording, "frame": v.frame, "held_out": v.held_out,
              "baselines": v.baselines}
    figures = {}
    if scene["output"]["plots"]:  # the runner closes only the figures it saves: never built and left open
        figures = {"footprints": footprints_figure(v, layout, f"{scene.name}: recorded vs simulated footprints "
                                                               "(strongest frame of each recording)"),
                   "metrics": metrics_figure(v, f"{scene.name}: footprint statistics over the contact frames"),
                   "by_force": force_figure(v, f"{scene.name}: footprint statistics against the pressed force")}
    for w in v.warnings + notes:     # the runner lists them (result.json "warnings", report.md)
        warnings.warn(w, LargeDeformationWarning if "linear elasticity" in w else UserWarning, stacklevel=2)
    sections = [_table(v.metrics), f"Indenter: {indenter}, conforming to the skin: {task['conform']}. "
                f"Recordings held out of the calibration: {', '.join(held) or 'none named'}."]
    unrecorded = "the taxel is not in the recording (its UID is missing): unknown on both sides"
    return TaskResult(metrics=v.metrics, arrays=arrays, figures=figures, sections=sections,
                      nan_meaning={"real": unrecorded, "sim": unrecorded},
                      extra={"recordings": v.paths, "held_out": held, "indenter": indenter,
                             "conform": task["conform"]})


def _table(m: dict) -> str:
    from ...calibrate.footprint import METRICS

    lines = ["## Recorded vs simulated footprints", "",
             "| frames | statistic | recorded median [IQR] | simulated median [IQR] | simulated median within recorded IQR |",
             "|---|---|---|---|---|"]
    for g, label in (("all", "all"), ("heldout", "held out of the calibration"), ("fitted", "used by the calibration"),
                     ("peak_heldout", "peak frames, held out"), ("peak_fitted", "peak frames, used by the calibration"),
                     ("rest_all", "all but the peak frames")):
        if f"{g}_real_peak_median" not in m:
            continue
        for name in METRICS:
            r = [m[f"{g}_real_{name}_{q}"] for q in ("median", "q25", "q75")]
            s = [m[f"{g}_sim_{name}_{q}"] for q in ("median", "q25", "q75")]
            lines.append(f"| {label} | {name} | {r[0]:.3g} [{r[1]:.3g}-{r[2]:.3g}] | {s[0]:.3g} [{s[1]:.3g}-{s[2]:.3g}] "
                         f"| {'yes' if m[f'{g}_sim_{name}_within_real_iqr'] else 'no'} |")
    return "\n".join(lines)


register_task(TaskSpec("validate", run, PARAMS, sections=("layout", "layer"),
                       effects=("soft_layer", "gain", "noise", "saturation", "quantisation"),
                       doc="compare the sensor model with real recordings, press by press"))
