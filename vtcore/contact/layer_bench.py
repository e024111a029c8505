"""The layer models against the finite-element reference (``vtcore bench contact`` writes ``layer/``).

For each reference indenter (:data:`vtcore.contact.indenters.CASES`) and layer (3, 6, 10 mm of
Ecoflex 00-20, bonded), the neo-Hookean reference (:mod:`vtcore.contact.fem_reference`) and the FFT
layer models (``finite_layer``, linear; ``hyperelastic``, :mod:`vtcore.contact.hyperelastic`) press
to the same compressions (the indenter's travel beyond first contact over h). Axisymmetric cases
run on an N x N grid; plane-strain ones (cube edge, finger pad) on a body 16 h long, read on its
middle row (force per unit length). Reported: force, peak pressure and contact radius (half-width),
each model's largest relative error up to 60 % compression, and the time of a force-controlled
press on the N = 256 problem (a sphere into 3 mm) per model.
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np

from .elastic import compliance_operator, solve_pk
from .hyperelastic import SETH_HILL_ORDER, solve_large
from .indenters import CASES, Indenter
from .materials import SoftLayer

COMPRESSIONS = (0.05, 0.1, 0.2, 0.3, 0.4, 0.5, 0.6)
THICKNESSES = (0.003, 0.006, 0.010)
FAST_MODELS = ("finite_layer", "hyperelastic")


def fast_grid(ind: Indenter, h: float, n: int, cmax: float = 0.6):
    """(gap (nx, ny) m, dx, dy, middle row index or None): the reference case on an FFT grid.

    Axisymmetric: n x n cells over the largest contact radius plus 4 h each side. Plane: n cells
    across and a body 16 h long along y in cells of h / 2 (its middle row is in plane strain).
    """
    a = ind.radius if ind.kind in ("punch", "cube_edge") else min(ind.radius, 1.3 * np.sqrt(2 * ind.radius * cmax * h))
    half = a + 4 * h
    dx = 2 * half / n
    x = (np.arange(n) - n / 2 + 0.5) * dx
    if ind.geometry == "axisymmetric":
        X, Y = np.meshgrid(x, x, indexing="ij")
        return ind.gap(X, Y), dx, dx, None
    dy = h / 2
    ny = 32
    y = (np.arange(ny) - ny / 2 + 0.5) * dy
    X, Y = np.meshgrid(x, y, indexing="ij")
    return ind.gap(X, Y), dx, dy, ny // 2


def fast_curves(ind: Indenter, layer: SoftLayer, model: str, compressions=COMPRESSIONS, n: int = 256,
                order: float | None = None):
    """Force (N or N/m), peak pressure (Pa) and contact radius (m) of a fast model, each (S,)."""
    g, dx, dy, mid = fast_grid(ind, layer.thickness, n, max(compressions))
    op = compliance_operator(g.shape, dx, dy, layer, "finite_layer", 1e-7)
    X = (np.arange(g.shape[0]) - g.shape[0] / 2 + 0.5) * dx
    Y = (np.arange(g.shape[1]) - g.shape[1] / 2 + 0.5) * dy
    R = np.hypot(*np.meshgrid(X, Y, indexing="ij")) if mid is None else np.abs(X)[:, None] + 0 * Y
    out, p0 = [], None
    for c in compressions:
        d = c * layer.thickness
        kw = {} if order is None else {"order": order}
        s = (solve_pk(g, op, dx * dy, approach=d, p0=p0) if model == "finite_layer" else
             solve_large(g, op, dx * dy, layer.thickness, approach=d, p0=p0, **kw))
        p = s.pressure if mid is None else s.pressure[:, mid:mid + 1]
        force = float(p.sum() * dx * (dy if mid is None else 1.0))
        rad = float(R[:, :p.shape[1]][p > 0].max()) + dx / 2 if mid is not None and p.any() else \
            (float(R[p > 0].max()) + dx / 2 if p.any() else 0.0)
        out.append((force, float(p.max()), rad))
        p0 = s.pressure
    return tuple(np.array(v) for v in zip(*out))


def errors(ref, fast, upto: float = 0.6):
    """Largest |fast / ref - 1| over compressions <= ``upto``, for force and peak pressure."""
    c = np.asarray(ref["c"])
    k = c <= upto + 1e-9
    return (float(np.max(np.abs(np.asarray(fast[0])[k] / np.asarray(ref["f"])[k] - 1))),
            float(np.max(np.abs(np.asarray(fast[1])[k] / np.asarray(ref["p"])[k] - 1))))


#: Seth-Hill orders the fit scans (1: the linear layer)
ORDERS = (1.0, 0.8, 0.6, 0.5, 0.4, 0.3, 0.2)


def fit_order(refs: dict, n: int = 128, orders=ORDERS, upto: float = 0.6):
    """(best order, {order: (rms error, worst error)}): the Seth-Hill order with the smallest
    root-mean-square relative error of force and peak pressure over every reference case and
    compression up to ``upto`` (the worst single error is reported beside it; a least-squares fit,
    not a min-max one, so one poorly resolved reference point does not decide it).

    refs : ``"<kind>_<h>"`` -> reference dict (:func:`reference_curves`).
    """
    out = {}
    for m in orders:
        errs = []
        for key, ref in refs.items():
            kind, h = key.rsplit("_", 1)
            fc = fast_curves(CASES[kind], SoftLayer(thickness=float(h)), "finite_layer" if m == 1 else "hyperelastic",
                             ref["c"], n, order=None if m == 1 else m)
            k = np.asarray(ref["c"]) <= upto + 1e-9
            for got, want in ((fc[0], ref["f"]), (fc[1], ref["p"])):
                errs.extend(np.asarray(got)[k] / np.asarray(want)[k] - 1)
        e = np.abs(np.array(errs))
        out[m] = (float(np.sqrt(np.mean(e**2))), float(e.max()))
    return min(out, key=lambda m: out[m][0]), out


def timed_press(model: str, n: int = 256, force: float = 2.0, h: float = 0.003, repeat: int = 3):
    """Best wall and CPU seconds of a force-controlled press of the 30 mm sphere into ``h`` on n x n."""
    lay = SoftLayer(thickness=h)
    g, dx, _, _ = fast_grid(CASES["sphere"], h, n)
    op = compliance_operator(g.shape, dx, dx, lay, "finite_layer", 1e-7)
    best = (np.inf, np.inf)
    for _ in range(repeat):
        w, c = time.perf_counter(), time.process_time()
        if model == "finite_layer":
            s = solve_pk(g, op, dx * dx, force=force)
        else:
            s = solve_large(g, op, dx * dx, h, force=force)
        best = min(best, (time.perf_counter() - w, time.process_time() - c))
    return best[0], best[1], float(s.approach)


def reference_curves(ind: Indenter, layer: SoftLayer, compressions=COMPRESSIONS, fine: float | None = None,
                     max_seconds: float | None = None) -> dict:
    """The finite-element reference as a dict (c, f, p, a, seconds, dofs); ``fine`` and ``max_seconds`` as in
    reference_press."""
    from .fem_reference import reference_press

    r = reference_press(ind, layer.thickness, layer.young_modulus, layer.poisson, compressions, fine=fine,
                        max_seconds=max_seconds)
    return {"c": list(r.compression), "f": list(r.force), "p": list(r.peak_pressure), "a": list(r.contact_radius),
            "seconds": r.seconds, "cpu_seconds": r.cpu_seconds, "dofs": int(r.dofs)}


#: the reference sweeps as the bench runs them (not the quick run), computed once: 100-250 s each on the
#: shared machine, so the fit and the bench read them from here (``python -m vtcore.contact.layer_bench``)
REFERENCE_FILE = Path(__file__).with_name("layer_reference.json")


def load_references(path: Path = REFERENCE_FILE) -> dict:
    """``"<kind>_<h>"`` -> reference dict (:func:`reference_curves`) stored in ``path``; {} when absent."""
    import json

    path = Path(path)
    return json.loads(path.read_text())["cases"] if path.exists() else {}


def store_reference(key: str, ref: dict, path: Path = REFERENCE_FILE, command: str = "") -> None:
    """Add (or replace) one case in the reference file, with the scikit-fem version, the command that
    made it and the date; written to a temporary file and moved in (never half-written)."""
    import json
    import os
    from datetime import datetime, timezone
    from importlib.metadata import version

    path = Path(path)
    data = json.loads(path.read_text()) if path.exists() else {"about": "neo-Hookean FE reference sweeps "
                                                                "(vtcore.contact.fem_reference), Ecoflex 00-20 "
                                                                "defaults, bonded base", "cases": {}}
    data["cases"][key] = dict(ref, scikit_fem=version("scikit-fem"), command=command,
                              date=datetime.now(timezone.utc).strftime("%Y-%m-%d %H:%M UTC"),
                              load=os.getloadavg()[0])
    tmp = path.with_suffix(".tmp")
    tmp.write_text(json.dumps(data, indent=1) + "\n")
    tmp.replace(path)


def run(out: Path, quick: bool = False, refs: dict | None = None) -> list[dict]:
    """Write ``out/layer.md``, ``layer.csv`` and ``layer_curves.png``, ``layer_accuracy_vs_time.png``.

    refs : precomputed reference dicts by ``"<kind>_<h>"`` (``json`` of :func:`reference_curves`); given,
        only those cases run. Else every case is computed here (12 sweeps of 100-250 s at a load of 20).
    quick : the sphere into 3 mm at 5 and 10 % on a coarse mesh, N = 64 (a smoke run).
    """
    from .._bench import write_table

    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    kinds = ("sphere",) if quick else tuple(CASES)
    comps = (0.05, 0.1) if quick else COMPRESSIONS
    hs = (0.003,) if quick else THICKNESSES
    n = 64 if quick else 256
    rows, curves = [], {}
    for h in hs:
        lay = SoftLayer(thickness=h)
        for kind in kinds:
            key = f"{kind}_{h}"
            if refs is not None and key not in refs:
                continue
            ref = (refs or {}).get(key) or reference_curves(CASES[kind], lay, comps,
                                                                       h / 4 if quick else None)
            if not ref["c"]:
                continue  # the reference reached none of the compressions (its warning says where it stopped)
            row = {"indenter": kind, "h_mm": h * 1e3, "reference_s": round(ref.get("seconds", ref.get("s", 0)), 1)}
            curves[key] = {"ref": ref}
            for model in FAST_MODELS:
                t = time.perf_counter()
                fc = fast_curves(CASES[kind], lay, model, ref["c"], n)
                curves[key][model] = fc
                ef, ep = errors(ref, fc)
                row[f"{model}_force_err"] = round(ef, 4)
                row[f"{model}_peak_err"] = round(ep, 4)
                row[f"{model}_s"] = round(time.perf_counter() - t, 2)
            rows.append(row)
    timing = {m: timed_press(m, n) for m in FAST_MODELS}
    best, worst = fit_order({k: v["ref"] for k, v in curves.items()}, 64 if quick else 128)
    notes = [f"Force-controlled press, 30 mm sphere, 2 N into 3 mm, N = {n}: " + "; ".join(
        f"{m} {w * 1e3:.0f} ms wall / {c * 1e3:.0f} ms CPU" for m, (w, c, _) in timing.items()) +
        f" (ratio {timing['hyperelastic'][1] / timing['finite_layer'][1]:.2f} in CPU time).",
        f"Seth-Hill order scan (rms / largest relative error of force and peak pressure to 60 % over these cases, "
        f"N = {64 if quick else 128}): " + ", ".join(f"m = {m:g}: {e[0]:.3f} / {e[1]:.3f}" for m, e in worst.items())
        + f"; best m = {best:g}, shipped "
        f"SETH_HILL_ORDER = {SETH_HILL_ORDER:g}."]
    write_table(out, rows, title="Layer models against the neo-Hookean finite-element reference", notes=notes)
    for name in ("table.md", "table.csv"):
        (out / name).replace(out / name.replace("table", "layer"))
    _plots(out, curves, rows, timing)
    return rows


def _plots(out: Path, curves: dict, rows: list[dict], timing: dict) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from .._bench import save_png

    keys = list(curves)
    fig, axes = plt.subplots(3, len(keys), figsize=(2.6 * len(keys), 7.5), squeeze=False)
    for j, key in enumerate(keys):
        ref = curves[key]["ref"]
        c = np.asarray(ref["c"]) * 100
        for i, (what, scale, label) in enumerate((("f", 1.0, "force (N or N/m)"), ("p", 1e-3, "peak pressure kPa"),
                                                  ("a", 1e3, "contact radius mm"))):
            ax = axes[i, j]
            ax.plot(c, np.asarray(ref[what]) * scale, "k-o", ms=3, label="FE neo-Hookean")
            for model, style in zip(FAST_MODELS, ("b--", "r-")):
                ax.plot(c, np.asarray(curves[key][model][i]) * scale, style, label=model)
            if j == 0:
                ax.set_ylabel(label)
            if i == 0:
                kind, h = key.rsplit("_", 1)
                ax.set_title(f"{kind} {float(h) * 1e3:g} mm", fontsize=8)
            if i == 2:
                ax.set_xlabel("compression %")
            ax.tick_params(labelsize=6)
    axes[0, 0].legend(fontsize=6)
    fig.tight_layout()
    save_png(fig, out / "layer_curves.png")
    plt.close(fig)
    fig, ax = plt.subplots(figsize=(4.5, 3.5))
    for model, mk in zip(FAST_MODELS, ("bs", "ro")):
        worst = max(max(r[f"{model}_force_err"], r[f"{model}_peak_err"]) for r in rows)
        ax.plot(timing[model][1] * 1e3, worst * 100, mk, label=model)
    ref_s = max(r["reference_s"] for r in rows)
    ax.plot(ref_s * 1e3, 0.0, "k^", label="FE reference (slowest case)")
    ax.set_xscale("log")
    ax.set_xlabel("time per press, ms (CPU; reference: wall per sweep)")
    ax.set_ylabel("largest error to 60 %, %")
    ax.legend(fontsize=7)
    fig.tight_layout()
    save_png(fig, out / "layer_accuracy_vs_time.png")
    plt.close(fig)


def main(argv=None) -> None:
    """``python -m vtcore.contact.layer_bench KIND H_MM [--max-seconds S]``: compute one reference sweep at the
    bench's compressions and mesh and store it in :data:`REFERENCE_FILE`."""
    import argparse
    import sys

    ap = argparse.ArgumentParser(prog="python -m vtcore.contact.layer_bench")
    ap.add_argument("kind", choices=tuple(CASES))
    ap.add_argument("h_mm", type=float)
    ap.add_argument("--max-seconds", type=float, default=None)
    ap.add_argument("--file", type=Path, default=REFERENCE_FILE)
    a = ap.parse_args(argv)
    h = a.h_mm * 1e-3
    ref = reference_curves(CASES[a.kind], SoftLayer(thickness=h), COMPRESSIONS, max_seconds=a.max_seconds)
    store_reference(f"{a.kind}_{h:g}", ref, a.file, "python -m vtcore.contact.layer_bench " + " ".join(
        sys.argv[1:] if argv is None else argv))
    print(f"{a.kind} {a.h_mm:g} mm: reached {ref['c'][-1] if ref['c'] else 0:.0%} in {ref['seconds']:.0f} s")


if __name__ == "__main__":
    main()
