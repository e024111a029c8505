"""Robots as input and output of a skin design (issue 25): read a URDF or MJCF robot, lay skin on
its own links (the layout is born in the link's frame), export the robot with the skin in it.

- :func:`load_robot` (URDF through :mod:`.urdf`, stdlib only; MJCF through MuJoCo's compiler,
  :mod:`.mjcf`) -> :class:`Robot` (links with visual and collision geometry, joints, forward kinematics).
- :func:`link_mesh`: a link's surface in its frame, metres (the model's scale and origin applied).
- :func:`lay_on_link`: place or fill a patch there.
- :func:`export_skinned`: the robot's own file with the taxel frames (URDF) or sites and touch
  sensors (MJCF) added; a URDF robot also exports as MJCF through MuJoCo's URDF import.

``vtcore`` robot commands: ``vtcore robot info``, ``vtcore robot export``, and ``vtcore layout place
ROBOT --link NAME`` (docs/layout.md, "Robot in, skinned robot out").
"""

from __future__ import annotations

from .export import FORMATS, export_skinned, load_robot, robot_format, skin_link, taxel_frames  # noqa: F401
from .meshes import describe, link_mesh  # noqa: F401
from .model import Geometry, Joint, Link, Robot  # noqa: F401
from .skin import anchors, default_anchor, lay_on_link, outer_region  # noqa: F401
