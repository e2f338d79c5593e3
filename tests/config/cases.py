# ruff: noqa: E501 - the expected error lines are kept whole, as a user sees them
"""Malformed configurations and sequences with the exact errors they must give.

Each case: (name, YAML text, expected error lines). ``{f}`` stands for the file's path.
"""

from __future__ import annotations

BASE = """\
runtime:
  tick: 0.001
  tasks:
    motion: {period: 0.001}
buses:
  can0: {type: can, interface: virtual, channel: t}
  mb0: {type: modbus, host: 127.0.0.1, port: 0}
axes:
  x:
    limits: {v_max: 1.0, a_max: 2.0, j_max: 20.0}
    drive: {bus: can0, node_id: 1}
  y:
    limits: {v_max: 1.0, a_max: 2.0}
    drive: {bus: mb0, unit_id: 1}
groups:
  xy: [x, y]
"""


def _cfg(
    axes: str, runtime: str = "  tasks:\n    motion: {period: 0.001}\n", buses: str = ""
) -> str:
    return f"runtime:\n{runtime}" + (f"buses:\n{buses}" if buses else "") + f"axes:\n{axes}"


_X = "  x:\n    limits: {v_max: 1.0, a_max: 2.0}\n"
_CAN = "  can0: {type: can, interface: virtual}\n"

CONFIG_CASES: list[tuple[str, str, list[str]]] = [
    (
        "unknown top-level key",
        _cfg(_X) + "extras: 1\n",
        [
            "{f}:7: (top level).extras: unknown key (allowed: runtime, buses, axes, groups, "
            "cams, gcode, opcua, hmi)"
        ],
    ),
    (
        "missing axes",
        "runtime:\n  tasks:\n    motion: {}\n",
        ["{f}:1: (top level).axes: missing (allowed: required key)"],
    ),
    (
        "unknown runtime key",
        _cfg(_X, runtime="  tick: 0.001\n  cycle: 0.002\n  tasks:\n    motion: {}\n"),
        [
            "{f}:3: runtime.cycle: unknown key "
            "(allowed: tick, clock, overrun, trace_capacity, trace_bytes, "
            "blend_replans_per_cycle, max_overruns, realtime, tasks)"
        ],
    ),
    (
        "trace byte budget too small",
        _cfg(_X, runtime="  trace_bytes: 1000\n  tasks:\n    motion: {}\n"),
        ["{f}:2: runtime.trace_bytes: got 1000 (allowed: an integer >= 65536)"],
    ),
    (
        "blend re-plan budget out of range",
        _cfg(_X, runtime="  blend_replans_per_cycle: 0\n  tasks:\n    motion: {}\n"),
        ["{f}:2: runtime.blend_replans_per_cycle: got 0 (allowed: an integer in 1..1000)"],
    ),
    (
        "tick not a number",
        _cfg(_X, runtime="  tick: fast\n  tasks:\n    motion: {}\n"),
        ["{f}:2: runtime.tick: got string 'fast' (allowed: a number > 0)"],
    ),
    (
        "negative tick",
        _cfg(_X, runtime="  tick: -0.001\n  tasks:\n    motion: {}\n"),
        ["{f}:2: runtime.tick: got -0.001 (allowed: a number > 0)"],
    ),
    (
        "clock not allowed",
        _cfg(_X, runtime="  clock: wallclock\n  tasks:\n    motion: {}\n"),
        ["{f}:2: runtime.clock: got string 'wallclock' (allowed: simulated, realtime)"],
    ),
    (
        "period not a multiple of the tick",
        _cfg(_X, runtime="  tick: 0.001\n  tasks:\n    motion: {period: 0.0025}\n"),
        [
            "{f}:4: runtime.tasks.motion.period: 0.0025 s is not a multiple of the tick "
            "0.001 s (allowed: k * 0.001 s with k = 1, 2, ...)"
        ],
    ),
    (
        "priority out of range",
        _cfg(_X, runtime="  tasks:\n    motion: {priority: 40}\n"),
        ["{f}:3: runtime.tasks.motion.priority: got 40 (allowed: an integer in 0..31)"],
    ),
    (
        "watchdog without time",
        _cfg(_X, runtime="  tasks:\n    motion: {watchdog: {sensitivity: 2}}\n"),
        ["{f}:3: runtime.tasks.motion.watchdog.time: missing (allowed: required key)"],
    ),
    (
        "no task",
        _cfg(_X, runtime="  tasks: {}\n"),
        ["{f}:2: runtime.tasks: no task (allowed: at least one task)"],
    ),
    (
        "non-positive v_max and a_max (both reported)",
        _cfg("  x:\n    limits: {v_max: 0, a_max: -2.0}\n"),
        [
            "{f}:6: axes.x.limits.v_max: got 0 (allowed: a number > 0)",
            "{f}:6: axes.x.limits.a_max: got -2 (allowed: a number > 0)",
        ],
    ),
    (
        "missing limits",
        _cfg("  x:\n    units: m\n"),
        ["{f}:6: axes.x.limits: missing (allowed: required key)"],
    ),
    (
        "unknown limit key",
        _cfg("  x:\n    limits: {v_max: 1.0, a_max: 2.0, vmax: 3}\n"),
        ["{f}:6: axes.x.limits.vmax: unknown key (allowed: v_max, a_max, j_max, v_min, a_min)"],
    ),
    (
        "positive v_min",
        _cfg("  x:\n    limits: {v_max: 1.0, a_max: 2.0, v_min: 0.5}\n"),
        ["{f}:6: axes.x.limits.v_min: got 0.5 (allowed: a number <= 0)"],
    ),
    (
        "j_max as a string",
        _cfg("  x:\n    limits: {v_max: 1.0, a_max: 2.0, j_max: '20'}\n"),
        ["{f}:6: axes.x.limits.j_max: got string '20' (allowed: a number > 0, or .inf)"],
    ),
    (
        "units not allowed",
        _cfg("  x:\n    units: mm\n    limits: {v_max: 1.0, a_max: 2.0}\n"),
        ["{f}:6: axes.x.units: got string 'mm' (allowed: m, rad)"],
    ),
    (
        "unknown task of an axis",
        _cfg("  x:\n    task: fast\n    limits: {v_max: 1.0, a_max: 2.0}\n"),
        ["{f}:6: axes.x.task: got string 'fast' (allowed: motion)"],
    ),
    (
        "software limits reversed",
        _cfg("  x:\n    limits: {v_max: 1.0, a_max: 2.0}\n    software_limits: {min: 1, max: 0}\n"),
        ["{f}:7: axes.x.software_limits.max: max 0 is not above min 1 (allowed: min < max)"],
    ),
    (
        "modulo with software limits",
        _cfg(
            "  x:\n    limits: {v_max: 1.0, a_max: 2.0}\n    modulo: 6.28\n"
            "    software_limits: {min: 0, max: 1}\n"
        ),
        [
            "{f}:7: axes.x.modulo: a modulo axis has no software limits (allowed: modulo or software_limits)"
        ],
    ),
    (
        "homing switch without position",
        _cfg("  x:\n    limits: {v_max: 1.0, a_max: 2.0}\n    homing: {method: switch}\n"),
        ["{f}:7: axes.x.homing.switch: missing for method switch (allowed: a number)"],
    ),
    (
        "homing method not allowed",
        _cfg("  x:\n    limits: {v_max: 1.0, a_max: 2.0}\n    homing: {method: index}\n"),
        ["{f}:7: axes.x.homing.method: got string 'index' (allowed: set_position, switch, drive)"],
    ),
    (
        "axis bound to an undefined bus",
        _cfg(
            "  x:\n    limits: {v_max: 1.0, a_max: 2.0}\n    drive: {bus: can1, node_id: 1}\n",
            buses=_CAN,
        ),
        ["{f}:9: axes.x.drive.bus: unknown bus 'can1' (allowed: can0)"],
    ),
    (
        "duplicate node ids",
        _cfg(
            "  x:\n    limits: {v_max: 1.0, a_max: 2.0}\n    drive: {bus: can0, node_id: 3}\n"
            "  y:\n    limits: {v_max: 1.0, a_max: 2.0}\n    drive: {bus: can0, node_id: 3}\n",
            buses=_CAN,
        ),
        [
            "{f}:12: axes.y.drive.node_id: 3 is already used by axis 'x' on bus 'can0' (allowed: one axis per id and bus)"
        ],
    ),
    (
        "node id out of range",
        _cfg(
            "  x:\n    limits: {v_max: 1.0, a_max: 2.0}\n    drive: {bus: can0, node_id: 128}\n",
            buses=_CAN,
        ),
        ["{f}:9: axes.x.drive.node_id: got 128 (allowed: an integer in 1..127)"],
    ),
    (
        "unit_id on a CAN bus",
        _cfg(
            "  x:\n    limits: {v_max: 1.0, a_max: 2.0}\n    drive: {bus: can0, unit_id: 1}\n",
            buses=_CAN,
        ),
        [
            "{f}:9: axes.x.drive.unit_id: not used on a CAN bus (allowed: node_id)",
            "{f}:9: axes.x.drive.node_id: missing (allowed: an integer in 1..127)",
        ],
    ),
    (
        "word order not allowed",
        _cfg(
            "  x:\n    limits: {v_max: 1.0, a_max: 2.0}\n"
            "    drive: {bus: mb0, unit_id: 1, word_order: middle}\n",
            buses="  mb0: {type: modbus}\n",
        ),
        ["{f}:9: axes.x.drive.word_order: got string 'middle' (allowed: big, little)"],
    ),
    (
        "simulated Modbus drives on a non-loopback host",
        _cfg(_X, buses="  mb0: {type: modbus, host: 192.168.1.10}\n"),
        [
            "{f}:5: buses.mb0.host: simulated drives listen on loopback only, got '192.168.1.10' (allowed: 127.0.0.1, ::1, localhost)"
        ],
    ),
    (
        "CAN interface not allowed",
        _cfg(_X, buses="  can0: {type: can, interface: udp_multicast}\n"),
        [
            "{f}:5: buses.can0.interface: udp_multicast sends CAN frames as IP multicast beyond "
            "this machine (allowed: virtual, socketcan, socketcand, pcan, kvaser, ixxat, vector, "
            "slcan, gs_usb, serial, canalystii, cantact, etas, iscan, neousys, neovi, nican, "
            "nixnet, robotell, seeedstudio, systec, usb2can)"
        ],
    ),
    (
        "CAN interface unknown",
        _cfg(_X, buses="  can0: {type: can, interface: peak}\n"),
        [
            "{f}:5: buses.can0.interface: got string 'peak' (allowed: virtual, socketcan, "
            "socketcand, pcan, kvaser, ixxat, vector, slcan, gs_usb, serial, canalystii, cantact, "
            "etas, iscan, neousys, neovi, nican, nixnet, robotell, seeedstudio, systec, usb2can)"
        ],
    ),
    (
        "bitrate not allowed",
        _cfg(_X, buses="  can0: {type: can, bitrate: 1000}\n"),
        [
            "{f}:5: buses.can0.bitrate: got number 1000 (allowed: 10000, 20000, 50000, 125000, 250000, 500000, 800000, 1000000)"
        ],
    ),
    (
        "register map on a simulated Modbus bus",
        _cfg(
            "  x:\n    limits: {v_max: 1, a_max: 1}\n"
            "    drive: {bus: mb, unit_id: 1, register_map: other.yaml}\n",
            buses="  mb: {type: modbus}\n",
        ),
        [
            "{f}:9: axes.x.drive.register_map: no such register map file 'other.yaml' (allowed: "
            "a shipped map (motionplc-v1), a path to a map file, or an inline mapping)",
            "{f}:9: axes.x.drive.register_map: the simulated drives of bus 'mb' speak the "
            "motionplc-v1 map only (allowed: motionplc-v1, or drives: external on buses.mb)",
        ],
    ),
    (
        "Modbus key on a CAN bus",
        _cfg(_X, buses="  can0: {type: can, port: 502}\n"),
        [
            "{f}:5: buses.can0.port: unknown key "
            "(allowed: type, drives, interface, channel, bitrate, max_frames_per_cycle, options, "
            "master_node_id, master_heartbeat, sync_cob_id, sdo_timeout)"
        ],
    ),
    (
        "CAN frame budget out of range",
        _cfg(_X, buses="  can0: {type: can, interface: virtual, max_frames_per_cycle: 0}\n"),
        ["{f}:5: buses.can0.max_frames_per_cycle: got 0 (allowed: an integer in 1..100000)"],
    ),
    (
        "bus type missing",
        _cfg(_X, buses="  can0: {interface: virtual}\n"),
        ["{f}:5: buses.can0.type: missing (allowed: can, modbus)"],
    ),
    (
        "group with an unknown axis",
        _cfg(_X) + "groups:\n  g: [x, z]\n",
        ["{f}:8: groups.g[1]: unknown axis 'z' (allowed: x)"],
    ),
    (
        "duplicate key",
        _cfg(
            "  x:\n    limits: {v_max: 1.0, a_max: 2.0}\n  x:\n    limits: {v_max: 2.0, "
            "a_max: 2.0}\n"
        ),
        ["{f}:7: axes.x: duplicate key"],
    ),
    (
        "invalid axis name",
        _cfg("  x.1:\n    limits: {v_max: 1.0, a_max: 2.0}\n"),
        [
            "{f}:5: axes.x.1: invalid name 'x.1' (allowed: letters, digits and _, not starting with a digit)"
        ],
    ),
    (
        "YAML syntax error",
        "runtime:\n  tasks: {motion: {}\naxes: {}\n",
        ["{f}:3: YAML syntax error: did not find expected ',' or '}'"],  # libyaml's words,
    ),
    (
        "top level is a list",
        "- runtime\n- axes\n",
        ["{f}:1: (top level): got a list (allowed: a mapping)"],
    ),
    (
        "several errors at once",
        _cfg(
            "  x:\n    limits: {v_max: -1, a_max: 2.0}\n    drive: {bus: nope, node_id: 1}\n",
            runtime="  clock: fast\n  tasks:\n    motion: {}\n",
        ),
        [
            "{f}:2: runtime.clock: got string 'fast' (allowed: simulated, realtime)",
            "{f}:7: axes.x.limits.v_max: got -1 (allowed: a number > 0)",
            "{f}:8: axes.x.drive.bus: unknown bus 'nope' (allowed: no bus is defined)",
        ],
    ),
]

SEQUENCE_CASES: list[tuple[str, str, list[str]]] = [
    (
        "unknown step key",
        "steps:\n  - name: a\n    wiat: 1\n",
        [
            "{f}:3: steps[0].wiat: unknown key "
            "(allowed: name, call, until, timeout, expect, wait, parallel)"
        ],
    ),
    (
        "unknown FB type",
        "steps:\n  - call: [{block: m, type: MC_MoveAbsolut, axis: x}]\n",
        [
            "{f}:2: steps[0].call[0].type: got string 'MC_MoveAbsolut' (allowed: "
            "MC_AbortTrigger, MC_Halt, MC_HaltSuperimposed, MC_Home, MC_Jog, MC_MoveAbsolute, "
            "MC_MoveAdditive, MC_MoveRelative, MC_MoveSuperimposed, MC_MoveVelocity, MC_Power, "
            "MC_ReadActualPosition, MC_ReadActualTorque, MC_ReadActualVelocity, "
            "MC_ReadAxisError, MC_ReadAxisInfo, MC_ReadBoolParameter, MC_ReadMotionState, "
            "MC_ReadParameter, MC_ReadStatus, MC_Reset, MC_SetOverride, MC_SetPosition, MC_Stop, "
            "MC_TouchProbe, MC_WriteBoolParameter, MC_WriteParameter, SyncMoveAbsolute)"
        ],
    ),
    (
        "unknown axis",
        "steps:\n  - call: [{block: m, type: MC_MoveAbsolute, axis: z}]\n",
        ["{f}:2: steps[0].call[0].axis: unknown axis 'z' (allowed: x, y)"],
    ),
    (
        "unknown FB input",
        "steps:\n  - call: [{block: m, type: MC_MoveAbsolute, axis: x, pos: 1.0}]\n",
        [
            "{f}:2: steps[0].call[0].pos: unknown key (allowed: block, type, axis, "
            "continuous_update, position, velocity, acceleration, deceleration, jerk, "
            "direction, buffer_mode)"
        ],
    ),
    (
        "buffer mode not allowed",
        "steps:\n  - call:\n      - {block: m, type: MC_MoveAbsolute, axis: x,\n"
        "         buffer_mode: QUEUED}\n",
        [
            "{f}:4: steps[0].call[0].buffer_mode: got string 'QUEUED' (allowed: ABORTING, "
            "BUFFERED, BLENDING_LOW, BLENDING_PREVIOUS, BLENDING_NEXT, BLENDING_HIGH)"
        ],
    ),
    (
        "position as a string",
        "steps:\n  - call: [{block: m, type: MC_MoveAbsolute, axis: x, position: far}]\n",
        ["{f}:2: steps[0].call[0].position: got string 'far' (allowed: a number)"],
    ),
    (
        "done on an undeclared block",
        "steps:\n  - wait: 1\n    until: {done: m}\n",
        ["{f}:3: steps[0].until.done: unknown block 'm' (allowed: no block is declared yet)"],
    ),
    (
        "axis state not allowed",
        "steps:\n  - until: {state: {x: MOVING}}\n",
        [
            "{f}:2: steps[0].until.state.x: got string 'MOVING' (allowed: DISABLED, "
            "STANDSTILL, HOMING, DISCRETE_MOTION, CONTINUOUS_MOTION, SYNCHRONIZED_MOTION, "
            "STOPPING, ERROR_STOP)"
        ],
    ),
    (
        "expectation on an unknown field",
        "steps:\n  - expect: {x.pos: 1.0}\n",
        [
            "{f}:2: steps[0].expect.x.pos: unknown axis field 'pos' (allowed: position, "
            "actual_position, velocity, following_error, state)"
        ],
    ),
    (
        "negative wait",
        "steps:\n  - wait: -1\n",
        ["{f}:2: steps[0].wait: got -1 (allowed: a number >= 0)"],
    ),
    (
        "step with call and wait",
        "steps:\n  - call: [{block: p, type: MC_Power, axis: x}]\n    wait: 1\n",
        [
            "{f}:3: steps[0].wait: a step has one of call, wait, parallel; this one also has "
            "call (allowed: call, wait, parallel)"
        ],
    ),
    (
        "sync move on an unknown group",
        "steps:\n  - call: [{block: g, type: SyncMoveAbsolute, group: xyz}]\n",
        ["{f}:2: steps[0].call[0].group: unknown group 'xyz' (allowed: xy)"],
    ),
    (
        "block re-bound to another axis",
        "steps:\n  - call: [{block: m, type: MC_MoveAbsolute, axis: x, velocity: 0.5}]\n"
        "  - call: [{block: m, axis: y}]\n",
        ["{f}:3: steps[1].call[0].axis: block 'm' is bound to 'x' (line 2) (allowed: x)"],
    ),
    (
        "no steps",
        "task: motion\n",
        ["{f}:1: (top level).steps: missing (allowed: required key)"],
    ),
    (
        "unknown task",
        "task: slow\nsteps:\n  - wait: 1\n",
        ["{f}:1: task: got string 'slow' (allowed: motion)"],
    ),
]
