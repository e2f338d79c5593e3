"""The state diagram table against the spec's acceptance matrix (spec notes 1.2/1.3)."""

from __future__ import annotations

import pytest

from motionplc.blocks import AxisState, ErrorID
from motionplc.blocks.axis_state import COMMANDS, EDGES, Event, allowed, next_state

S = AxisState
D, SS, H, DM, CM, SM, ST, ES = (
    S.DISABLED,
    S.STANDSTILL,
    S.HOMING,
    S.DISCRETE_MOTION,
    S.CONTINUOUS_MOTION,
    S.SYNCHRONIZED_MOTION,
    S.STOPPING,
    S.ERROR_STOP,
)

# Independent transcription of the matrix: command -> {state: resulting state}; absent = Error.
EXPECTED = {
    Event.HOME: {SS: H},
    Event.STOP: {SS: ST, H: ST, DM: ST, CM: ST, SM: ST, ST: ST},
    Event.DISCRETE: {SS: DM, DM: DM, CM: DM, SM: DM},
    Event.CONTINUOUS: {SS: CM, DM: CM, CM: CM, SM: CM},
    Event.RESET: {s: s for s in S},  # ErrorStop: handled by RESET_ENABLED/DISABLED below
    Event.POWER_OFF: {**{s: D for s in S if s is not ES}, ES: ES},
}


@pytest.mark.parametrize("event", COMMANDS, ids=lambda e: e.name)
@pytest.mark.parametrize("state", list(S), ids=lambda s: s.name)
def test_acceptance_matrix(event: Event, state: AxisState) -> None:
    expect = EXPECTED[event].get(state)
    assert allowed(event, state) is (expect is not None)
    if expect is None:
        with pytest.raises(KeyError, match=f"{event.name} is not allowed in {state.name}"):
            next_state(event, state)
    else:
        assert next_state(event, state) is expect


@pytest.mark.parametrize("state", list(S), ids=lambda s: s.name)
def test_system_events(state: AxisState) -> None:
    assert next_state(Event.AXIS_ERROR, state) is ES  # T1 from anywhere
    completions = {
        Event.POWER_ON_READY: {D: SS},  # T5
        Event.RESET_DISABLED: {ES: D},  # T3
        Event.RESET_ENABLED: {ES: SS},  # T4
        Event.HOME_DONE: {H: SS},  # T7
        Event.DISCRETE_DONE: {DM: SS},  # T9
        Event.STOP_RELEASED: {ST: SS},  # T19
    }
    for ev, table in completions.items():
        assert allowed(ev, state) is (state in table)
        if state in table:
            assert next_state(ev, state) is table[state]


def test_no_arrows_into_or_out_of_homing_except_the_spec_ones() -> None:
    into = {a for (a, b) in EDGES if b is H and a is not H}
    out = {b for (a, b) in EDGES if a is H and b is not H}
    assert into == {SS}
    assert out == {SS, ST, ES, D}


def test_state_error_ids() -> None:
    assert {ErrorID.for_state(s) for s in S} == {ErrorID(0x2000 + int(s)) for s in S}
    assert ErrorID.for_state(ES) is ErrorID.STATE_ERROR_STOP
