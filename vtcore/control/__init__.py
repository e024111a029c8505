"""Control on top of the skin: contour following, compliance-aware paths, reaching."""

from .contour import (AnalyticContact, CircleContour, ContourFollower, ContourRun, LineContour,  # noqa: F401
                      control_frame, facing_down, motion, motion_matrix, summarize)
from .path_following import (ForceController, PathFollowingResult, follow_path,  # noqa: F401
                              force_setpoint)
from .reach import Obstacle, ReachResult, influence_radii, reach  # noqa: F401
