"""HIL fixtures: rigs closed after every test; pymodbus kept quiet."""

from __future__ import annotations

import logging
from collections.abc import Callable, Iterator
from typing import Any

import pytest

from tests.hil.rigs import HilRig, make_rig


@pytest.fixture(autouse=True)
def _quiet_pymodbus() -> None:
    logging.getLogger("pymodbus").setLevel(logging.CRITICAL)


@pytest.fixture
def rig_factory() -> Iterator[Callable[..., HilRig]]:
    made: list[HilRig] = []

    def make(kind: str, n_axes: int = 1, **kw: Any) -> HilRig:
        rig = make_rig(kind, n_axes, **kw)
        made.append(rig)
        return rig

    yield make
    for rig in made:
        rig.close()
