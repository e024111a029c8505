"""``vtcore can decode|encode|replay`` and ``vtcore recording import``.

    vtcore can decode LOG --codec icub|cyskin16 [--layout LAYOUT [--boards B,...]] --out FRAMES.npz
    vtcore can encode FRAMES.npz --codec icub|cyskin16 --out LOG
    vtcore can replay LOG [--channel NAME] [--speed 1.0]
    vtcore recording import FILE --format cyskin-txt --layout LAYOUT --out FRAMES.npz
"""

from __future__ import annotations

import math

#: seconds: --period (a skin samples at 1 Hz .. 1 MHz; past this range the row arithmetic overflows)
PERIOD_S = (1e-6, 3600.0)
#: --window periods (the decoder compares row numbers in int64)
WINDOW_PERIODS = (1, 10**9)
#: --speed: 0 (or inf) sends at once; a positive factor below this would take hours per second of log
MIN_SPEED = 1e-3


def _load_layout(path):
    from ..errors import InputError
    from .. import layout as lay

    if not hasattr(lay, "load"):
        raise InputError("vtcore.layout.load is not available in this version; cannot read a layout file",
                         file=path)
    return lay.load(path)


def _boards(text: str) -> list[int]:
    import argparse

    try:
        out = [int(x, 0) for x in text.replace(" ", "").split(",") if x]
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected board addresses like 3 or 14,13, got {text!r}") from None
    if not out:
        raise argparse.ArgumentTypeError("no board address given")
    if not all(0 <= b <= 15 for b in out):  # checked here: 2**70 overflowed the decoder's int64 arrays
        raise argparse.ArgumentTypeError(f"board addresses are 4 bits (0..15), got {text!r}")
    return out


def cmd_decode(args) -> int:
    from ..can import decode_log, save_frames_npz
    from ..inputs import check_output_file

    from ..inputs import to_float, to_int

    if args.period is not None:
        to_float(args.period, lo=PERIOD_S[0], hi=PERIOD_S[1], key="--period")
    to_int(args.window, lo=WINDOW_PERIODS[0], hi=WINDOW_PERIODS[1], key="--window")
    check_output_file(args.out)
    if args.summary:
        check_output_file(args.summary, key="--summary")
    layout = _load_layout(args.layout) if args.layout else None
    res = decode_log(args.log, args.codec, layout=layout, period=args.period, window=args.window,
                     boards=args.boards)
    save_frames_npz(args.out, res)
    print(f"{args.log}: {res.summary.text()}")
    print(f"-> {args.out}: frames {res.frames.shape} ({args.codec} wire values), mask, taxel_ids")
    if args.summary:
        from .._io import write_json

        summary = res.summary.as_dict()
        if not math.isfinite(summary["period_s"]):
            summary["period_s"] = None  # no frames: the period is undefined (JSON has no NaN)
        write_json(args.summary, summary)
    return 0


def cmd_encode(args) -> int:
    from ..can import encode_to_log
    from ..inputs import check_output_file

    check_output_file(args.out)
    n = encode_to_log(args.frames, args.codec, args.out, channel=args.can_channel)
    print(f"{args.frames} -> {args.out}: {n} {args.codec} frames")
    return 0


def cmd_replay(args) -> int:
    from ..can import Summary, replay

    from ..errors import InputError

    if not (args.speed == 0 or args.speed >= MIN_SPEED):  # nan fails both
        raise InputError(f"must be 0 (no waiting) or at least {MIN_SPEED:g} (1 = real time, inf = no waiting), "
                         f"got {args.speed:g}", key="--speed")
    summary = Summary()
    stats = replay(args.log, channel=args.channel, speed=args.speed, interface=args.interface, summary=summary)
    print(f"{args.log}: sent {stats['frames_sent']} frames spanning {stats['log_seconds']:.3f} s of log "
          f"in {stats['seconds']:.3f} s (max lag {stats['lag_max_s'] * 1e3:.2f} ms)")
    if summary.rejected_total or summary.notes:
        print(summary.text())
    return 0


def cmd_record_import(args) -> int:
    from .._io import save_npz
    from ..can.recording import read_cyskin_txt, report_text
    import numpy as np

    from ..inputs import check_output_file

    check_output_file(args.out)
    if args.report:
        check_output_file(args.report, key="--report")
    layout = _load_layout(args.layout)
    rec = read_cyskin_txt(args.file, layout=layout)
    arrays = rec.arrays()
    arrays.update({"positions": layout.positions, "normals": layout.normals, "codec": np.array("cyskin16")})
    save_npz(args.out, arrays)
    print(f"{args.file}: {report_text(rec.report)}")
    print(f"-> {args.out}: frames {rec.frames.shape} in layout order")
    if args.report:
        from .._io import write_json

        write_json(args.report, rec.report)
    return 0


def register(sub) -> None:
    p = sub.add_parser("can", help="decode, encode and replay skin CAN traffic (python-can logs)")
    csub = p.add_subparsers(dest="can_command", metavar="SUBCOMMAND")
    d = csub.add_parser("decode", help="log (.log .asc .blf .trc .csv) -> FRAMES.npz")
    d.add_argument("log", metavar="LOG")
    d.add_argument("--codec", required=True, choices=("icub", "cyskin16"))
    d.add_argument("--layout", metavar="LAYOUT", help="layout file: columns follow its taxel order")
    d.add_argument("--boards", type=_boards, default=None, metavar="B[,B...]",
                   help="iCub: board address of each 192-row block of the layout's positions file, in file "
                        "order (a file for board 3: --boards 3; boards 14 then 13: --boards 14,13)")
    d.add_argument("--out", required=True, metavar="FRAMES.npz")
    d.add_argument("--period", type=float, default=None, help="sampling period in s (default: from the log)")
    d.add_argument("--window", type=int, default=8, help="periods a row waits for late frames")
    d.add_argument("--summary", metavar="JSON", help="also write the replay summary as JSON")
    d.set_defaults(func=cmd_decode)
    e = csub.add_parser("encode", help="FRAMES.npz -> log of the frames a skin would send")
    e.add_argument("frames", metavar="FRAMES.npz")
    e.add_argument("--codec", required=True, choices=("icub", "cyskin16"))
    e.add_argument("--out", required=True, metavar="LOG")
    e.add_argument("--can-channel", default="vcan0", help="channel name written in candump .log files")
    e.set_defaults(func=cmd_encode)
    r = csub.add_parser("replay", help="send a log onto a CAN bus in real or scaled time")
    r.add_argument("log", metavar="LOG")
    r.add_argument("--channel", default="vtcore", metavar="NAME",
                   help="bus channel (vcan0/can0: SocketCAN when the kernel has it; else python-can virtual)")
    r.add_argument("--speed", type=float, default=1.0, help="time scale (2 = twice as fast, 0 = no waiting)")
    r.add_argument("--interface", default=None, help="python-can interface (virtual, socketcan, udp_multicast)")
    r.set_defaults(func=cmd_replay)
    p.set_defaults(func=lambda a: (p.print_help(), 2)[1])

    q = sub.add_parser("recording", help="import real skin recordings onto a layout")
    qsub = q.add_subparsers(dest="recording_command", metavar="SUBCOMMAND")
    i = qsub.add_parser("import", help="CySkin text recording -> FRAMES.npz in layout order (joined by UID)")
    i.add_argument("file", metavar="FILE")
    i.add_argument("--format", required=True, choices=("cyskin-txt",))
    i.add_argument("--layout", required=True, metavar="LAYOUT")
    i.add_argument("--out", required=True, metavar="FRAMES.npz")
    i.add_argument("--report", metavar="JSON", help="also write the join report as JSON")
    i.set_defaults(func=cmd_record_import)
    q.set_defaults(func=lambda a: (q.print_help(), 2)[1])
