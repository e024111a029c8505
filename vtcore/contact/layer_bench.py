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
from .hyperelastic import Law, law, solve_large
from .indenters import CASES, Indenter
from .materials import SoftLayer

COMPRESSIONS = (0.05, 0.1, 0.2, 0.3, 0.4, 0.5, 0.6)
THICKNESSES = (0.003, 0.006, 0.010)
FAST_MODELS = ("finite_layer", "hyperelastic")


def fast_grid(ind: Indenter, h: float, n: int, cmax: float = 0.6):
    """(gap (nx, ny) m, dx, dy, middle row index or None): the reference case on an FFT grid.

    Axisymmetric: n x n cells over the largest contact radius plus 4 h each side. Plane: n cells
    across and a body max(16 h, 6 a) long along y in 32 cells (its middle row is in plane strain).
    """
    a = ind.radius if ind.kind in ("punch", "cube_edge") else min(ind.radius, 1.3 * np.sqrt(2 * ind.radius * cmax * h))
    half = a + 4 * h
    dx = 2 * half / n
    x = (np.arange(n) - n / 2 + 0.5) * dx
    if ind.geometry == "axisymmetric":
        X, Y = np.meshgrid(x, x, indexing="ij")
        return ind.gap(X, Y), dx, dx, None
    # long enough that its middle row is in plane strain: 16 h, and 6 contact half-widths for a wide face (a
    # bonded layer's pressure under a face much wider than h spans the whole face: 16 h left the cube's edge
    # on 3 mm 8 % softer than plane strain at 5 %)
    ny = 32
    dy = max(16 * h, 6 * a) / ny
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
             solve_large(g, op, dx * dy, layer.thickness, approach=d, p0=p0, spacing=(dx, dy), **kw))
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


#: Seth-Hill orders the fit evaluates each case at (the fit interpolates between them; 1: the linear layer)
ORDERS = (1.6, 1.4, 1.2, 1.0, 0.8, 0.6, 0.4, 0.2, 0.0, -0.2, -0.4, -0.6)


def _order_table(ind: Indenter, layer: SoftLayer, comps, n: int, orders=ORDERS):
    """Per compression: the footprint's elongation e (-), and per order in ``orders`` the pressure (on the
    read row or grid) and the compression there, for the :func:`fit_law` interpolation."""
    from .hyperelastic import elongation

    h = layer.thickness
    g, dx, dy, mid = fast_grid(ind, h, n, max(comps))
    op = compliance_operator(g.shape, dx, dy, layer, "finite_layer", 1e-7)
    w = dx * (dy if mid is None else 1.0)
    rows = []
    for c in comps:
        e = float(elongation(g < c * h, (dx, dy)).max())
        fields = []
        for m in orders:
            s = solve_large(g, op, dx * dy, h, approach=c * h, order=m, spacing=(dx, dy))
            p = s.pressure if mid is None else s.pressure[:, mid]
            cc = np.clip((c * h - (g if mid is None else g[:, mid])) / h, 0.0, 0.9)
            fields.append((p, cc))
        rows.append((e, w, fields))
    return rows


def _law_curves(rows, lw: Law, orders=ORDERS):
    """(force, peak) (2, S) of law ``lw`` from an :func:`_order_table`, linear in the order between its grid."""
    om = np.asarray(orders)
    out = []
    for e, w, fields in rows:
        m = np.clip(lw.round + (lw.strip - lw.round) * e, om.min(), om.max())
        j = int(np.clip(np.searchsorted(-om, -m), 1, len(om) - 1))
        t = (m - om[j - 1]) / (om[j] - om[j - 1])
        fp = [(np.sum(p * (1 - cc) ** -lw.concentration) * w, np.max(p * (1 - cc) ** -lw.concentration))
              for p, cc in (fields[j - 1], fields[j])]
        out.append((1 - t) * np.array(fp[0]) + t * np.array(fp[1]))
    return np.array(out).T


def fit_law(refs: dict, fit_keys=None, n: int = 128, upto: float = 0.6, tables: dict | None = None,
            round_order: float | None = 1.0):
    """(fitted :class:`Law`, {case: (force errors, peak errors)} signed, (S,) each, rms over the fitted
    cases): the law with the smallest root-mean-square relative error of force and peak pressure over the
    cases ``fit_keys`` (default: all) and compressions up to ``upto``; the errors are reported for every
    case of ``refs``, so cases left out of the fit are held-out tests. A least-squares fit (Nelder-Mead),
    not a min-max one: one poorly resolved reference point does not decide it.

    round_order : the round contact's order held fixed (default 1, the linear layer's travel: fitted
    too, None, it trades against the stiffening exponent along a valley, 1.2-1.6 for k 0.2-0.38 at
    the same error within a few tenths of a per cent, and leaves the orders' grid).

    refs : ``"<kind>_<h>"`` -> reference dict (:func:`reference_curves`, :func:`load_references`).
    tables : a cache of :func:`_order_table` by case, filled here (the slow part: 10 orders per point).
    """
    from scipy.optimize import minimize

    tables = {} if tables is None else tables
    data = {}
    for key, ref in refs.items():
        kind, h = key.rsplit("_", 1)
        k = np.asarray(ref["c"]) <= upto + 1e-9
        if key not in tables:
            tables[key] = _order_table(CASES[kind], SoftLayer(thickness=float(h)), np.asarray(ref["c"])[k], n)
        data[key] = (tables[key], np.asarray(ref["f"])[k], np.asarray(ref["p"])[k])

    def errs(lw, key):
        rows, f, p = data[key]
        got = _law_curves(rows, lw)
        return got[0] / f - 1, got[1] / p - 1

    keys = list(refs) if fit_keys is None else [k for k in fit_keys if k in refs]

    def full(x):
        return x if round_order is None else (round_order, *x)

    def cost(x):
        lw = Law(*full(x))
        if not (ORDERS[-1] <= min(lw.round, lw.strip) and max(lw.round, lw.strip) <= ORDERS[0]
                and 0 <= lw.concentration < 2):
            return 1e3
        return float(np.mean(np.concatenate([np.concatenate(errs(lw, k)) for k in keys]) ** 2))

    x0 = [0.9, 0.4, 0.1] if round_order is None else [0.4, 0.1]
    r = minimize(cost, x0, method="Nelder-Mead", options={"xatol": 1e-4, "fatol": 1e-9})
    lw = Law(*(round(float(v), 3) for v in full(r.x)))
    return lw, {k: errs(lw, k) for k in refs}, float(np.sqrt(cost(r.x[:] if round_order is None else
                                                                   (lw.strip, lw.concentration))))


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
    """``"<kind>_<h>"`` -> reference dict (:func:`reference_curves`) stored in ``path``; {} when absent.

    A case stored again on a finer mesh (key ``"<kind>_<h>@<mesh>"``, its spacing in ``"fine"``) replaces
    the values at the compressions it has, the finest last; ``"refined"`` lists those compressions."""
    import json

    path = Path(path)
    cases = json.loads(path.read_text())["cases"] if path.exists() else {}
    out = {k: dict(v, f=list(v["f"]), p=list(v["p"]), a=list(v["a"])) for k, v in cases.items() if "@" not in k}
    for key, v in sorted(((k, v) for k, v in cases.items() if "@" in k), key=lambda kv: -kv[1].get("fine", 0)):
        base = out.get(key.split("@")[0])
        for j, c in enumerate(v["c"] if base else ()):
            i = np.flatnonzero(np.isclose(base["c"], c))
            for q in ("f", "p", "a") if i.size else ():
                base[q][int(i[0])] = v[q][j]
            if i.size:
                base["refined"] = sorted(set(base.get("refined", [])) | {c})
                base.setdefault("mesh_at", {})[c] = key.split("@")[1]
    return out


def mesh_label(ref: dict) -> str:
    """Which reference mesh each compression's values come from, e.g. ``"h/8"`` or ``"h/16 5-50 %, h/8 60 %"``."""
    at = [ref.get("mesh_at", {}).get(c, "h/8") for c in ref["c"]]
    parts = []
    for m in dict.fromkeys(at):
        cs = [c for c, x in zip(ref["c"], at) if x == m]
        parts.append(f"{m} {cs[0] * 100:.0f}" + (f"-{cs[-1] * 100:.0f} %" if len(cs) > 1 else " %"))
    return parts[0].split(" ")[0] if len(parts) == 1 else ", ".join(parts)


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


#: the cases :data:`vtcore.contact.hyperelastic.Law`'s constants were fitted on; every other case of the
#: reference file (the 6 mm layers, the punch, the cube's edge) is a held-out test of the fit
FIT_CASES = ("sphere_0.003", "sphere_0.01", "finger_0.003", "finger_0.01")


def run(out: Path, quick: bool = False, refs: dict | None = None, recompute: bool = False) -> list[dict]:
    """Write ``out/layer.md``, ``layer.csv`` and ``layer_curves.png``, ``layer_accuracy_vs_time.png``.

    refs : reference dicts by ``"<kind>_<h>"`` (:func:`reference_curves`); default: the cached
        :data:`REFERENCE_FILE` (:func:`load_references`), and a case it lacks is computed here (100-250 s
        at a load of 20, kept out of the file). recompute : compute every case here instead.
    quick : the sphere into 3 mm at 5 and 10 % on a coarse mesh, N = 64 (a smoke run, always computed).
    """
    from .._bench import write_table

    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    if refs is None and not (quick or recompute):
        refs = load_references()
    n = 64 if quick else 256
    rows, curves = [], {}
    for h in (0.003,) if quick else THICKNESSES:
        for kind in ("sphere",) if quick else tuple(CASES):
            key = f"{kind}_{h}"
            ref = (refs or {}).get(key) or reference_curves(CASES[kind], SoftLayer(thickness=h),
                                                           (0.05, 0.1) if quick else COMPRESSIONS,
                                                           h / 4 if quick else None)
            if ref["c"]:  # else the reference reached none of the compressions (its warning says where it stopped)
                rows.append(_row(key, ref, n, curves))
    timing = {m: timed_press(m, n) for m in FAST_MODELS}
    notes = [f"Force-controlled press, 30 mm sphere, 2 N into 3 mm, N = {n}: " + "; ".join(
        f"{m} {w * 1e3:.0f} ms wall / {c * 1e3:.0f} ms CPU" for m, (w, c, _) in timing.items()) +
        f" (ratio {timing['hyperelastic'][1] / timing['finite_layer'][1]:.2f} in CPU time).",
        "No fit in the quick run (one case at 5-10 %)." if quick else _fit_note(curves)]
    write_table(out, rows, title="Layer models against the neo-Hookean finite-element reference", notes=notes)
    for name in ("table.md", "table.csv"):
        (out / name).replace(out / name.replace("table", "layer"))
    _plots(out, curves, rows, timing)
    return rows


def _fit_note(curves: dict) -> str:
    """The law refitted here on :data:`FIT_CASES`, beside the shipped one, with the held-out cases' errors."""
    lw, errs, rms = fit_law({k: v["ref"] for k, v in curves.items()}, FIT_CASES, 128)
    held = [k for k in curves if k not in FIT_CASES]
    worst = max((np.abs(np.concatenate(errs[k])).max() for k in held), default=0.0)
    return (f"Least-squares fit of the law on {', '.join(k for k in FIT_CASES if k in curves) or 'none'} (N = 128): "
            f"round {lw.round:g}, strip {lw.strip:g}, stiffening {lw.concentration:g} (shipped: {Law()}); rms "
            f"relative error of force and peak to 60 % over the fitted cases {rms:.3f}, largest over the held-out "
            f"ones ({', '.join(held) or 'none'}) {worst:.3f}.")


def _row(key: str, ref: dict, n: int, curves: dict) -> dict:
    """One table row: each fast model's largest force and peak errors to 60 % and its time; fills ``curves``."""
    kind, h = key.rsplit("_", 1)
    lay = SoftLayer(thickness=float(h))
    row = {"indenter": kind, "h_mm": float(h) * 1e3, "fit": "fitted" if key in FIT_CASES else "held out",
           "reached": f"{ref['c'][-1]:.0%}", "reference_mesh": mesh_label(ref),
           "reference_s": round(ref.get("seconds", ref.get("s", 0)), 1)}
    curves[key] = {"ref": ref}
    for model in FAST_MODELS:
        t = time.perf_counter()
        fc = fast_curves(CASES[kind], lay, model, ref["c"], n)
        curves[key][model] = fc
        ef, ep = errors(ref, fc)
        row[f"{model}_force_err"] = round(ef, 4)
        row[f"{model}_peak_err"] = round(ep, 4)
        row[f"{model}_s"] = round(time.perf_counter() - t, 2)
    return row


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
