"""motionplc: a soft-PLC motion-control runtime in Python.

The planning core lives in :mod:`motionplc.planning`; PLCopen function blocks in
:mod:`motionplc.blocks`; the cyclic runtime in :mod:`motionplc.runtime`; drives in
:mod:`motionplc.fieldbus`.
"""

from motionplc.errors import MotionPlcError, PlanningError

__all__ = ["MotionPlcError", "PlanningError"]
__version__ = "0.1.0"
