"""Sweeps: one scene over a grid of ``--set`` values and seeds, each point an ordinary run.

``plan_sweep(scene, grid_args, seeds, sets)`` validates the sweep and lists its
points (nothing runs); ``run_sweep(plan, out, workers=, scheduler=)`` runs them
on dask.distributed (a ``LocalCluster`` by default) into ``out/<point>/`` and
writes ``out/sweep.csv`` and ``out/report.md``. dask is imported only when a
sweep runs. See docs/sweeps.md.
"""

from .engine import SchedulerError, run_sweep
from .spec import MAX_POINTS, Plan, Point, parse_grid_arg, parse_seeds, plan_sweep

__all__ = ["plan_sweep", "run_sweep", "Plan", "Point", "parse_grid_arg", "parse_seeds", "SchedulerError",
           "MAX_POINTS"]
