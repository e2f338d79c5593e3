"""Suite-wide Hypothesis defaults: derandomized, so a CI run is reproducible (the examples are
a fixed function of each test). ``PLANNING_THOROUGH=1`` switches to random exploration (the
planning tests also run 10x their examples then, see ``tests/planning/_strategies.py``)."""

from __future__ import annotations

import os

from hypothesis import settings

settings.register_profile(
    "motionplc", derandomize=os.environ.get("PLANNING_THOROUGH", "") != "1", deadline=None
)
settings.load_profile("motionplc")
