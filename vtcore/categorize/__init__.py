"""Category formation through soft filters (seed 001).

Tactile images of touched objects are projected by PCA to two dimensions and
split by K-Means into two categories; which split comes out depends on the
soft layer over the sensor. The package holds the algorithm
(:class:`CategoryFormation`), the tasks and cluster matching of seed 001
(:func:`make_tasks`, :func:`cluster_match`, :func:`accuracy`), tactile images
(:func:`tactile_images`), the spatial-resolution study
(:func:`resolution_study`), the soft-layer designer (:func:`design_sweep`) and
the model variants (:func:`variant_sweep`: the same under other contact and
sensor assumptions).
Figures are in :mod:`vtcore.categorize.plots`.
"""

from .designer import LayerSweep, design_sweep, format_ranges_mm
from .formation import CategoryFormation, canonical, decision_boundary, kmeans_splits, single_threaded
from .images import tactile_images
from .resolution import ResolutionStudy, resolution_study
from .variants import Variant, VariantSweep, variant_grid, variant_sweep, variants_summary, variants_table
from .tasks import (PAPER_FIG8, PAPER_OBJECTS, PAPER_TASK_NOTES, PAPER_TASKS, Task, accuracy, cluster_match, confusion,
                    make_tasks, task_accuracies)

__all__ = [
    "CategoryFormation", "canonical", "decision_boundary", "kmeans_splits", "single_threaded", "tactile_images", "make_tasks", "Task",
    "cluster_match", "accuracy", "confusion", "task_accuracies", "PAPER_OBJECTS", "PAPER_TASKS",
    "PAPER_TASK_NOTES", "PAPER_FIG8", "resolution_study", "ResolutionStudy", "design_sweep", "LayerSweep",
    "format_ranges_mm", "Variant", "VariantSweep", "variant_grid", "variant_sweep", "variants_table",
    "variants_summary",
]
