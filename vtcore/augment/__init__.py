"""Augmented point clouds (seed 000): compliance from probing, propagation, colours.

- :func:`compliance` (Eq. 1), :class:`TactilePointCloud`, :func:`load_probes`, :class:`ProbeModel`
- :class:`ClusterPropagation` (Eq. 2), :class:`SmoothPropagation` (Eqs. 3-4),
  :class:`GPPropagation` (appendix), :class:`AugmentedPointCloud` (touch-by-touch updates)
- :func:`visual_cloud`, :func:`depth_camera_view`, :func:`read_point_cloud`,
  :func:`write_ply`, :func:`colour_map`
- :func:`make_seed000_object`: the six objects of seed 000 with stiffness fields
"""

from .cloud import (DepthCamera, colour_map, depth_camera_view, read_ply_vertices, read_point_cloud, two_cameras,
                    visual_cloud, write_ply)
from .compliance import ProbeModel, TactilePointCloud, compliance, load_probes
from .objects import OBJECTS, CompliantObject, make_seed000_object
from .propagation import (AugmentedPointCloud, ClusterPropagation, GPPropagation, SmoothPropagation,
                          softmax_weights)

__all__ = ["ClusterPropagation", "SmoothPropagation", "GPPropagation", "AugmentedPointCloud", "softmax_weights",
           "compliance", "TactilePointCloud", "load_probes", "ProbeModel",
           "DepthCamera", "two_cameras", "depth_camera_view", "visual_cloud", "read_point_cloud",
           "colour_map", "write_ply", "read_ply_vertices",
           "OBJECTS", "CompliantObject", "make_seed000_object"]
