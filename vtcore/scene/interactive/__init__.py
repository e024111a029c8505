"""Glue for interactive front ends (the Blender add-on): one call per user action.

Each function takes plain numpy arrays (SI units, one frame), composes the
``vtcore`` packages and returns plain arrays, so the add-on only gathers input,
calls ONE function here and writes the result. Nothing here imports ``bpy``;
everything is testable without Blender. No algorithm lives here: these are
thin compositions of ``vtcore.layout``, ``vtcore.contact``, ``vtcore.filters``
and ``vtcore.augment``.

One module per concern (``skin``, ``contact``, ``live``, ``evaluate``, ``augment``, ``scenes``, ``robot``); this package
re-exports their public names, so the add-on reads ``interactive.<function>``. A new
front-end action goes in the module of its concern (or a new one, re-exported here).
"""

from __future__ import annotations

from ..._progress import Job, keep_going  # noqa: F401  (Job: the add-on runs a long fill in one)
from .augment import augment, probes_from_file  # noqa: F401
from .contact import (Contact, SkinEdges, bake, edges, indenter_mesh, sensor_response,  # noqa: F401
                      sensor_summary, simulate, soft_layer)
from .evaluate import SkinMap, evaluate_skin  # noqa: F401
from .live import LiveFrame, LiveTouch, LiveWorker  # noqa: F401
from .robot import (LinkPart, RobotImport, export_skinned_robot, import_layout, import_robot,  # noqa: F401
                    parse_joint_values, parse_packages)
from .scenes import SceneOutput, run_scene_file  # noqa: F401
from .skin import (LayoutEdit, export_layout, lay_patch, merge, move_module, remove_modules,  # noqa: F401
                   selection_anchor, skin_triangles)
