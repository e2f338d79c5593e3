"""Shared fixtures of the planner tests.

* ``oracle``: a 1-DoF Ruckig :class:`~tests.planning._cases.RuckigOracle` (test skipped when
  ruckig is not installed);
* ``summary``: ``summary("text")`` adds a line to the "planning summary" section printed at the
  end of the pytest run (sweep statistics, duration ratios).

Hypothesis settings are per test (``tests/planning/_strategies.hsettings``): derandomized,
no deadline; ``PLANNING_THOROUGH=1`` runs 10x the examples with random seeds.
"""

from __future__ import annotations

from collections.abc import Callable

import pytest

from tests.planning._cases import RuckigOracle

_SUMMARY_KEY = pytest.StashKey[list[str]]()


@pytest.fixture(scope="session")
def oracle() -> RuckigOracle:
    rk = pytest.importorskip("ruckig")
    return RuckigOracle(rk)


@pytest.fixture
def summary(request: pytest.FixtureRequest) -> Callable[[str], None]:
    lines = request.config.stash.setdefault(_SUMMARY_KEY, [])

    def add(text: str) -> None:
        lines.append(f"{request.node.name}: {text}")

    return add


def pytest_terminal_summary(terminalreporter: pytest.TerminalReporter) -> None:
    lines = terminalreporter.config.stash.get(_SUMMARY_KEY, [])
    if lines:
        terminalreporter.section("planning summary")
        for line in lines:
            terminalreporter.write_line(line)
