"""Suite-wide Hypothesis defaults: derandomized, so a CI run is reproducible (the examples are
a fixed function of each test). ``PLANNING_THOROUGH=1`` switches to random exploration (the
planning tests also run 10x their examples then, see ``tests/planning/_strategies.py``)."""

from __future__ import annotations

import os

import pytest
from hypothesis import settings

settings.register_profile(
    "motionplc", derandomize=os.environ.get("PLANNING_THOROUGH", "") != "1", deadline=None
)
settings.load_profile("motionplc")


# -- real SocketCAN ------------------------------------------------------------------------
# Tests marked ``vcan`` need a real vcan0 (a kernel with SocketCAN). Where there is none they
# skip with the reason; inside ``tools/with-vcan`` (WITH_VCAN=1, what .ci/run does) a missing
# vcan0 is a failure. Select them with ``-m vcan``.
def pytest_configure(config: pytest.Config) -> None:
    config.addinivalue_line(
        "markers", "vcan: needs a real SocketCAN vcan0 (skips without one, fails in with-vcan)"
    )


def pytest_runtest_setup(item: pytest.Item) -> None:
    if item.get_closest_marker("vcan") is None:
        return
    from tests.vcan_env import vcan_missing

    reason = vcan_missing()
    if reason is None:
        return
    if os.environ.get("WITH_VCAN") == "1":
        pytest.fail(f"inside with-vcan but {reason}", pytrace=False)
    pytest.skip(f"{reason}; run them with: tools/with-vcan .venv/bin/python -m pytest -m vcan")
