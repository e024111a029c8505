"""``sweep.csv`` and ``report.md`` of a sweep, with one plot per metric.

``sweep.csv``: one row per point: ``point``, the grid keys, ``seed``,
``status``, ``seconds``, every metric (the union over points, in the order
first seen), then ``error_file``, ``error_key``, ``error_message``, ``worker``.

``report.md``: counts by status, the failed points with their errors, the
task's own summary where its adapter provides one (``TaskSpec.sweep_summary``),
a table of each metric's mean and spread over seeds, and ``plots/<metric>.png``:
the metric against the first grid key (mean over seeds, a band from the
smallest to the largest seed's value, error bars of one standard deviation),
one line per combination of the other grid keys.
"""

from __future__ import annotations

import csv
import io
import math
import re
from collections import defaultdict
from pathlib import Path

import numpy as np

from .._io import atomic_write
from .spec import Plan, shown

ERROR_COLUMNS = ("error_file", "error_key", "error_message", "worker")


def metric_names(rows: list[dict]) -> list[str]:
    names: dict[str, None] = {}
    for r in rows:
        for k in r.get("metrics") or {}:
            names.setdefault(k, None)
    return list(names)


def _cell(v) -> str:
    if v is None:
        return ""
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, float):
        return repr(v)
    return str(v)


def write_csv(plan: Plan, rows: list[dict], out: Path) -> None:
    """Write ``out/sweep.csv`` atomically (one row per point of ``rows``)."""
    metrics = metric_names(rows)
    cols = ["point", *plan.keys, "seed", "status", "seconds", *metrics, *ERROR_COLUMNS]
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(cols)
    for r in rows:
        err = r.get("error") or {}
        w.writerow([r["name"], *(shown(r["grid"][k]) for k in plan.keys), _cell(r["seed"]), r["status"],
                    _cell(None if r.get("seconds") is None else round(float(r["seconds"]), 4)),
                    *(_cell((r.get("metrics") or {}).get(m)) for m in metrics),
                    _cell(err.get("file")), _cell(err.get("key")), _cell(err.get("message")),
                    _cell(r.get("worker"))])
    with atomic_write(Path(out) / "sweep.csv", "w", encoding="utf-8", newline="") as fh:
        fh.write(buf.getvalue())


def _key(value):
    """A grid value as a dict key: lists (``--grid 'task.propagations=["cluster"],["smooth"]'``) by
    their TOML text, everything else as it is (numbers stay numbers for the plots' x axis)."""
    return shown(value) if isinstance(value, (list, dict)) else value


def _number(v) -> float:
    """A metric as a float (bools as 0/1; None, text and non-finite values as NaN)."""
    if isinstance(v, bool):
        return float(v)
    if isinstance(v, (int, float)) and math.isfinite(v):
        return float(v)
    return math.nan


def aggregate(plan: Plan, rows: list[dict], metric: str) -> dict:
    """Per grid combination (seeds pooled) the values of ``metric`` over the ok points.

    Returns ``{combo: (K,) float array}`` keyed by the tuple of grid values (in key order).
    """
    out: dict[tuple, list[float]] = defaultdict(list)
    for r in rows:
        if r["status"] != "ok":
            continue
        v = _number((r.get("metrics") or {}).get(metric))
        combo = tuple(_key(r["grid"][k]) for k in plan.keys)
        out[combo].append(v)
    return {k: np.asarray(v, dtype=np.float64) for k, v in out.items()}


def _stats(vals: np.ndarray) -> tuple[float, float, float, float, int]:
    """(mean, std, min, max, n) over the finite values; NaNs when there are none."""
    v = vals[np.isfinite(vals)]
    if v.size == 0:
        return math.nan, math.nan, math.nan, math.nan, 0
    return float(v.mean()), float(v.std()), float(v.min()), float(v.max()), int(v.size)


def _fmt(x: float) -> str:
    return "-" if not math.isfinite(x) else f"{x:.4g}"


def _x_positions(values: list) -> tuple[np.ndarray, list[str] | None]:
    """x coordinates of the first key's values: the numbers themselves, else their order (with labels)."""
    if all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in values):
        return np.asarray(values, dtype=np.float64), None
    return np.arange(len(values), dtype=np.float64), [shown(v) for v in values]


def plot_metric(plan: Plan, rows: list[dict], metric: str, path: Path) -> None:
    """``path``: ``metric`` against the first grid key (or the seed, for a seeds-only sweep)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from .._bench import save_png

    fig, ax = plt.subplots(figsize=(6.0, 3.6))
    if plan.keys:
        first, rest = plan.keys[0], plan.keys[1:]
        agg = aggregate(plan, rows, metric)
        firsts = list(dict.fromkeys(_key(p.grid[first]) for p in plan.points))
        xs, labels = _x_positions(firsts)
        groups = list(dict.fromkeys(combo[1:] for combo in agg))
        for g in groups:
            st = np.array([_stats(agg.get((v, *g), np.array([]))) for v in firsts])
            label = ", ".join(f"{k}={shown(v)}" for k, v in zip(rest, g)) or None
            line = ax.errorbar(xs, st[:, 0], yerr=st[:, 1], marker="o", ms=4, capsize=3, label=label)
            if plan.seeds and len(plan.seeds) > 1:
                ax.fill_between(xs, st[:, 2], st[:, 3], alpha=0.15, color=line[0].get_color(), lw=0)
        ax.set_xlabel(first)
        if labels:
            ax.set_xticks(xs, labels, rotation=30, ha="right")
        if any(groups) and len(groups) > 1:
            ax.legend(fontsize=7)
    else:
        ok = [r for r in rows if r["status"] == "ok"]
        seeds = np.array([r["seed"] if r["seed"] is not None else 0 for r in ok], dtype=float)
        vals = np.array([_number(r["metrics"].get(metric)) for r in ok])
        ax.plot(seeds, vals, "o")
        mean, std, *_ = _stats(vals)
        if math.isfinite(mean):
            ax.axhline(mean, color="k", lw=1, label=f"mean {mean:.4g}")
            ax.axhspan(mean - std, mean + std, color="k", alpha=0.1, lw=0, label=f"± std {std:.3g}")
            ax.legend(fontsize=7)
        ax.set_xlabel("seed")
    spread = (f"mean over {len(plan.seeds)} seeds; bars: ± 1 std, band: min-max" if plan.seeds and len(plan.seeds) > 1
              else "one run per point")
    ax.set_title(f"{metric}\n{spread}", fontsize=9)
    ax.set_ylabel(metric)
    ax.grid(alpha=0.3)
    save_png(fig, path)


def _summary_table(plan: Plan, rows: list[dict], metrics: list[str]) -> list[str]:
    """Markdown: one row per (metric, other-key combination), one column per value of the first key."""
    if not plan.keys:
        lines = ["| metric | mean | std | min | max | runs |", "|---|---|---|---|---|---|"]
        for m in metrics:
            vals = np.array([_number(r["metrics"].get(m)) for r in rows if r["status"] == "ok"])
            mean, std, lo, hi, n = _stats(vals)
            lines.append(f"| `{m}` | {_fmt(mean)} | {_fmt(std)} | {_fmt(lo)} | {_fmt(hi)} | {n} |")
        return lines
    first, rest = plan.keys[0], plan.keys[1:]
    firsts = list(dict.fromkeys(_key(p.grid[first]) for p in plan.points))
    head = "| metric | " + (" | ".join(rest) + " | " if rest else "") + " | ".join(
        f"{first}={shown(v)}" for v in firsts) + " |"
    lines = [head, "|---" * (1 + len(rest) + len(firsts)) + "|"]
    multi = bool(plan.seeds) and len(plan.seeds) > 1
    for m in metrics:
        agg = aggregate(plan, rows, m)
        for g in dict.fromkeys(combo[1:] for combo in agg):
            cells = []
            for v in firsts:
                mean, std, *_ = _stats(agg.get((v, *g), np.array([])))
                cells.append(f"{_fmt(mean)} ± {_fmt(std)}" if multi and math.isfinite(mean) else _fmt(mean))
            lines.append(f"| `{m}` | " + "".join(f"{shown(x)} | " for x in g) + " | ".join(cells) + " |")
    return lines


def write(plan: Plan, rows: list[dict], out: Path, *, command: str = "", seconds: float | None = None) -> None:
    """Write ``sweep.csv``, ``plots/*.png`` and ``report.md`` into ``out`` (each atomically)."""
    from ..scene import load_scene
    from ..scene.registry import TASKS

    out = Path(out)
    write_csv(plan, rows, out)
    scene = load_scene(plan.scene, plan.sets)
    counts: dict[str, int] = defaultdict(int)
    for r in rows:
        counts[r["status"]] += 1
    ok = [r for r in rows if r["status"] == "ok"]
    lines = [f"# Sweep: {scene.name}", ""]
    if scene["scene"]["description"]:
        lines += [scene["scene"]["description"], ""]
    lines += [f"Scene `{plan.scene}`, task `{scene.task}`; grid: "
              + (", ".join(f"`{k}` = {', '.join(shown(v) for v in dict.fromkeys(_key(p.grid[k]) for p in plan.points))}"
                           for k in plan.keys) or "none")
              + f"; seeds: {', '.join(map(str, plan.seeds)) if plan.seeds else f'the scene’s own ({scene.seed})'}"
              + (f"; `--set` {' '.join(plan.sets)}" if plan.sets else "") + ".", ""]
    if command:
        lines += ["```", command, "```", ""]
    lines += [f"{len(rows)} points: " + ", ".join(f"{n} {s}" for s, n in sorted(counts.items()))
              + (f"; {seconds:.1f} s wall" if seconds is not None else "")
              + ". Every point's own files are in its folder (`<point>/result.json`, `arrays.npz`, `report.md`); "
                "one row per point in [`sweep.csv`](sweep.csv).", ""]
    bad = [r for r in rows if r["status"] != "ok"]
    if bad:
        lines += ["## Points that did not finish", "", "| point | status | file | key | message |", "|---|---|---|---|---|"]
        for r in bad:
            e = r.get("error") or {}
            msg = str(e.get("message") or "").replace("\n", " ").replace("|", "\\|")
            lines.append(f"| `{r['name']}` | {r['status']} | {e.get('file') or '-'} | {e.get('key') or '-'} | {msg} |")
        lines.append("")
    spec = TASKS.get(scene.task)
    if ok and spec is not None and spec.sweep_summary is not None:
        lines += [spec.sweep_summary(scene, ok, plan.keys).rstrip(), ""]
    metrics = metric_names(ok)
    varying, constant = [], []
    for m in metrics:
        vals = [_number(r["metrics"].get(m)) for r in ok]
        finite = [v for v in vals if math.isfinite(v)]
        (constant if len(set(finite)) <= 1 and len(finite) == len(vals) else varying).append(m)
    if metrics:
        lines += ["## Metrics", "",
                  ("Mean ± standard deviation over the seeds of each point." if plan.seeds and len(plan.seeds) > 1
                   else "One run per point."), ""]
        lines += _summary_table(plan, ok, metrics) + [""]
    if varying:
        lines += ["## Plots", ""]
        plots = out / "plots"
        for m in varying:
            stem = re.sub(r"[^A-Za-z0-9_.-]+", "-", m)
            plot_metric(plan, ok, m, plots / f"{stem}.png")
            lines.append(f"![{m}](plots/{stem}.png)")
        lines.append("")
    if constant:
        lines += ["The same at every point (not plotted): " + ", ".join(
            f"`{m}` = {_cell(ok[0]['metrics'].get(m)) or 'undefined'}" for m in constant) + ".", ""]
    with atomic_write(out / "report.md", "w", encoding="utf-8") as fh:
        fh.write("\n".join(lines))
