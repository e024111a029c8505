"""Control on top of the skin: contour following, compliance-aware paths, reaching."""

from .contour import (AnalyticContact, CircleContour, ContourFollower, ContourRun, LineContour,  # noqa: F401
                      control_frame, facing_down, motion, motion_matrix, summarize)
