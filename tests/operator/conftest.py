"""tests/operator: the OPC UA module runs one server and two clients (asyncua's start loads
its standard address space: ~30 s on the loaded 2-core machine, ~3 s unloaded): ``slow``."""

from __future__ import annotations

import pytest


def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    for item in items:
        if item.nodeid.startswith("tests/operator/test_opcua.py"):
            item.add_marker(pytest.mark.slow)
