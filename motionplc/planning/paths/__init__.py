"""Geometric paths and time-optimal motion along them.

Public API::

    from motionplc.planning.paths import Line, Arc, Helix, CompositePath, polyline, join
    from motionplc.planning.paths import blend_corners, Transition      # G2 corner blends
    from motionplc.planning.paths import HermitePath, BSplinePath, fit_bspline, deviation
    from motionplc.planning.paths import OrientationSpline, slerp
    from motionplc.planning.paths import plan_path, PathTrajectory      # time-optimal motion

The interface every path implements is :class:`~motionplc.planning.paths.base.Path`.
"""

from motionplc.planning.paths.arclength import ArcLengthTable, adaptive_simpson
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
from motionplc.planning.paths.bspline import (
    BSplineFit,
    BSplinePath,
    Deviation,
    deviation,
    fit_bspline,
)
from motionplc.planning.paths.composite import CompositePath, join, polyline
from motionplc.planning.paths.geometry import Arc, Helix, Line, PathSegment
from motionplc.planning.paths.hermite import HermitePath
from motionplc.planning.paths.orientation import (
    OrientationSpline,
    quat_from_axis_angle,
    quat_to_matrix,
    slerp,
)
from motionplc.planning.paths.topp import DEFAULT_GRID, plan_path
from motionplc.planning.paths.trajectory import PathSample, PathSamples, PathTrajectory

__all__ = [
    "DEFAULT_GRID",
    "Arc",
    "ArcLengthTable",
    "BSplineFit",
    "BSplinePath",
    "BlendedPath",
    "CompositePath",
    "Corner",
    "CornerBlend",
    "CornerKind",
    "Deviation",
    "Helix",
    "HermitePath",
    "Line",
    "OrientationSpline",
    "Path",
    "PathSample",
    "PathSamples",
    "PathSegment",
    "PathTrajectory",
    "Transition",
    "TransitionMode",
    "adaptive_simpson",
    "as_param",
    "blend_corners",
    "blend_polyline",
    "deviation",
    "fit_bspline",
    "join",
    "plan_path",
    "polyline",
    "quat_from_axis_angle",
    "quat_to_matrix",
    "slerp",
]
