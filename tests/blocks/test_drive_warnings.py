"""Drive warnings (DriveFeedback.warning, e.g. a warning EMCY) reach the user without
stopping anything, and drive-fault texts name the code once, with its meaning."""

from __future__ import annotations

import dataclasses

from motionplc.blocks import AxisState, MC_MoveAbsolute, MC_Power
from motionplc.fieldbus.base import DriveCommand, DriveFeedback
from motionplc.fieldbus.ideal import IdealDrive
from motionplc.runtime import Runtime


class WarningDrive(IdealDrive):
    """An ideal follower that reports ``warning`` while it is set."""

    def __init__(self) -> None:
        super().__init__("w")
        self.warning = ""

    def read_inputs(self, t: float) -> DriveFeedback:
        return dataclasses.replace(super().read_inputs(t), warning=self.warning)

    def write_outputs(self, t: float, command: DriveCommand) -> None:
        super().write_outputs(t, command)


def test_warning_is_traced_and_motion_goes_on() -> None:
    drive = WarningDrive()
    rt = Runtime(cycle=0.001)
    ax = rt.add_axis("x", 1.0, 10.0, 100.0, drive=drive)
    power = MC_Power(axis=ax, enable=True)
    move = MC_MoveAbsolute(axis=ax, position=0.3, velocity=0.5, acceleration=5.0, deceleration=5.0)
    warnings = {100: "EMCY 0x4210 (temperature: device)", 300: "", 350: "EMCY 0x3220 (DC link)"}

    def program(ctx: object) -> None:
        power()
        move(execute=power.status)
        k = ctx.cycle  # type: ignore[attr-defined]
        if k in warnings:
            drive.warning = warnings[k]

    rt.add_task("main", program)
    rt.run(cycles=1500)
    assert (ax.state, ax.position, move.error_id) == (AxisState.STANDSTILL, 0.3, 0), move.error_id
    events = [(e.fb, e.output, e.value) for e in rt.trace.events if e.fb == "x.drive"]
    assert events == [
        ("x.drive", "warning: EMCY 0x4210 (temperature: device)", True),
        ("x.drive", "warning: EMCY 0x4210 (temperature: device)", False),
        ("x.drive", "warning: EMCY 0x3220 (DC link)", True),
    ]
    assert [text for _, text in ax.warnings_seen] == [warnings[100], warnings[350]]
    assert ax.drive_warning == warnings[350]
    # seen by the axis in the cycle after the drive set it (read inputs before the program)
    assert [round(t, 3) for t, _ in ax.warnings_seen] == [0.101, 0.351]


def test_fault_text_names_the_code_once() -> None:
    for detail, expected in [
        ("", "drive fault 0x8611 (following error)"),
        ("drive fault 0x8611 (FAULT)", "drive fault 0x8611 (FAULT)"),
        ("encoder cable", "drive fault 0x7300 (sensor): encoder cable"),
    ]:
        drive = IdealDrive("d")
        rt = Runtime(cycle=0.001)
        ax = rt.add_axis("x", 1.0, 10.0, 100.0, drive=drive)
        power = MC_Power(axis=ax, enable=True)
        rt.add_task("main", lambda ctx, p=power: p())
        rt.run(cycles=10)
        code = 0x7300 if "encoder" in detail else 0x8611
        drive.inject_fault(code, detail)
        rt.run(cycles=5)
        assert ax.state is AxisState.ERROR_STOP
        assert ax.axis_error_reason == expected


def test_axis_as_positional_name_is_refused() -> None:
    import pytest

    rt = Runtime(cycle=0.001)
    ax = rt.add_axis("x", 1.0, 10.0, 100.0)
    with pytest.raises(TypeError, match=r"MC_Power: the first positional argument is the FB's"):
        MC_Power(ax, enable=True)  # type: ignore[arg-type]
