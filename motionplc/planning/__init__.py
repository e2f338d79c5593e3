"""Planning core: time-optimal jerk-limited trajectories.

Public API::

    from motionplc.planning import State, Limits, Profile, plan, plan_velocity, PlanningError
    from motionplc.planning import plan_batch, BatchPlan  # N problems at once, as arrays
    from motionplc.planning import CamTable, CamPoint  # cam tables (VDI 2143 motion laws)

``COMPILED`` is True when the mypyc-compiled planning core is in use, False for the pure-Python
sources (``MOTIONPLC_PURE_PYTHON=1``, no C compiler at install, or a source edited since the
build; ``motionplc.compiled_core()`` says why).
"""

from motionplc import _purepy
from motionplc.errors import PlanningError
from motionplc.planning.batch import BatchPlan, plan_batch
from motionplc.planning.cam import CamPoint, CamTable, CamTableError
from motionplc.planning.limits import Limits
from motionplc.planning.otg import OnlineGenerator
from motionplc.planning.plan import plan, plan_velocity
from motionplc.planning.profile import Knot, Profile, Sample, Samples, Segment
from motionplc.planning.state import State
from motionplc.planning.sync import plan_fixed_duration, plan_sync
from motionplc.planning.tracking import Tracker, track
from motionplc.planning.trajectory import Trajectory, TrajectorySamples

__all__ = [
    "COMPILED",
    "BatchPlan",
    "CamPoint",
    "CamTable",
    "CamTableError",
    "Knot",
    "Limits",
    "OnlineGenerator",
    "PlanningError",
    "Profile",
    "Sample",
    "Samples",
    "Segment",
    "State",
    "Tracker",
    "Trajectory",
    "TrajectorySamples",
    "plan",
    "plan_batch",
    "plan_fixed_duration",
    "plan_sync",
    "plan_velocity",
    "track",
]

COMPILED: bool = _purepy.status().compiled
