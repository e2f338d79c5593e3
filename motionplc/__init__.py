"""motionplc: a soft-PLC motion-control runtime in Python.

The planning core lives in :mod:`motionplc.planning`; PLCopen function blocks in
:mod:`motionplc.blocks`; the cyclic runtime in :mod:`motionplc.runtime`; drives in
:mod:`motionplc.fieldbus`; YAML machine configurations in :mod:`motionplc.config`
(``load_config``, ``build``), motion sequences in :mod:`motionplc.sequence`.
"""

from motionplc import _purepy

_purepy.install()  # before any planning module: compiled core or the pure-Python sources

from motionplc.config import build, load_config  # noqa: E402
from motionplc.errors import ConfigError, MotionPlcError, PlanningError  # noqa: E402

__all__ = [
    "ConfigError",
    "MotionPlcError",
    "PlanningError",
    "build",
    "compiled_core",
    "load_config",
]
__version__ = "0.1.0"


def compiled_core() -> _purepy.CoreStatus:
    """Whether the planning core in use is the mypyc-compiled one (``.compiled``) and why
    (``.reason``: compiled, or why the pure-Python sources are used)."""
    return _purepy.status()
