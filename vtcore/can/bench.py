"""Benchmark: vectorised decoding vs the per-message python-can + cantools path, side by side.

``vtcore bench can --out DIR [--quick]``. One synthetic skin log per codec (iCub: 16 boards x 16
triangles = 512 frames per period; cyskin16: 60 modules x 3 frames = 180 per period) held in
memory, decoded by:

- ``vectorised``: column arrays of the frames (``FrameBatch``) -> ``(T, N)`` grid with mask;
- ``vectorised_from_messages``: the same, starting from a list of ``can.Message`` (adds the
  conversion to columns, the fair comparison with the reference);
- ``reference_cantools``: one ``can.Message`` at a time through cantools ``decode_message`` and a
  dict lookup per taxel (a subset of the frames: it is slow), rows by ``round((t - t0) / period)``;
- ``file_candump_python_can``: a candump ``.log`` on disk read through python-can in chunks and
  decoded (end to end, parsing dominates).

Accuracy: samples that differ from the reference decode of the same frames (must be 0).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from .._bench import best_time, save_png, write_table
from .codecs import Cyskin16Codec, IcubCodec
from .decode import decode_batches
from .encode import encode
from .frames import FrameBatch

#: What this benchmark measures its error against (the closing note of ``vtcore bench`` lists it).
REFERENCE = "cantools' own decode of the same frames, one message at a time (an independent decoder)"


def _log_in_memory(codec, periods: int, seed: int = 0):
    rng = np.random.default_rng(seed)
    if codec.name == "icub":
        ids = np.arange(16 * 192)                                  # 16 boards, all slots
    else:
        ids = ((np.arange(60)[:, None] + 1) << 4 | np.arange(1, 11)[None, :]).reshape(-1)
    wire = rng.integers(0, codec.wire_max + 1, size=(periods, len(ids)))
    batch = encode(1700000000.0 + np.arange(periods) * 0.05, wire, ids, codec)
    return batch, ids, wire


def _reference(msgs, codec, ids, period):
    """Per-message python-can + cantools decode into a (T, N) grid."""
    col = {int(t): j for j, t in enumerate(ids)}
    t0 = msgs[0].timestamp
    rows = int(round((msgs[-1].timestamp - t0) / period)) + 1
    out = np.zeros((rows, len(ids)), np.int64)
    mask = np.zeros((rows, len(ids)), bool)
    for m in msgs:
        key, vals, _err = codec.reference_decode(m)
        if key < 0:
            continue
        r = int(round((m.timestamp - t0) / period))
        for tid, v in vals.items():
            j = col.get(tid)
            if j is not None:
                out[r, j] = v
                mask[r, j] = True
    return out, mask


def run(out: Path, quick: bool = False) -> list[dict]:
    from .logs import iter_batches, write_log

    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    rows = []
    for codec in (IcubCodec(), Cyskin16Codec()):
        per = 512 if codec.name == "icub" else 180
        periods = (20_000 if quick else 1_000_000) // per
        batch, ids, wire = _log_in_memory(codec, periods)
        n = len(batch)
        sec, res = best_time(lambda: decode_batches(batch, codec, taxel_ids=ids, period=0.05), 1 if quick else 3,
                             clock="cpu")
        exact = int((res.frames != wire).sum() + (~res.mask).sum())
        rows.append({"codec": codec.name, "method": "vectorised", "frames": n, "seconds": sec,
                     "frames_per_s": n / sec, "mismatched_samples": exact})
        n_ref = min(n, 5_000 if quick else 50_000)
        ref_periods = n_ref // per
        n_ref = ref_periods * per
        msgs = list(batch.take(slice(0, n_ref)).to_messages())
        sec_m, res_m = best_time(lambda: decode_batches(FrameBatch.from_messages(msgs), codec, taxel_ids=ids,
                                                        period=0.05), 1 if quick else 3, clock="cpu")
        sec_r, (ref, ref_mask) = best_time(lambda: _reference(msgs, codec, ids, 0.05), 1, clock="cpu")
        mism = int((res_m.frames != ref).sum() + (res_m.mask != ref_mask).sum())
        mism_truth = int((ref != wire[:ref_periods]).sum())
        rows.append({"codec": codec.name, "method": "vectorised_from_messages", "frames": n_ref, "seconds": sec_m,
                     "frames_per_s": n_ref / sec_m, "mismatched_samples": mism})
        rows.append({"codec": codec.name, "method": "reference_cantools", "frames": n_ref, "seconds": sec_r,
                     "frames_per_s": n_ref / sec_r, "mismatched_samples": mism_truth})
        # end to end from a candump file (python-can parsing)
        n_file = min(n, 10_000 if quick else 100_000)
        path = out / f"_bench_{codec.name}.log"
        write_log(path, batch.take(slice(0, n_file)))
        sec_f, res_f = best_time(lambda: decode_batches(iter_batches(path), codec, taxel_ids=ids, period=0.05), 1,
                                 clock="cpu")
        path.unlink()
        k = len(res_f.timestamps)
        mism_f = int((res_f.frames[res_f.mask] != wire[:k][res_f.mask]).sum())
        rows.append({"codec": codec.name, "method": "file_candump_python_can", "frames": n_file, "seconds": sec_f,
                     "frames_per_s": n_file / sec_f, "mismatched_samples": mism_f})
    for r in rows:
        ref = next(x for x in rows if x["codec"] == r["codec"] and x["method"] == "reference_cantools")
        r["speedup_vs_reference"] = r["frames_per_s"] / ref["frames_per_s"]
    _write(out, rows, quick)
    return rows


def _write(out: Path, rows: list[dict], quick: bool) -> None:
    write_table(out, rows, title="CAN decoding: vectorised vs per-message python-can + cantools", notes=[
        f"{'Quick run (small sizes).' if quick else 'Full run.'} Same frames, same machine, one run; CPU seconds. "
        "`mismatched_samples` counts samples that differ from the reference decode "
        "(for the reference row: from the values that were encoded)."],
        columns=["codec", "method", "frames", "seconds", "frames_per_s", "speedup_vs_reference",
                 "mismatched_samples"])
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6.5, 4))
    marks = {"icub": "o", "cyskin16": "s"}
    for r in rows:
        us = 1e6 / r["frames_per_s"]
        ax.scatter(us, r["mismatched_samples"], marker=marks[r["codec"]], s=50)
        ax.annotate(f"{r['codec']} {r['method']}", (us, r["mismatched_samples"]), fontsize=7,
                    xytext=(4, 4 + 8 * (r["codec"] == "cyskin16")), textcoords="offset points")
    ax.set_xscale("log")
    ax.set_xlabel("time per frame (µs, log)")
    ax.set_ylabel("mismatched samples vs reference")
    ax.set_title("CAN decode: accuracy vs time")
    ax.axvline(1.0, color="0.6", ls="--", lw=0.8)
    ax.text(1.0, ax.get_ylim()[1] * 0.9 if ax.get_ylim()[1] > 0 else 0.5, " 1 M frames/s", fontsize=7, color="0.4")
    save_png(fig, out / "accuracy_vs_time.png")
