"""vtcore's contact solve side by side with the field's public solvers (``vtcore bench contact --peers``).

The problems (issue 20): a rigid paraboloid of radius R = 30 mm pressed at F = 10 N on Ecoflex
00-20 (E 55 kPa, nu 0.49, :data:`vtcore.contact.MATERIALS`), on an N x N grid four times the
contact diameter wide, N = 64 ... 512:

* half-space, non-periodic (Love's cells, zero padding): vtcore, tamaas 2.9 (C++ with FFTW, its
  non-periodic ``dcfft`` operator) and ContactMechanics 1.8 (``FreeFFTElasticHalfSpace``); the
  grid is 4 x the Hertz diameter and the error is against Hertz's pressure;
* a 3 mm layer bonded to a rigid base: vtcore (real-space kernel, non-periodic; padded and with
  its automatic truncation) and ContactMechanics (``PeriodicFFTElasticHalfSpace(thickness=)``, a
  periodic N x N layer); the grid is 4 x the layer's contact diameter (found by a padded vtcore
  solve at N = 128) and the solvers are compared with each other.

Times: the solve only (each solver's operator or model is built before the clock starts), the
median of ``repeat`` runs, wall and process CPU time. ``conv`` is the time vtcore spent inside
its convolutions during the same solves (the limit the FFTs set). The machine is shared: the
medians are noisy, and the table says so.

The peers never become a project dependency: with ``peers=True`` the benchmark creates a
throwaway virtual environment under its output folder (``peers-venv``, pinned :data:`PEERS`,
from the package index with pip), runs :data:`PEER_SCRIPT` there on the same problems (heights
and sizes passed as files) and reads its answers back.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

from ..errors import InputError
from . import elastic
from .materials import SoftLayer

#: the peers and the versions the numbers in docs/contact.md were measured with
PEERS = ("tamaas==2.9.0", "ContactMechanics==1.8.3")
RADIUS, FORCE, THICKNESS = 0.03, 10.0, 3e-3  # m, N, m
TOL = 1e-7  # vtcore's tolerance (relative change of the pressure per iteration)


def _layer(thickness=THICKNESS):
    return SoftLayer(thickness=thickness, material="ecoflex_00_20", base="bonded")


def hertz_radius(layer=None) -> float:
    """Hertz contact radius (m) of the paraboloid at :data:`FORCE` on the half-space."""
    es = (layer or _layer()).e_star
    return (3 * FORCE * RADIUS / (4 * es)) ** (1 / 3)


def _gap(n, size):
    dx = size / n
    x = (np.arange(n) - (n - 1) / 2) * dx
    X, Y = np.meshgrid(x, x, indexing="ij")
    return (X ** 2 + Y ** 2) / (2 * RADIUS), dx


def layer_domain() -> float:
    """Side (m) of the layer problems' grid: 4 x the contact diameter of a padded vtcore solve at N = 128
    on a grid 4 x the Hertz diameter (the bonded layer's contact is narrower than Hertz's)."""
    gap, dx = _gap(128, 8 * hertz_radius())
    lay = _layer()
    sol = elastic.solve_pk(gap, elastic.compliance_operator(gap.shape, dx, dx, lay, "finite_layer"), dx * dx,
                           force=FORCE, tol=TOL)
    a = np.sqrt((sol.pressure > 0).sum() * dx * dx / np.pi)
    return float(8 * a)


def problems(ns) -> list[dict]:
    """The problems as plain data (also what the peers' script reads)."""
    lay = _layer()
    size_h, size_l = 8 * hertz_radius(lay), layer_domain()
    out = []
    for model, size in (("halfspace", size_h), ("finite_layer", size_l)):
        for n in ns:
            out.append({"model": model, "n": int(n), "size": size, "radius": RADIUS, "force": FORCE,
                        "e_star": lay.e_star, "poisson": lay.poisson, "young": lay.young_modulus,
                        "thickness": THICKNESS})
    return out


class _Timed:
    """A convolution that adds up the wall time spent in it."""

    def __init__(self, conv):
        self.conv, self.seconds, self.truncation = conv, 0.0, conv.truncation

    def __call__(self, p):
        t0 = time.perf_counter()
        out = self.conv(p)
        self.seconds += time.perf_counter() - t0
        return out


VARIANTS = {  # name: (truncation, precision)
    "vtcore padded": (0.0, "float64"),
    "vtcore": (TOL, "float64"),
    "vtcore float32": (TOL, "float32"),
}


def run_vtcore(prob, variant, repeat=3) -> dict:
    """Solve one problem ``repeat`` times with one of :data:`VARIANTS`; medians and the pressure."""
    truncation, precision = VARIANTS[variant]
    lay = _layer(prob["thickness"])
    gap, dx = _gap(prob["n"], prob["size"])
    t0 = time.perf_counter()
    op, op32 = elastic.compliance_operators(gap.shape, dx, dx, lay, prob["model"], truncation, precision)
    build = time.perf_counter() - t0
    walls, cpus, convs, ratios = [], [], [], []
    for _ in range(repeat):
        a = _Timed(op)
        b = _Timed(op32) if op32 is not None else None
        w0, c0 = time.perf_counter(), time.process_time()
        sol = elastic.solve_pk(gap, a, dx * dx, force=FORCE, tol=TOL, conv32=b)
        walls.append(time.perf_counter() - w0)
        cpus.append(time.process_time() - c0)
        convs.append(a.seconds + (b.seconds if b is not None else 0.0))
        ratios.append(walls[-1] / max(convs[-1], 1e-12))
    return {"solver": variant, "ms": 1e3 * float(np.median(walls)), "cpu_ms": 1e3 * float(np.median(cpus)),
            "conv_ms": 1e3 * float(np.median(convs)), "total_over_conv": float(np.median(ratios)),
            "iterations": sol.iterations,
            "fft": "x".join(map(str, op.fft_shape)), "truncation": op.truncation, "build_s": build,
            "pressure": sol.pressure}


def hertz_error(prob, pressure) -> float:
    """Relative L2 error of a pressure field against Hertz's on the problem's grid."""
    gap, dx = _gap(prob["n"], prob["size"])
    a = hertz_radius()
    r2 = 2 * RADIUS * gap
    ref = 3 * FORCE / (2 * np.pi * a * a) * np.sqrt(np.clip(1 - r2 / (a * a), 0, None))
    return float(np.linalg.norm(pressure - ref) / np.linalg.norm(ref))


PEER_SCRIPT = r'''
"""Runs tamaas and ContactMechanics on vtcore's benchmark problems (written by vtcore.contact.peers)."""
import json, os, sys, tempfile, time
import numpy as np

probs = json.load(open(sys.argv[1]))
out, repeat = sys.argv[2], int(sys.argv[3])
rows, fields = [], {}


def gap(n, size, radius):
    dx = size / n
    x = (np.arange(n) - (n - 1) / 2) * dx
    X, Y = np.meshgrid(x, x, indexing="ij")
    return (X ** 2 + Y ** 2) / (2 * radius), dx


def captured(fn):
    """fn() with the process's standard output and error (tamaas' C++ iteration log) caught:
    (result, text)."""
    import ctypes

    sys.stdout.flush()
    sys.stderr.flush()
    keep = {fd: os.dup(fd) for fd in (1, 2)}
    tmp = tempfile.TemporaryFile()
    for fd in keep:
        os.dup2(tmp.fileno(), fd)
    try:
        res = fn()
    finally:
        ctypes.CDLL(None).fflush(None)  # C++ streams write through C stdio: flush before restoring
        for fd, k in keep.items():
            os.dup2(k, fd)
            os.close(k)
    tmp.seek(0)
    return res, tmp.read().decode(errors="replace")


def last_iteration(log):
    nums = [ln.split()[0] for ln in log.splitlines() if ln.split() and ln.split()[0].isdigit()]
    return int(nums[-1]) if nums else -1


def timed(fn):
    walls, cpus, res = [], [], None
    for _ in range(repeat):
        w0, c0 = time.perf_counter(), time.process_time()
        res = fn()
        walls.append(time.perf_counter() - w0)
        cpus.append(time.process_time() - c0)
    return 1e3 * float(np.median(walls)), 1e3 * float(np.median(cpus)), res


for k, pr in enumerate(probs):
    n, size = pr["n"], pr["size"]
    g, dx = gap(n, size, pr["radius"])
    if pr["model"] == "halfspace":
        import tamaas as tm

        def tamaas_solve():
            model = tm.ModelFactory.createModel(tm.model_type.basic_2d, [size, size], [n, n])
            model.E, model.nu = pr["young"], pr["poisson"]
            tm.ModelFactory.registerNonPeriodic(model, "dcfft")
            solver = tm.PolonskyKeerRey(model, -g, 1e-12)
            solver.setIntegralOperator("dcfft")
            solver.max_iter = 10000
            t0 = time.perf_counter()
            _, log = captured(lambda: solver.solve(pr["force"] / (size * size)))  # mean pressure over the domain
            return time.perf_counter() - t0, last_iteration(log), np.array(model.traction, float).reshape(n, n)

        ms_list, cpu_list, res = [], [], None
        for _ in range(repeat):  # the model's construction is not timed: only solve()
            c0 = time.process_time()
            secs, it, p = tamaas_solve()
            ms_list.append(1e3 * secs)
            cpu_list.append(1e3 * (time.process_time() - c0))
            res = (it, p)
        fields[f"{k}_tamaas"] = res[1]
        rows.append({"k": k, "solver": "tamaas", "ms": float(np.median(ms_list)), "cpu_ms": float(np.median(cpu_list)),
                     "iterations": res[0]})
    from ContactMechanics import FreeFFTElasticHalfSpace, PeriodicFFTElasticHalfSpace
    from ContactMechanics.Optimization import constrained_conjugate_gradients
    from SurfaceTopography import Topography

    if pr["model"] == "halfspace":
        sub = FreeFFTElasticHalfSpace((n, n), pr["e_star"], (size, size))
    else:
        # with a thickness, ContactMechanics takes Young's modulus and Poisson's ratio (not E*)
        sub = PeriodicFFTElasticHalfSpace((n, n), pr["young"], (size, size), thickness=pr["thickness"],
                                          poisson=pr["poisson"])
    topo = Topography(-g, (size, size))
    cell = dx * dx
    pentol = 1e-9 * float(g.max())

    def cm_solve():
        return constrained_conjugate_gradients(sub, topo, external_force=pr["force"], pentol=pentol,
                                               forcetol=1e-9 * pr["force"], maxiter=100000)

    ms, cpu, res = timed(cm_solve)
    fields[f"{k}_ContactMechanics"] = np.asarray(res.jac, float) / cell
    rows.append({"k": k, "solver": "ContactMechanics", "ms": ms, "cpu_ms": cpu, "iterations": int(res.nit),
                 "converged": bool(res.success)})
    print(f"peers: problem {k + 1}/{len(probs)} done", flush=True)

np.savez_compressed(out + ".npz", **fields)
json.dump(rows, open(out + ".json", "w"))
'''


def ensure_venv(folder: Path) -> Path:
    """The peers' throwaway venv under ``folder`` (created and filled with :data:`PEERS` once)."""
    folder = Path(folder)
    py = folder / "bin" / "python"
    stamp = folder / "peers.txt"
    if not (py.exists() and stamp.exists() and stamp.read_text() == "\n".join(PEERS)):
        subprocess.run([sys.executable, "-m", "venv", "--clear", str(folder)], check=True)
        subprocess.run([str(py), "-m", "pip", "install", "--quiet", *PEERS], check=True)
        stamp.write_text("\n".join(PEERS))
    return py


def run_peers(probs, out: Path, repeat=3, venv: Path | None = None) -> tuple[list[dict], dict]:
    """Run :data:`PEER_SCRIPT` in the peers' venv; (rows, pressure fields keyed ``"{k}_{solver}"``)."""
    out = Path(out)
    py = ensure_venv(venv or out / "peers-venv")
    (out / "peer_problems.json").write_text(json.dumps(probs))
    script = out / "peer_script.py"
    script.write_text(PEER_SCRIPT)
    env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}  # the venv's own packages only
    subprocess.run([str(py), str(script), str(out / "peer_problems.json"), str(out / "peer_results"), str(repeat)],
                   check=True, env=env)
    rows = json.loads((out / "peer_results.json").read_text())
    with np.load(out / "peer_results.npz") as z:
        fields = {k: z[k] for k in z.files}
    return rows, fields


def run(out: Path, quick: bool = False, peers: bool = False, ns=None, repeat=None, venv: Path | None = None):
    """The side-by-side table rows (list of dicts); writes ``peers.md``, ``peers.csv`` and
    ``time_vs_n.png`` into ``out``. peers : also run tamaas and ContactMechanics (creates their venv)."""
    from .._bench import save_png

    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    ns = tuple(ns or ((64,) if quick else (64, 128, 256, 512)))
    if any(int(n) < 8 or int(n) > 1024 for n in ns):
        raise InputError(f"grid sizes must lie in 8..1024, got {ns}", key="ns")
    repeat = repeat or (1 if quick else 3)
    probs = problems(ns)
    rows, fields = [], {}
    for k, pr in enumerate(probs):
        for variant in VARIANTS:
            r = run_vtcore(pr, variant, repeat)
            fields[f"{k}_{variant}"] = r.pop("pressure")
            rows.append({"k": k, **r})
    if peers:
        prow, pfields = run_peers(probs, out, repeat, venv)
        rows += prow
        fields.update(pfields)
    table = []
    for r in rows:
        pr = probs[r["k"]]
        p = fields[f"{r['k']}_{r['solver']}"]
        ref_name = "vtcore padded" if pr["model"] == "halfspace" else (
            "ContactMechanics" if f"{r['k']}_ContactMechanics" in fields else "vtcore padded")
        ref = fields[f"{r['k']}_{ref_name}"]
        row = {"model": pr["model"], "n": pr["n"], "solver": r["solver"], "ms": r["ms"], "cpu_ms": r["cpu_ms"],
               "iterations": r["iterations"], "conv_ms": r.get("conv_ms", float("nan")),
               "total_over_conv": r.get("total_over_conv", float("nan")),
               "fft": r.get("fft", ""), "truncation": r.get("truncation", float("nan")),
               "error_vs_hertz": hertz_error(pr, p) if pr["model"] == "halfspace" else float("nan"),
               "vs": ref_name, "diff_vs": float(np.linalg.norm(p - ref) / np.linalg.norm(ref))}
        table.append(row)
    _write(out, table, probs, peers, repeat)
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(2, 2, figsize=(10, 7.5), sharex=True)
    solvers = list(dict.fromkeys(r["solver"] for r in table))
    for col, (model, title) in enumerate((("halfspace", "half-space, non-periodic"),
                                          ("finite_layer", f"{THICKNESS * 1e3:g} mm bonded layer"))):
        for row, (key, what) in enumerate((("ms", "wall"), ("cpu_ms", "process CPU"))):
            ax = axes[row, col]
            for j, solver in enumerate(solvers):
                sel = [r for r in table if r["model"] == model and r["solver"] == solver]
                if sel:
                    ax.loglog([r["n"] for r in sel], [r[key] for r in sel], "o-", label=solver, color=f"C{j}")
            ax.set_xticks(list(ns), [str(n) for n in ns])
            ax.minorticks_off()
            ax.grid(True, which="both", lw=0.3)
            ax.set_title(f"{title}: {what} time", fontsize=9)
            if col == 0:
                ax.set_ylabel(f"solve, ms ({what}, median)")
            if row == 1:
                ax.set_xlabel("N (grid N x N)")
    handles, labels = axes[0, 0].get_legend_handles_labels()
    h2, l2 = axes[0, 1].get_legend_handles_labels()
    for h, lab in zip(h2, l2):
        if lab not in labels:
            handles.append(h)
            labels.append(lab)
    fig.legend(handles, labels, loc="lower center", ncol=len(labels), fontsize=8)
    fig.suptitle(f"paraboloid R {RADIUS * 1e3:g} mm, {FORCE:g} N, Ecoflex 00-20: solve time vs N "
                 "(shared 2-core machine: noisy)")
    fig.tight_layout(rect=(0, 0.05, 1, 1))
    save_png(fig, out / "time_vs_n.png")
    return table


def _write(out: Path, table, probs, peers, repeat):
    cols = ["model", "n", "solver", "ms", "cpu_ms", "iterations", "conv_ms", "total_over_conv", "fft", "truncation",
            "error_vs_hertz", "vs", "diff_vs"]

    def fmt(v):
        if isinstance(v, float):
            return "" if not np.isfinite(v) else (f"{v:.3g}" if abs(v) < 1e4 else f"{v:.0f}")
        return str(v)

    lines = ["# Contact solvers side by side", "",
             f"Paraboloid R {RADIUS * 1e3:g} mm, {FORCE:g} N, Ecoflex 00-20 (E* {probs[0]['e_star'] / 1e3:.1f} kPa); "
             f"half-space grid {probs[0]['size'] * 1e3:.1f} mm (4 x the Hertz diameter), layer ({THICKNESS * 1e3:g} mm, "
             f"bonded) grid {probs[-1]['size'] * 1e3:.1f} mm (4 x its contact diameter). Times: the solve only, median "
             f"of {repeat} runs on a shared machine (noisy); conv = vtcore's time inside its convolutions in the same "
             f"solves. error_vs_hertz: relative L2 against Hertz; diff_vs: relative L2 against the named solver."
             + ("" if peers else " Peers not run (add --peers)."), "",
             "| " + " | ".join(cols) + " |", "|" + "---|" * len(cols)]
    lines += ["| " + " | ".join(fmt(r[c]) for c in cols) + " |" for r in table]
    (out / "peers.md").write_text("\n".join(lines) + "\n", encoding="utf-8")
    import csv

    with open(out / "peers.csv", "w", newline="", encoding="utf-8") as fh:
        w = csv.DictWriter(fh, fieldnames=cols)
        w.writeheader()
        w.writerows(table)
