"""motionplc.blocks: PLCopen single-axis function blocks, the axis and its state machine.

from motionplc.blocks import MC_Power, MC_MoveAbsolute, BufferMode, AxisState
"""

from motionplc.blocks.admin import (
    MC_Power,
    MC_ReadActualPosition,
    MC_ReadActualVelocity,
    MC_ReadAxisError,
    MC_ReadMotionState,
    MC_ReadStatus,
    MC_Reset,
    MC_SetOverride,
    MC_SetPosition,
)
from motionplc.blocks.axis import Axis, AxisConfig, Command, Handle, Status
from motionplc.blocks.cam_select import CamTableID, MC_CamTableSelect
from motionplc.blocks.enums import (
    AxisState,
    BufferMode,
    Direction,
    ErrorID,
    ExecutionMode,
    JogMode,
    Source,
    StartMode,
    SyncMode,
)
from motionplc.blocks.jog import MC_Jog
from motionplc.blocks.motion import (
    MC_Halt,
    MC_Home,
    MC_MoveAbsolute,
    MC_MoveAdditive,
    MC_MoveRelative,
    MC_MoveVelocity,
    MC_Stop,
)
from motionplc.blocks.params import (
    MC_ReadActualTorque,
    MC_ReadAxisInfo,
    MC_ReadBoolParameter,
    MC_ReadParameter,
    MC_WriteBoolParameter,
    MC_WriteParameter,
)
from motionplc.blocks.probe import MC_AbortTrigger, MC_TouchProbe, TriggerRef
from motionplc.blocks.superimposed import MC_HaltSuperimposed, MC_MoveSuperimposed
from motionplc.blocks.sync import (
    MC_CamIn,
    MC_CamOut,
    MC_GearIn,
    MC_GearInPos,
    MC_GearOut,
    MC_PhasingAbsolute,
    MC_PhasingRelative,
)

__all__ = [
    "Axis",
    "AxisConfig",
    "AxisState",
    "BufferMode",
    "CamTableID",
    "Command",
    "Direction",
    "ErrorID",
    "ExecutionMode",
    "Handle",
    "JogMode",
    "MC_AbortTrigger",
    "MC_CamIn",
    "MC_CamOut",
    "MC_CamTableSelect",
    "MC_GearIn",
    "MC_GearInPos",
    "MC_GearOut",
    "MC_Halt",
    "MC_HaltSuperimposed",
    "MC_Home",
    "MC_Jog",
    "MC_MoveAbsolute",
    "MC_MoveAdditive",
    "MC_MoveRelative",
    "MC_MoveSuperimposed",
    "MC_MoveVelocity",
    "MC_PhasingAbsolute",
    "MC_PhasingRelative",
    "MC_Power",
    "MC_ReadActualPosition",
    "MC_ReadActualTorque",
    "MC_ReadActualVelocity",
    "MC_ReadAxisError",
    "MC_ReadAxisInfo",
    "MC_ReadBoolParameter",
    "MC_ReadMotionState",
    "MC_ReadParameter",
    "MC_ReadStatus",
    "MC_Reset",
    "MC_SetOverride",
    "MC_SetPosition",
    "MC_Stop",
    "MC_TouchProbe",
    "MC_WriteBoolParameter",
    "MC_WriteParameter",
    "Source",
    "StartMode",
    "Status",
    "SyncMode",
    "TriggerRef",
]
