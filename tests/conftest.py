"""Suite-wide Hypothesis defaults: derandomized, so a CI run is reproducible (the examples are
a fixed function of each test). ``PLANNING_THOROUGH=1`` switches to random exploration (the
planning tests also run 10x their examples then, see ``tests/planning/_strategies.py``)."""

from __future__ import annotations

import os
import warnings

import pytest
from hypothesis import settings

settings.register_profile(
    "motionplc", derandomize=os.environ.get("PLANNING_THOROUGH", "") != "1", deadline=None
)
settings.load_profile("motionplc")


# -- known kernel defects the invariant checker's differencing rules (group D) find -------------
# Test node id -> the defect, its owner and what fixes it. For these tests only, the checker's
# D failures are recorded instead of raised; the test fails if none occurs (the entry must go
# when the fix merges), a warning in the summary names them otherwise. Every other test runs
# the full check.
_HALT_OVERRIDE_HANDOVER = (
    "axis kernel, blocks/axis.py + override.py, no owner in TEAM.md (lead): an MC_Halt that "
    "ends while an MC_SetOverride ramp runs hands over to the buffered MC_MoveAbsolute with an "
    "acceleration column spike (0.63 -> 19.37 -> 0.79 m/s^2 in two cycles, jerk column "
    "+20000 then 172) that the set positions do not follow: K1 off by 5.4e-6 m, 2.1x its "
    "allowance (widened 4x for the override ramp), cycle 1663 of seed 3"
)
KNOWN_DEFECTS: dict[str, str] = {
    "tests/runtime/test_fast_paths.py::test_every_output_edge_is_traced[3]": (
        _HALT_OVERRIDE_HANDOVER
    ),
    "tests/runtime/test_plan_ahead.py::test_random_trace_is_the_same_without_planning_ahead[3]": (
        _HALT_OVERRIDE_HANDOVER
    ),
}


@pytest.fixture(autouse=True)
def _known_defect(request: pytest.FixtureRequest, monkeypatch: pytest.MonkeyPatch):
    reason = KNOWN_DEFECTS.get(request.node.nodeid)
    if reason is None:
        yield
        return
    from motionplc.runtime.invariants import InvariantChecker

    seen: list[str] = []
    monkeypatch.setattr(
        InvariantChecker,
        "_d_failed",
        lambda self, cycle, who, detail: seen.append(f"cycle {cycle}: {who}: D: {detail}"),
    )
    yield
    if not seen:
        pytest.fail(f"KNOWN_DEFECTS lists this test ({reason}) but group D held: remove it")
    warnings.warn(
        f"known defect ({reason}): {len(seen)} group-D failures, the first: {seen[0]}",
        stacklevel=1,
    )
