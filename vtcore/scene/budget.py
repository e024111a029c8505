"""Resource guards of a scene run: sizes a scene sets, checked before the work allocates them.

A scene sets counts whose product with the number of taxels sizes the run's arrays:
``task.readings`` (frames held, ``(T, N)`` arrays through every sensor effect),
``layer.samples_per_taxel`` / ``effects.soft_layer.samples_per_taxel`` (points averaged over
each taxel disc, ``(N * S, 3)`` arrays through the proximity query), ``task.trials`` x
``task.readings`` x objects (tactile images). Each is checked against the memory budget
(:func:`vtcore.inputs.memory_budget`, ``VTCORE_MEMORY_BUDGET``, default 4 GiB) as soon as the
number of taxels is known, with a message naming the key and what it would need.

The factors are a deliberately generous guess (not a measurement) of how many arrays of that
size are alive at the peak of the stage, so the estimate errs towards refusing early.
"""

from __future__ import annotations

from ..inputs import need_memory, need_time

#: Live (T, N) float64 arrays at the peak of a run's sensor pipeline.
FRAME_COPIES = 16
#: Live (N * S, 3) float64 arrays at the peak of a proximity query over taxel samples.
SAMPLE_COPIES = 8
#: Optimistic seconds of one simulated contact frame (a press solve on a small grid, warm-started): the
#: time guard refuses only trajectories that surely take longer than the budget (measured 0.02-0.2 s).
CONTACT_FRAME_S = 0.01
#: Largest task.force accepted, N (a tonne-force: far past any skin's range; 1e308 N made the press
#: solve overflow and report force_n = 0).
MAX_FORCE_N = 1e4
#: Longest strip:N patch (modules); a 1000-module CySkin strip is 7.5 m long.
MAX_STRIP_MODULES = 1000
#: Largest |value| of a sensor parameter in counts (offsets, drift, noise, ceilings): 15,000 times the
#: 16-bit range. Past it, 1e308 counts plus a drift overflowed to infinity (or NaN) in the frames.
MAX_COUNTS = 1e9
#: Largest gain, counts per pascal (CySkin: about 0.1-2): 1e6 saturates the converter at 0.07 Pa.
MAX_GAIN = 1e6
#: Object stiffness range, N/m: softer than any sponge (300 N/m) to stiffer than a steel contact; a
#: stiffness of 5e-324 made the object's deflection force / k infinite.
STIFFNESS_N_M = (1.0, 1e12)


def check_run_sizes(scene, n_taxels: int) -> None:
    """Raise InputError (naming the key) if the scene's counts need more than the memory budget."""
    n = max(int(n_taxels), 1)
    task = scene.get("task") or {}
    file = scene.path
    readings = task.get("readings") if isinstance(task, dict) else None
    if isinstance(readings, int):
        rows = readings * max(int(task.get("trials", 1) or 1), 1) * max(len(scene.get("objects") or []), 1)
        need_memory(8.0 * FRAME_COPIES * rows * n, key="task.readings", file=file,
                    what=f"{rows} readings x {n} taxels")
    samples = [("layer.samples_per_taxel", (scene.get("layer") or {}).get("samples_per_taxel")),
               ("effects.soft_layer.samples_per_taxel",
                (scene.effects.get("soft_layer") or {}).get("samples_per_taxel"))]
    for key, s in samples:
        if isinstance(s, int) and s > 0:
            need_memory(8.0 * 3 * SAMPLE_COPIES * s * n, key=key, file=file,
                        what=f"{s} samples per taxel x {n} taxels")


def check_frames(scene, frames: float, n_taxels: int, key: str, what: str) -> None:
    """Refuse, before the loop, ``frames`` simulated contact frames that need more memory or time than
    the budgets (``frames`` counted in floats: 1e308 s of keyframes is not an int)."""
    n = max(int(n_taxels), 1)
    need_memory(8.0 * FRAME_COPIES * frames * n, key=key, file=scene.path, what=f"{what} x {n} taxels")
    need_time(frames, CONTACT_FRAME_S, key=key, file=scene.path, what=what)
