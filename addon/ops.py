"""All operators, one module per concern (``ops_<concern>.py``); their shared base is in
``opbase.py``. A new concern adds its module here, in the order of the panel."""

from __future__ import annotations

from . import ops_analysis, ops_contact, ops_evaluate, ops_layout, ops_replay, ops_robot, ops_scene
from .ops_layout import VTSKIN_OT_lay_patch  # noqa: F401  (tests start a modal fill from the class)

CLASSES = (ops_scene.CLASSES + ops_robot.CLASSES + ops_layout.CLASSES + ops_contact.CLASSES + ops_replay.CLASSES
           + ops_analysis.CLASSES + ops_evaluate.CLASSES)
