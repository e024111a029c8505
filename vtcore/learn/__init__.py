"""Learning on augmented point clouds (seed 000, Sect. 4.1): data sets, PointNet, active touch selection.

- :mod:`vtcore.learn.datasets`: the paper's data sets from the augmented clouds (numpy only)
- :mod:`vtcore.learn.active`: choosing which probes to touch (numpy only)
- :mod:`vtcore.learn.pointnet`, :mod:`vtcore.learn.train`: PointNet in PyTorch, the optional
  extra ``vtcore[learn]``; torch is imported inside their functions, so this package (and
  ``import vtcore``) works without it.
"""

from .datasets import (POINTS, PROPAGATIONS, SUBSAMPLES, TOUCHES, DataSet, ObjectScan, build_clouds,
                       disjoint_subsamples, draw_pairs, make_dataset, object_subsamples)
from .pointnet import TORCH_PIN, MissingTorchError, require_torch

__all__ = ["POINTS", "PROPAGATIONS", "SUBSAMPLES", "TOUCHES", "DataSet", "ObjectScan", "build_clouds",
           "disjoint_subsamples", "draw_pairs", "make_dataset", "object_subsamples", "TORCH_PIN",
           "MissingTorchError", "require_torch"]
