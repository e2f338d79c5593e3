"""motionplc: a soft-PLC motion-control runtime in Python.

The planning core lives in :mod:`motionplc.planning`; PLCopen function blocks in
:mod:`motionplc.blocks`; the cyclic runtime in :mod:`motionplc.runtime`; drives in
:mod:`motionplc.fieldbus`; YAML machine configurations in :mod:`motionplc.config`
(``load_config``, ``build``), motion sequences in :mod:`motionplc.sequence`.
"""

from motionplc.config import build, load_config
from motionplc.errors import ConfigError, MotionPlcError, PlanningError

__all__ = ["ConfigError", "MotionPlcError", "PlanningError", "build", "load_config"]
__version__ = "0.1.0"
