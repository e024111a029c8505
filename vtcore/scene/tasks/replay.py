"""Task ``replay``: a recording (a CAN log or a CySkin text recording) onto the scene's layout,
through the edge filter.

The log (``[task] log``, any python-can format) is decoded with ``codec`` into the
layout's taxel order (``vtcore.can.decode_log``); what could not be used is counted
by reason in the metrics (``rejected_<reason>``) and in ``report.md``. With
``codec = "cyskin-txt"`` the file is a CySkin text recording (line 1 the channel UIDs, then
``row time v1 ... vN``), joined to the layout by UID (``vtcore.can.read_cyskin_txt``); the
metrics count its rows, matched UIDs and rejected lines. Wire values
become counts (iCub: ``(240 - wire) * 4``; cyskin16: the 16-bit value), a per-taxel
baseline (median of the first ``baseline_rows`` received samples, as the iCub
skinManager does over its first seconds) is removed, and masked samples hold the
taxel's previous value (zero before its first) so that the filter sees a full frame;
the ``mask`` array says which samples were real. The response then goes through
``vtcore.filters.edge_filter`` on the layout's skin mesh and a per-frame relative
threshold (``edge_fraction``) gives ``edge (T, N)``.

Arrays: ``positions``, ``normals``, ``taxel_ids``, ``timestamps (T,)`` s, ``wire (T, N)``
(the decoded wire values), ``mask (T, N)``, ``frames (T, N)`` counts, ``response (T, N)``
counts above baseline, ``edge_response (T, N)``, ``edge (T, N)`` bool.
"""

from __future__ import annotations

import time

import numpy as np

from ..registry import TaskSpec, register_task
from ..runner import TaskResult
from ..schema import Field, Section
from ..sections.layout import build_layout

PARAMS = Section({
    "log": Field("path", doc="recording to replay: a CAN log (.log candump, .asc, .blf, .trc, .csv) or, with "
                 "codec cyskin-txt, a CySkin text recording"),
    "codec": Field("str", default="cyskin16", choices=("icub", "cyskin16", "cyskin-txt"),
                   doc="how the frames are coded (cyskin-txt: a CySkin text recording, counts as recorded)"),
    "period": Field("float", default=0.0, ge=0, unit="s", doc="sampling period; 0: estimated from the log"),
    "window": Field("int", default=8, ge=1, doc="periods a row waits for late frames"),
    "boards": Field("list", default=[], item=Field("int", ge=0, le=15),
                    doc="iCub: board address of each 192-row block of the layout (empty: as the layout says)"),
    "baseline_rows": Field("int", default=5, ge=1, doc="first rows whose median is each taxel's baseline"),
    "edge_fraction": Field("float", default=0.3, gt=0, le=1,
                           doc="edge threshold as a fraction of each frame's strongest filter response"),
    "min_response": Field("float", default=0.0, ge=0, doc="counts: a frame whose strongest response is below "
                          "this (noise, no contact) has no edges"),
    "frame_plot": Field("int", default=-1, doc="row shown in the taxel maps (-1: the row of peak response)"),
})


def run(scene, ctx) -> TaskResult:
    from ...can import decode_log, icub_wire_to_counts
    from ...can.timeline import baseline_first, hold
    from ...layout import skin_mesh

    p = scene["task"]
    layout = build_layout(scene)
    if p["codec"] == "cyskin-txt":
        timestamps, wire, mask, text, metrics = _read_cyskin_txt(p, layout)
        summary = dict(metrics)
    else:
        res = decode_log(p["log"], p["codec"], layout=layout, period=p["period"] or None, window=p["window"],
                         boards=p["boards"] or None)
        timestamps, wire, mask = res.timestamps, res.frames, res.mask
        text, metrics, summary = res.summary.text(), dict(res.summary.metrics()), res.summary.as_dict()
    counts = icub_wire_to_counts(wire) if p["codec"] == "icub" else wire.astype(np.float64)
    counts = np.where(mask, counts, 0.0)
    base = baseline_first(counts, mask, p["baseline_rows"])
    response = np.clip(hold(counts, mask) - base, 0.0, None)
    response = np.where(hold(mask.astype(float), mask) > 0, response, 0.0)

    edge_resp = edge = None
    sections = ["## Replay summary\n\n```\n" + text + "\n```"]
    try:
        from ...filters import edge_filter, relative_threshold
    except ImportError:  # the filters package is optional for this task
        edge_filter = None
    if edge_filter is not None and len(response):
        mesh = skin_mesh(layout)
        t0 = time.perf_counter()
        edge_resp = edge_filter(mesh, response)
        metrics["edge_filter_ms_per_frame"] = (time.perf_counter() - t0) * 1e3 / len(response)
        edge = edge_resp > relative_threshold(edge_resp, p["edge_fraction"])[:, None]
        edge &= (response.max(axis=1) >= p["min_response"])[:, None]
        metrics["edge_taxels_max"] = int(edge.sum(axis=1).max())
    elif edge_filter is None:
        sections.append("vtcore.filters.edge_filter is not available: no edge output.")
    n_cells = max(mask.size, 1)
    metrics.update({
        "taxels": len(layout), "rows_decoded": int(len(timestamps)),
        "duration_s": float(timestamps[-1] - timestamps[0]) if len(timestamps) else 0.0,
        "masked_fraction": float((~mask).sum() / n_cells),
        "response_max": float(response.max()) if response.size else 0.0,
    })
    arrays = {"positions": layout.positions, "normals": layout.normals, "taxel_ids": layout.taxel_ids,
              "timestamps": timestamps, "wire": wire, "mask": mask, "frames": counts, "response": response}
    if edge is not None:
        arrays.update({"edge_response": edge_resp, "edge": edge})
    figures = {}
    if len(response) and layout.flat is not None:
        from ...plots import taxel_map

        row = int(p["frame_plot"]) if p["frame_plot"] >= 0 else int(np.argmax(response.sum(axis=1)))
        row = min(row, len(response) - 1)
        figures["response"] = taxel_map(layout.flat, response[row],
                                        title=f"{scene.name}: response, row {row}", label="counts")
        if edge is not None:
            figures["edge"] = taxel_map(layout.flat, edge_resp[row] * edge[row],
                                        title=f"{scene.name}: edge response above threshold, row {row}",
                                        label="Eq. 6")
        figures["timeline"] = _timeline(timestamps, response, mask, edge, scene.name)
    return TaskResult(metrics=metrics, arrays=arrays, figures=figures, sections=sections,
                      extra={"replay_summary": summary})


def _read_cyskin_txt(p, layout):
    """(timestamps (T,), counts (T, N), mask (T, N), summary text, metrics) of a CySkin text recording
    in the layout's taxel order."""
    from ...can import read_cyskin_txt
    from ...can.recording import report_text
    from ...errors import InputError

    if p["boards"]:
        raise InputError("board addresses apply to the icub codec only", key="task.boards")
    rec = read_cyskin_txt(p["log"], layout=layout)
    r = rec.report
    if not r["matched_uids"]:
        raise InputError(f"none of the {r['recorded_uids']} recorded UIDs is a taxel of the layout (another skin?)",
                         file=p["log"], key="task.log")
    metrics = {"rows": int(r["rows"]), "recorded_uids": int(r["recorded_uids"]), "matched_uids": int(r["matched_uids"]),
               "unmatched_uids": len(r["unmatched_uids"]), "unrecorded_taxels": len(r.get("unrecorded_taxels", [])),
               "rejected_lines": len(r["rejected_lines"]), "masked_samples": int((~rec.mask).sum())}
    return rec.timestamps, rec.frames, rec.mask, report_text(r), metrics


def _timeline(ts, response, mask, edge, name):
    from ...plots import pyplot

    plt = pyplot()
    fig, ax = plt.subplots(3, 1, figsize=(6.5, 5.5), sharex=True)
    t = ts - ts[0]
    ax[0].plot(t, response.max(axis=1), lw=1)
    ax[0].set_ylabel("max response\n(counts)")
    ax[1].plot(t, (~mask).sum(axis=1), lw=1, color="tab:red")
    ax[1].set_ylabel("masked\nsamples")
    if edge is not None:
        ax[2].plot(t, edge.sum(axis=1), lw=1, color="tab:green")
    ax[2].set_ylabel("edge taxels")
    ax[2].set_xlabel("time (s)")
    ax[0].set_title(f"{name}: replay timeline")
    fig.tight_layout()
    return fig


register_task(TaskSpec("replay", run, PARAMS, sections=("layout",),
                       doc="replay a CAN log or a CySkin text recording onto the layout, through the edge filter"))
