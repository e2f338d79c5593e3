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

_PROPERTY = "planning summary"  # the test report's user property that carries a line


@pytest.fixture(scope="session")
def oracle() -> RuckigOracle:
    rk = pytest.importorskip("ruckig")
    return RuckigOracle(rk)


@pytest.fixture
def summary(request: pytest.FixtureRequest) -> Callable[[str], None]:
    """The lines travel in the test's report (``user_properties``), so that they reach the
    printing process also from a pytest-xdist worker."""

    def add(text: str) -> None:
        request.node.user_properties.append((_PROPERTY, f"{request.node.name}: {text}"))

    return add


class _SummaryLines:
    """Collects the lines from the reports in the process that prints the summary (the only
    one under pytest-xdist; the worker's own copy never prints)."""

    def __init__(self) -> None:
        self.lines: list[str] = []

    def pytest_runtest_logreport(self, report: pytest.TestReport) -> None:
        if report.when == "call":
            self.lines += [v for k, v in report.user_properties if k == _PROPERTY]

    def pytest_terminal_summary(self, terminalreporter: pytest.TerminalReporter) -> None:
        if self.lines:
            terminalreporter.section("planning summary")
            for line in self.lines:
                terminalreporter.write_line(line)


def pytest_configure(config: pytest.Config) -> None:
    config.pluginmanager.register(_SummaryLines(), "planning-summary")
