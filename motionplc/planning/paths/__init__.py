"""Geometric paths and time-optimal motion along them.

The interface every path implements is :class:`~motionplc.planning.paths.base.Path`.
"""

from motionplc.planning.paths.base import Path, as_param
from motionplc.planning.paths.blend import (
    BlendedPath,
    Corner,
    CornerBlend,
    CornerKind,
    Transition,
    TransitionMode,
    blend_corners,
    blend_polyline,
)
from motionplc.planning.paths.composite import CompositePath, join, polyline
from motionplc.planning.paths.geometry import Arc, Helix, Line, PathSegment

__all__ = ["Path", "as_param"]
__all__ += ["Arc", "CompositePath", "Helix", "Line", "PathSegment", "join", "polyline"]
__all__ += ["BlendedPath", "Corner", "CornerBlend", "CornerKind", "Transition", "TransitionMode"]
__all__ += ["blend_corners", "blend_polyline"]
from motionplc.planning.paths.topp import DEFAULT_GRID, plan_path  # noqa: E402
from motionplc.planning.paths.trajectory import PathSample, PathSamples, PathTrajectory  # noqa: E402

__all__ += ["DEFAULT_GRID", "PathSample", "PathSamples", "PathTrajectory", "plan_path"]
from motionplc.planning.paths.arclength import ArcLengthTable, adaptive_simpson  # noqa: E402
from motionplc.planning.paths.bspline import (  # noqa: E402
    BSplineFit,
    BSplinePath,
    Deviation,
    deviation,
    fit_bspline,
)
from motionplc.planning.paths.hermite import HermitePath  # noqa: E402
from motionplc.planning.paths.orientation import (  # noqa: E402
    OrientationSpline,
    quat_from_axis_angle,
    quat_to_matrix,
    slerp,
)

__all__ += ["ArcLengthTable", "BSplineFit", "BSplinePath", "Deviation", "HermitePath"]
__all__ += ["OrientationSpline", "adaptive_simpson", "deviation", "fit_bspline"]
__all__ += ["quat_from_axis_angle", "quat_to_matrix", "slerp"]
