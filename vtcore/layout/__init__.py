"""Skin layouts: module geometry, patches placed on surfaces, the skin mesh, layout files."""

from .conform import LogMap, PlacementReport, fill, place
from .endeffectors import seed001_disc, seed002_curved, seed002_planar
from .io import FORMATS, load, save
from .mesh import LayoutWarning, SkinMesh, mesh_from_triangles, skin_mesh
from .model import Layout
from .modules import MODULES, PITCH, ModuleType, get_module, register_module
from .patches import Patch, fill_patch, hexagon_flat, make_patch, patch_from_poses, wrap_on_sphere

__all__ = ["Layout", "SkinMesh", "skin_mesh", "mesh_from_triangles", "LayoutWarning", "PITCH",
           "MODULES", "ModuleType", "get_module", "register_module", "Patch", "make_patch", "fill_patch",
           "patch_from_poses", "hexagon_flat", "wrap_on_sphere",
           "seed001_disc", "seed002_planar", "seed002_curved", "load", "save", "FORMATS",
           "place", "fill", "LogMap", "PlacementReport"]
