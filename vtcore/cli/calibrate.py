"""``vtcore calibrate`` and ``vtcore validate``: the sensor model against real recordings.

    vtcore calibrate RECORDING... --layout LAYOUT --out PROFILE.toml [--name NAME] [--k 5]
    vtcore validate RECORDING... --layout LAYOUT --scene SCENE.toml --out DIR
"""

from __future__ import annotations

import sys
from pathlib import Path


def _warn(text: str) -> None:
    print(f"vtcore: warning: {text}", file=sys.stderr)


def cmd_calibrate(args) -> int:
    from ..calibrate.calibrate import calibrate
    from ..contact.profile import save_profile
    from ..inputs import check_output_file, to_float
    from ..layout import load

    check_output_file(args.out)
    k = to_float(args.k, lo=0.1, hi=100.0, key="--k")
    layout = load(args.layout)
    result = calibrate(args.recordings, layout, name=args.name or Path(args.out).stem, k=k,
                       response=not args.noise_only, warn=_warn, holdout=args.holdout)
    prof = save_profile(args.out, result.doc, result.comments)
    for line in result.summary_lines():
        print(line)
    print(f"-> {args.out} (profile {prof.name!r}: noise sigma {prof.noise_sigma:.1f} counts, k {prof.detection_k:g})")
    return 0


def _recordings_and_layout(p, out: str) -> None:
    """The arguments calibrate and validate share: the recordings, the layout, the output."""
    p.add_argument("recordings", nargs="+", metavar="RECORDING", help="CySkin text recordings (.txt)")
    p.add_argument("--layout", required=True, metavar="LAYOUT", help="the recorded skin's layout (joined by taxel UID)")
    p.add_argument("--out", required=True, metavar=out)


def register(sub) -> None:
    c = sub.add_parser("calibrate", help="fit a sensor profile (noise, drift, response) to real recordings")
    _recordings_and_layout(c, "PROFILE.toml")
    c.add_argument("--name", default=None, help="profile name (default: the output file's stem)")
    c.add_argument("--k", default=5.0, type=float, help="detection threshold in noise deviations (default 5)")
    c.add_argument("--noise-only", action="store_true", help="fit the noise and detection only, not the response")
    c.add_argument("--holdout", nargs="*", default=[], metavar="RECORDING",
                   help="recordings to leave out of the calibration (named in the profile, so that vtcore validate "
                        "reports them apart); they may also be listed among RECORDING")
    c.set_defaults(func=cmd_calibrate)
    register_validate(sub)


def cmd_validate(args) -> int:
    import json

    from ..scene import run_scene

    overrides = [f"layout.file={json.dumps(str(Path(args.layout).resolve()))}",
                 f"task.recordings={json.dumps([str(Path(r).resolve()) for r in args.recordings])}"]
    if args.holdout is not None:
        overrides.append(f"task.held_out={json.dumps([str(Path(h).resolve()) for h in args.holdout])}")
    result = run_scene(args.scene, args.out, overrides + list(args.set or []))
    m = result["metrics"]
    print(f"{m['frames']} contact frames of {m['recordings']} recordings simulated "
          f"({m['frames_held_out']} from recordings held out of the calibration)")
    for g in ("all", "heldout", "peak_fitted", "peak_heldout"):
        if f"{g}_real_peak_median" not in m:
            continue
        parts = []
        for name in ("active", "ring1", "ring2", "major_mm", "minor_mm"):
            ok = "in" if m[f"{g}_sim_{name}_within_real_iqr"] else "OUT"
            parts.append(f"{name} {m[f'{g}_sim_{name}_median']:.3g} vs {m[f'{g}_real_{name}_median']:.3g} "
                         f"[{m[f'{g}_real_{name}_q25']:.3g}-{m[f'{g}_real_{name}_q75']:.3g}] {ok}")
        print(f"{g}: sim median vs real median [IQR]: " + "; ".join(parts))
    for w in result.get("warnings", []):
        _warn(f"{args.scene}: {w['key']}: {w['message']}" + (f" ({w['count']} times)" if w.get("count", 1) > 1 else ""))
    print(f"-> {args.out}")
    return 0


def register_validate(sub) -> None:
    v = sub.add_parser("validate", help="simulate matched presses of real recordings and compare the footprints")
    _recordings_and_layout(v, "DIR")
    v.add_argument("--scene", required=True, metavar="SCENE.toml",
                   help="a validate scene: indenter, layer, sensor effects (scenes/validate_cyskin_gesture.toml)")
    v.add_argument("--holdout", nargs="*", default=None, metavar="RECORDING",
                   help="recordings the calibration did not see, reported apart (default: the profile's held_out)")
    v.add_argument("--set", action="append", metavar="KEY=VALUE", help="override a scene value (as vtcore run)")
    v.set_defaults(func=cmd_validate)
