"""Local filters on the skin mesh (seed 002) and the tactile-image baseline.

Entry point: ``edge_filter(mesh, values)``, Eq. 6 of seed 002 before
thresholding, for (N,) or (T, N) values. Build :class:`EdgeFilter` once per
mesh to filter many frames; :func:`local_operator` gives the constant-weight
Eq. 4 filters (low-pass, Gaussian, Laplacian). The detectors turn a frame into
edge features (components, orientation, centroid) by three methods.
"""

from .detectors import ImageEdgeDetector, MeshEdgeDetector, SubtaxelEdgeDetector, make_detector
from .extract import (EdgeFeatures, component_orientation, features, mean_axis, mesh_components,
                      plane_basis, project_plane, skin_frame, wrap_half_pi)
from .image import TactileImage, canny_edges, flatten
from .local import (EdgeFilter, apply_local, edge_filter, inverse_distance, local_operator,
                    relative_threshold, threshold)
from .subdivide import loop_subdivision

__all__ = [
    "edge_filter", "EdgeFilter", "threshold", "relative_threshold", "local_operator", "apply_local",
    "inverse_distance", "EdgeFeatures", "features", "mesh_components", "component_orientation",
    "mean_axis", "plane_basis", "project_plane", "skin_frame", "wrap_half_pi", "TactileImage", "canny_edges",
    "flatten", "loop_subdivision", "MeshEdgeDetector", "ImageEdgeDetector", "SubtaxelEdgeDetector",
    "make_detector",
]
