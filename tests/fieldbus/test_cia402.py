"""CiA 402 tables and pure functions, exhaustively."""

from __future__ import annotations

import itertools

import pytest

from motionplc.fieldbus.cia402 import (
    CONTROLWORD_VALUE,
    DEVICE_TRANSITIONS,
    MASTER_TABLE,
    STATUSWORD_PATTERNS,
    TARGET_STATES,
    Cia402Command,
    Cia402State,
    decode_command,
    decode_statusword,
    device_transition,
    next_controlword,
    statusword_bits,
)

S = Cia402State
C = Cia402Command
REAL_STATES = [s for s in S if s is not S.UNKNOWN]


def test_statusword_patterns_are_disjoint_over_all_words() -> None:
    for sw in range(0x10000):
        hits = [st for mask, value, st in STATUSWORD_PATTERNS if sw & mask == value]
        assert len(hits) <= 1, hex(sw)
        assert decode_statusword(sw) == (hits[0] if hits else S.UNKNOWN)


@pytest.mark.parametrize(
    ("word", "state"),
    [
        (0x0000, S.NOT_READY_TO_SWITCH_ON),
        (0x0250, S.SWITCH_ON_DISABLED),
        (0x0231, S.READY_TO_SWITCH_ON),
        (0x0233, S.SWITCHED_ON),
        (0x0237, S.OPERATION_ENABLED),
        (0x1237, S.OPERATION_ENABLED),
        (0x0217, S.QUICK_STOP_ACTIVE),
        (0x021F, S.FAULT_REACTION_ACTIVE),
        (0x0218, S.FAULT),
        (0x0208, S.FAULT),
        (0x0001, S.UNKNOWN),
    ],
)
def test_typical_real_statuswords(word: int, state: Cia402State) -> None:
    assert decode_statusword(word) is state


@pytest.mark.parametrize("state", REAL_STATES)
def test_statusword_bits_round_trip(state: Cia402State) -> None:
    for extra in (0x0000, 0x0010, 0x0200, 0x1210):
        assert decode_statusword(statusword_bits(state) | extra) is state


def test_decode_command_every_controlword() -> None:
    expected = {
        0x06: C.SHUTDOWN,
        0x07: C.SWITCH_ON,
        0x0F: C.ENABLE_OPERATION,
        0x00: C.DISABLE_VOLTAGE,
        0x02: C.QUICK_STOP,
    }
    for cw in range(0x10000):
        for prev in (0x00, 0x80):
            cmd = decode_command(cw, prev)
            if cw & 0x80:
                assert cmd is (C.NONE if prev & 0x80 else C.FAULT_RESET)
                continue
            low = cw & 0x8F
            # the masks of the spec table
            if cw & 0x82 == 0x00:
                assert cmd is C.DISABLE_VOLTAGE
            elif cw & 0x86 == 0x02:
                assert cmd is C.QUICK_STOP
            elif cw & 0x87 == 0x06:
                assert cmd is C.SHUTDOWN
            elif low == 0x07:
                assert cmd is C.SWITCH_ON
            else:
                assert low == 0x0F and cmd is C.ENABLE_OPERATION
            if cw in expected:
                assert cmd is expected[cw]


def test_held_fault_reset_resets_once() -> None:
    state = S.FAULT
    prev = 0x00
    transitions = []
    for cw in (0x80, 0x80, 0x80):
        state, tr = device_transition(state, decode_command(cw, prev))
        transitions.append(tr)
        prev = cw
        if state is S.SWITCH_ON_DISABLED:
            state = S.FAULT  # fault still present: the device would fault again at once
    assert transitions == [15, None, None]


# every commanded transition of the standard with its number
STANDARD = [
    (S.SWITCH_ON_DISABLED, 0x06, S.READY_TO_SWITCH_ON, 2),
    (S.READY_TO_SWITCH_ON, 0x07, S.SWITCHED_ON, 3),
    (S.SWITCHED_ON, 0x0F, S.OPERATION_ENABLED, 4),
    (S.OPERATION_ENABLED, 0x07, S.SWITCHED_ON, 5),
    (S.SWITCHED_ON, 0x06, S.READY_TO_SWITCH_ON, 6),
    (S.READY_TO_SWITCH_ON, 0x00, S.SWITCH_ON_DISABLED, 7),
    (S.READY_TO_SWITCH_ON, 0x02, S.SWITCH_ON_DISABLED, 7),
    (S.OPERATION_ENABLED, 0x06, S.READY_TO_SWITCH_ON, 8),
    (S.OPERATION_ENABLED, 0x00, S.SWITCH_ON_DISABLED, 9),
    (S.SWITCHED_ON, 0x00, S.SWITCH_ON_DISABLED, 10),
    (S.SWITCHED_ON, 0x02, S.SWITCH_ON_DISABLED, 10),
    (S.OPERATION_ENABLED, 0x02, S.QUICK_STOP_ACTIVE, 11),
    (S.QUICK_STOP_ACTIVE, 0x00, S.SWITCH_ON_DISABLED, 12),
    (S.FAULT, 0x80, S.SWITCH_ON_DISABLED, 15),
]


@pytest.mark.parametrize(("start", "cw", "end", "number"), STANDARD)
def test_standard_transitions(start: Cia402State, cw: int, end: Cia402State, number: int) -> None:
    assert device_transition(start, decode_command(cw, 0x00)) == (end, number)


def test_transition_16_depends_on_quick_stop_option() -> None:
    for option in range(-1, 10):
        got = device_transition(S.QUICK_STOP_ACTIVE, C.ENABLE_OPERATION, option)
        if 5 <= option <= 8:
            assert got == (S.OPERATION_ENABLED, 16)
        else:
            assert got == (S.QUICK_STOP_ACTIVE, None)


def test_every_state_command_pair_is_either_listed_or_ignored() -> None:
    for state, cmd in itertools.product(S, C):
        new, number = device_transition(state, cmd, quick_stop_option=6)
        if (state, cmd) in DEVICE_TRANSITIONS:
            assert (new, number) == DEVICE_TRANSITIONS[(state, cmd)]
        else:
            assert (new, number) == (state, None)  # illegal command: unchanged


def test_spec_sequence_from_switch_on_disabled() -> None:
    state = S.SWITCH_ON_DISABLED
    prev = 0
    for cw, masked in ((0x06, 0x21), (0x07, 0x23), (0x0F, 0x27), (0x02, 0x07)):
        state, _ = device_transition(state, decode_command(cw, prev))
        prev = cw
        assert statusword_bits(state) & 0x6F == masked
    state, _ = device_transition(state, decode_command(0x00, prev))
    assert state is S.SWITCH_ON_DISABLED


def test_master_table_covers_every_state_target_pair() -> None:
    for state, target in itertools.product(S, TARGET_STATES):
        cw, number = MASTER_TABLE[(state, target)]
        assert cw in CONTROLWORD_VALUE.values()
        if number is not None:
            new, dev_number = device_transition(state, decode_command(cw, 0x00))
            assert dev_number == number, (state, target)


def test_next_controlword_rejects_non_target() -> None:
    with pytest.raises(ValueError, match="target"):
        next_controlword(S.FAULT, S.FAULT)


def _walk(state: Cia402State, target: Cia402State, reset: bool, steps: int = 8) -> list:
    prev = 0x0F
    path = [state]
    for _ in range(steps):
        cw = next_controlword(state, target, prev, fault_reset=reset)
        cmd = decode_command(cw, prev)
        state, _ = device_transition(state, cmd, quick_stop_option=2)
        # automatic transitions of the device
        if state is S.NOT_READY_TO_SWITCH_ON:
            state = S.SWITCH_ON_DISABLED  # 1
        elif state is S.FAULT_REACTION_ACTIVE:
            state = S.FAULT  # 14
        prev = cw
        path.append(state)
    return path


@pytest.mark.parametrize("start", list(S))
@pytest.mark.parametrize("target", TARGET_STATES)
def test_master_reaches_every_target_from_every_state(
    start: Cia402State, target: Cia402State
) -> None:
    path = _walk(start, target, reset=True)
    if start is S.UNKNOWN:
        assert path[-1] is S.UNKNOWN  # nothing to drive from an undecodable word
        return
    if target is S.QUICK_STOP_ACTIVE:
        # quick stop is entered only from OPERATION ENABLED; elsewhere the drive drops out
        expected = (
            S.QUICK_STOP_ACTIVE
            if start in (S.OPERATION_ENABLED, S.QUICK_STOP_ACTIVE)
            else (S.SWITCH_ON_DISABLED)
        )
        assert path[-1] is expected
        return
    assert path[-1] is target, path
    # at most: fault 0x00, 0x80 -> SOD, 2, 3, 4
    assert path.index(target) <= 5


@pytest.mark.parametrize("target", TARGET_STATES)
def test_fault_without_reset_request_stays(target: Cia402State) -> None:
    assert _walk(S.FAULT, target, reset=False)[-1] is S.FAULT


def test_fault_reset_edge_sequence() -> None:
    seq = []
    prev = 0x0F
    for _ in range(5):
        prev = next_controlword(S.FAULT, S.OPERATION_ENABLED, prev, fault_reset=True)
        seq.append(prev)
    assert seq == [0x00, 0x80, 0x00, 0x80, 0x00]
