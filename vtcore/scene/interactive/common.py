"""What the front-end calls share: the add-on's mesh under vtcore's input checks."""

from __future__ import annotations

import numpy as np

from ...errors import InputError
from ...layout.meshinput import SURFACE_SIZE_M, checked_mesh


def as_trimesh(vertices, triangles, size_range=SURFACE_SIZE_M):
    """The add-on's mesh (vertices (V, 3) metres, triangles (F, 3)) under the checks every mesh entering
    vtcore takes (:func:`vtcore.layout.meshinput.checked_mesh`); indenters pass the objects' size range."""
    if len(np.asarray(triangles).reshape(-1)) == 0:
        raise InputError("has no faces: a skin can only be laid on (and pressed by) a surface", key="mesh")
    return checked_mesh(vertices, triangles, size_range=size_range, key="mesh", scale_key="the object's scale",
                        process=False)
