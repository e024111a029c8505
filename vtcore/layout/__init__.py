"""Skin layouts: module geometry, patches placed on surfaces, the skin mesh, layout files."""

from .mesh import SkinMesh, mesh_from_triangles, skin_mesh
from .model import Layout
from .patches import PITCH, hexagon_flat, wrap_on_sphere

__all__ = ["Layout", "SkinMesh", "skin_mesh", "mesh_from_triangles", "PITCH", "hexagon_flat", "wrap_on_sphere"]
