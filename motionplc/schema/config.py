"""The schema of a machine configuration file (``configs/*.yaml``).

The single source of the keys, ranges and defaults that :mod:`motionplc.config`,
:mod:`motionplc.fieldbus.canopen_options` and :mod:`motionplc.fieldbus.modbus_options` check,
of the JSON Schema ``docs/schema/config.schema.json`` and of ``docs/reference/config.md``.
The named nodes below (``RUNTIME``, ``TASK``, ``CAN_BUS``, ``AXIS``, ``CANOPEN_DRIVE``, ...) are
what the validators read.
"""

from __future__ import annotations

from motionplc.fieldbus.canopen_startup import RPDO_OBJECTS, TPDO_OBJECTS
from motionplc.schema.gcode import GCODE
from motionplc.schema.nodes import (
    NAME_PATTERN,
    Bool,
    Choice,
    FileSchema,
    Integer,
    Key,
    ListOf,
    MapOf,
    Number,
    Obj,
    OneOf,
    Ref,
    Scalar,
    String,
)
from motionplc.schema.opcua import HMI, OPCUA
from motionplc.schema.register_map import REGISTER_MAP

__all__ = [
    "AXIS",
    "BUS",
    "BUS_DRIVES",
    "BUS_TYPES",
    "CAM",
    "CAM_LAWS",
    "CAM_POINT",
    "CANOPEN_DRIVE",
    "CANOPEN_DRIVE_KEYS",
    "CAN_BITRATES",
    "CAN_BUS",
    "CAN_INTERFACES",
    "CLOCKS",
    "CONFIG",
    "DRIVE",
    "GROUP",
    "GUARDING",
    "HEARTBEAT",
    "HOMING",
    "IDEAL_DRIVE",
    "LIMITS",
    "MODBUS_BUS",
    "MODBUS_DRIVE",
    "MODBUS_DRIVE_KEYS",
    "OVERRUN",
    "PDO_ENTRY_KEYS",
    "REALTIME",
    "RUNTIME",
    "SCALING",
    "SOFTWARE_LIMITS",
    "TASK",
    "TOP",
    "UNITS",
    "WATCHDOG",
]

CLOCKS = ("simulated", "realtime")
OVERRUN = ("skip", "catch_up")
BUS_TYPES = ("can", "modbus")
# python-can 4.6's interfaces (can.interfaces.VALID_INTERFACES; a test keeps the two equal) but
# udp_multicast: multicast leaves this machine. A literal, so that loading a configuration does
# not import python-can.
CAN_INTERFACES = (
    "virtual",
    "socketcan",
    "socketcand",
    "pcan",
    "kvaser",
    "ixxat",
    "vector",
    "slcan",
    "gs_usb",
    "serial",
    "canalystii",
    "cantact",
    "etas",
    "iscan",
    "neousys",
    "neovi",
    "nican",
    "nixnet",
    "robotell",
    "seeedstudio",
    "systec",
    "usb2can",
)
CAN_BITRATES = (10_000, 20_000, 50_000, 125_000, 250_000, 500_000, 800_000, 1_000_000)
BUS_DRIVES = ("simulated", "external")
UNITS = ("m", "rad")
HOMING_METHODS = ("set_position", "switch", "drive")
WORD_ORDERS = ("big", "little")
# supported ranges of axis configuration, the same as motionplc.blocks.axis (AXIS_LIMIT_MIN,
# AXIS_LIMIT_MAX, POSITION_MAX; a test keeps them equal)
LIMIT_LO = 1e-6
LIMIT_HI = 1e9
POSITION_MAX = 1e12

# ------------------------------------------------------------------------------- runtime
WATCHDOG = Obj(
    title="watchdog",
    description="The task's watchdog: the run fails when a cycle of the task takes longer than "
    "`time`, `sensitivity` times in a row (real-time clock only).",
    keys=(
        Key("time", Number(gt=0.0, unit="s", example=0.005, description="Watchdog time."), True),
        Key(
            "sensitivity",
            Integer(lo=1, default=1, description="Consecutive overlong cycles that trip it."),
        ),
    ),
)
TASK = Obj(
    title="task",
    description="A cyclic task. Axes, sequences and programs run in a task.",
    keys=(
        Key(
            "period",
            Number(
                gt=0.0,
                unit="s",
                default_text="the tick",
                example=0.002,
                description="Cycle time of the task.",
                checks=("a whole multiple of `runtime.tick` (k * tick, k = 1, 2, ...)",),
            ),
        ),
        Key(
            "priority",
            Integer(
                lo=0,
                hi=31,
                default=0,
                description="Scheduling priority among tasks due in the same tick (0 runs first).",
            ),
        ),
        Key("watchdog", WATCHDOG),
    ),
)
REALTIME = Obj(
    title="realtime",
    description="Real-time settings of the process, applied when the run starts on the "
    "real-time clock (`clock: realtime` or `motionplc run --realtime`). A setting the "
    "operating system refuses (no privilege, a CPU that does not exist on this machine) is "
    "reported in the run's statistics, never an error: the file stays portable.",
    keys=(
        Key(
            "priority",
            Integer(
                lo=1,
                hi=99,
                example=80,
                description="SCHED_FIFO priority of the process (Linux; needs CAP_SYS_NICE or "
                "an rtprio limit). Absent: the normal scheduler.",
            ),
        ),
        Key(
            "cpus",
            ListOf(
                item=Integer(lo=0, hi=1023, description="A CPU number."),
                min_items=1,
                default=(),
                example=[2, 3],
                description="CPUs the process is pinned to (`sched_setaffinity`). Any CPU "
                "number 0..1023 is accepted here; one this machine lacks is reported as "
                "refused when the run starts. Absent: no pinning.",
            ),
        ),
        Key(
            "lock_memory",
            Bool(
                default=False,
                description="`mlockall(MCL_CURRENT | MCL_FUTURE)`: no page of the process is "
                "paged out (needs the privilege or a large enough RLIMIT_MEMLOCK).",
            ),
        ),
    ),
)
RUNTIME = Obj(
    title="runtime",
    description="The cyclic runtime: base tick, clock, tasks, trace and real-time settings.",
    keys=(
        Key(
            "tick",
            Number(
                ge=1e-6,
                default=0.001,
                unit="s",
                description="Base tick of the scheduler; every task period is a multiple of it.",
            ),
        ),
        Key(
            "clock",
            Choice(
                options=CLOCKS,
                default="simulated",
                description="`simulated`: virtual time, as fast as the computer can, "
                "bit-reproducible; `realtime`: the wall clock (sleeps to each deadline).",
            ),
        ),
        Key(
            "overrun",
            Choice(
                options=OVERRUN,
                default="skip",
                description="Real-time clock: after an overrun, `skip` the missed cycles or "
                "`catch_up` (run them back to back).",
            ),
        ),
        Key(
            "trace_capacity",
            Integer(lo=1, default=500_000, description="Cycles the trace keeps (the newest)."),
        ),
        Key(
            "trace_bytes",
            Integer(
                lo=64 * 1024,
                default=32 * 1024 * 1024,
                unit="bytes",
                description="Memory budget of the trace; the oldest cycles are dropped beyond it.",
            ),
        ),
        Key(
            "blend_replans_per_cycle",
            Integer(
                lo=1,
                hi=1000,
                default=2,
                description="Re-plans of running moves for a newly queued blending successor "
                "per cycle (the rest follow in the next cycles).",
            ),
        ),
        Key(
            "max_overruns",
            Integer(
                lo=0,
                example=0,
                description="Overruns a run may have and still pass; one more fails it "
                "(`motionplc run --max-overruns` overrides it). Absent: overruns are counted, "
                "never a failure.",
            ),
        ),
        Key("realtime", REALTIME),
        Key(
            "tasks",
            MapOf(
                value=TASK,
                min_items=1,
                example={"motion": {"period": 0.001}},
                description="The cyclic tasks by name (at least one). Axes run in the first "
                "task unless they name another.",
            ),
            True,
        ),
    ),
)

# ------------------------------------------------------------------------------- buses
_BUS_DRIVES = Choice(
    options=BUS_DRIVES,
    default="simulated",
    description="`simulated`: virtual drives in this process at the other end of the bus, "
    "stepped with the runtime; `external`: real drives, or `motionplc drives` in another "
    "process (on the `virtual` CAN interface: a drive of this process on that channel).",
)
CAN_BUS = Obj(
    title="CAN bus",
    description="A CAN bus (CANopen CiA 402 drives) through python-can.",
    keys=(
        Key("type", Choice(options=("can",), description="A CAN bus."), True),
        Key("drives", _BUS_DRIVES),
        Key(
            "interface",
            Choice(
                options=CAN_INTERFACES,
                default="virtual",
                description="python-can interface (`udp_multicast` is refused: its frames leave "
                "this machine).",
            ),
        ),
        Key(
            "channel",
            String(
                default_text="the bus name for `virtual`, `vcan0` for `socketcan`",
                example="can0",
                description="The interface's channel (`can0`, `PCAN_USBBUS1`, `/dev/ttyACM0`, "
                "...).",
                checks=("required for interfaces other than `virtual` and `socketcan`",),
            ),
        ),
        Key(
            "bitrate",
            Choice(
                options=CAN_BITRATES,
                default=1_000_000,
                unit="bit/s",
                description="Bit rate (not passed to the `virtual` interface).",
            ),
        ),
        Key(
            "max_frames_per_cycle",
            Integer(
                lo=1,
                hi=100_000,
                default=256,
                description="Received frames handled per cycle (the cyclic ones first); the "
                "rest are counted.",
            ),
        ),
        Key(
            "options",
            MapOf(
                value=Scalar(description="A keyword argument of `can.Bus`."),
                key=String(pattern=r"^[A-Za-z_][A-Za-z0-9_]*$", what="a keyword"),
                example={"fd": True},
                description="Further keyword arguments of `can.Bus` for this interface "
                "(pcan's `fd`, slcan's `tty_baudrate`, ...), passed through as given "
                "(scalars only).",
                checks=("`interface`, `channel` and `bitrate` are set on the bus itself",),
            ),
        ),
        Key(
            "master_node_id",
            Integer(
                lo=1,
                hi=127,
                default=0x7F,
                description="The master's node id (its heartbeat COB-ID is 0x700 + id).",
            ),
        ),
        Key(
            "master_heartbeat",
            Number(
                ge=0.0,
                le=65.535,
                unit="s",
                default_text="half the shortest `heartbeat.consumer` of the bus's drives, else "
                "0 (none)",
                description="The master's heartbeat period.",
            ),
        ),
        Key(
            "sync_cob_id",
            Integer(lo=1, hi=0x7FF, default=0x80, description="COB-ID of the SYNC frames."),
        ),
        Key(
            "sdo_timeout",
            Number(gt=0.0, le=60.0, default=0.3, unit="s", description="SDO time-out."),
        ),
    ),
)
MODBUS_BUS = Obj(
    title="Modbus TCP bus",
    description="A Modbus TCP network (pymodbus).",
    keys=(
        Key("type", Choice(options=("modbus",), description="A Modbus TCP network."), True),
        Key("drives", _BUS_DRIVES),
        Key(
            "host",
            String(
                default="127.0.0.1",
                description="The server's address.",
                checks=("simulated drives listen on loopback only (127.0.0.1, ::1, localhost)",),
            ),
        ),
        Key(
            "port",
            Integer(
                lo=0,
                hi=65535,
                default=0,
                description="TCP port; 0 = an ephemeral port (simulated drives).",
                checks=("external drives need the server's port (1..65535)",),
            ),
        ),
        Key(
            "timeout",
            Number(gt=0.0, default=0.1, unit="s", description="Answer time-out of a request."),
        ),
    ),
)
BUS = OneOf(
    discriminator="type",
    variants=(CAN_BUS, MODBUS_BUS),
    description="A bus, by its `type`.",
)

# ------------------------------------------------------------------------------- drives
_OBJ_INDEX = r"0[xX][0-9a-fA-F]+|\d+"
OBJECT_PATTERN = rf"^\s*({_OBJ_INDEX})\s*(?::\s*({_OBJ_INDEX})\s*)?$"


def _pdo_object(kind: str, table: dict[int, tuple[str, str]]) -> OneOf:
    listed = ", ".join(f"0x{i:04X} ({name})" for i, (_, name) in table.items())
    choice = Choice(options=tuple(table), description=f"An object index: {listed}.", hex_digits=4)
    return OneOf(
        description=f"An object of the {kind.upper()}: an index (`0x6041`), a string "
        '(`"0x6041"`, `"0x6041:0"`) or `{index, sub, optional}`.',
        variants=(
            choice,
            String(pattern=OBJECT_PATTERN, what="an index or index:sub"),
            Obj(
                title="PDO object",
                keys=(
                    Key(
                        "index",
                        OneOf(
                            variants=(choice, String(pattern=rf"^\s*({_OBJ_INDEX})\s*$")),
                            description="The object index.",
                        ),
                        True,
                    ),
                    Key("sub", Integer(lo=0, hi=255, default=0, description="Sub-index.")),
                    Key(
                        "optional",
                        Bool(
                            default=False,
                            description="Left out when the drive refuses to map it.",
                        ),
                    ),
                ),
            ),
        ),
        checks=(f"an object the {kind.upper()} can carry ({listed}), sub-index 0",),
    )


PDO_ENTRY_KEYS = ("objects", "cob_id", "transmission")


def _pdo(kind: str, n: int, table: dict[int, tuple[str, str]]) -> Obj:
    return Obj(
        title=f"{kind}{n}",
        description=f"{kind.upper()} {n}: its objects, COB-ID and transmission type.",
        keys=(
            Key(
                "objects",
                ListOf(item=_pdo_object(kind, table), min_items=1, description="Mapped objects."),
                True,
            ),
            Key(
                "cob_id",
                Integer(
                    lo=0x001,
                    hi=0x7FF,
                    default_text=f"the CiA 301 default of {kind.upper()} {n} for the node",
                    description="COB-ID.",
                ),
            ),
            Key(
                "transmission",
                Integer(
                    lo=1, hi=240, default=1, description="Transmission type (every n-th SYNC)."
                ),
            ),
        ),
    )


PDO = Obj(
    title="pdo",
    description="The PDO layout written at start-up (PDOs 1..4 not listed are switched off).",
    keys=tuple(Key(f"rpdo{n}", _pdo("rpdo", n, RPDO_OBJECTS)) for n in range(1, 5))
    + tuple(Key(f"tpdo{n}", _pdo("tpdo", n, TPDO_OBJECTS)) for n in range(1, 5)),
    checks=(
        "the layout carries the controlword and target position (RPDOs), the statusword and "
        "position actual value (TPDOs), at most 64 bits per PDO, distinct COB-IDs",
    ),
)
_PAIR = ListOf(
    item=Integer(lo=1, hi=0xFFFFFFFF),
    min_items=2,
    max_items=2,
    description="[numerator, denominator].",
)
SCALING = OneOf(
    description="Drive-side scaling objects: `read` (read back and used), or the values to write.",
    variants=(
        Choice(options=("read",), description="Read 0x608F/0x6091/0x6092/0x607E back."),
        Obj(
            title="scaling",
            keys=(
                Key("encoder_resolution", _PAIR),
                Key("gear_ratio", _PAIR),
                Key("feed_constant", _PAIR),
                Key("polarity", Integer(lo=0, hi=255, description="0x607E polarity.")),
            ),
        ),
    ),
)
HEARTBEAT = Obj(
    title="heartbeat",
    description="CANopen heartbeat.",
    keys=(
        Key(
            "producer",
            Number(
                ge=0.0,
                le=65.535,
                unit="s",
                default_text="0.05 (50 ms; none with `node_guarding`)",
                description="The drive's heartbeat period (0x1017); 0 = none.",
                checks=("exclusive with `node_guarding`",),
            ),
        ),
        Key(
            "consumer",
            Number(
                ge=0.0,
                le=65.535,
                unit="s",
                default_text="0 (off)",
                description="The drive watches the master's heartbeat with this time (0x1016); "
                "0 = off.",
            ),
        ),
    ),
)
GUARDING = Obj(
    title="node_guarding",
    description="CANopen node guarding instead of the drive's heartbeat.",
    keys=(
        Key(
            "guard_time",
            Number(ge=0.001, le=65.535, unit="s", description="Guard time (0x100C)."),
            True,
        ),
        Key(
            "life_time_factor",
            Integer(lo=1, hi=255, default=3, description="Life time factor (0x100D)."),
        ),
    ),
)
_BUS_REF = String(
    description="The bus of the drive (a key of `buses`).",
    checks=("a bus defined under `buses`",),
)
_CPU = Number(
    gt=0.0,
    default=1.0e6,
    description="Drive counts (increments) per unit of the axis (m or rad).",
)
_DRIVE_TYPE = Choice(
    options=("bus",),
    description="`bus` (the default when `bus` is given).",
)
CANOPEN_DRIVE = Obj(
    title="CANopen drive",
    description="A CiA 402 drive on a CAN bus (the bus's `type: can`).",
    keys=(
        Key("type", _DRIVE_TYPE),
        Key("bus", _BUS_REF, True),
        Key(
            "node_id",
            Integer(
                lo=1,
                hi=127,
                description="CANopen node id.",
                checks=("one axis per node id and bus; the axes of a CAN bus run in one task",),
            ),
            True,
        ),
        Key("counts_per_unit", _CPU),
        Key(
            "eds",
            String(
                example="drives/servo.eds",
                description="The drive's EDS/DCF file (relative to the configuration file); "
                "its object dictionary is used for the SDO transfers.",
                checks=("the file exists",),
            ),
        ),
        Key("heartbeat", HEARTBEAT),
        Key("node_guarding", GUARDING),
        Key("pdo", PDO),
        Key("scaling", SCALING),
        Key(
            "mode_timeout",
            Number(
                ge=0.0, le=60.0, unit="s", description="Wait for 0x6061 to show CSP at start-up."
            ),
        ),
        Key(
            "setup_timeout",
            Number(ge=0.001, le=600.0, unit="s", description="Time for the whole start-up."),
        ),
        Key(
            "following_error_window",
            Number(
                gt=0.0,
                le=1e12,
                unit="m or rad",
                default_text="the axis' `following_error`",
                description="Following error window written to 0x6065.",
            ),
        ),
        Key(
            "following_error_timeout",
            Number(ge=0.0, le=65.535, unit="s", description="Following error time-out (0x6066)."),
        ),
        Key(
            "rated_torque",
            Number(
                gt=0.0,
                le=1e9,
                unit="N m or N",
                default_text="read from 0x6076 (mN m) at the first torque read",
                description="The drive's rated torque, the unit of its torque actual value "
                "(MC_ReadActualTorque).",
            ),
        ),
    ),
)
MODBUS_DRIVE = Obj(
    title="Modbus drive",
    description="A drive on a Modbus TCP network (the bus's `type: modbus`).",
    keys=(
        Key("type", _DRIVE_TYPE),
        Key("bus", _BUS_REF, True),
        Key(
            "unit_id",
            Integer(
                lo=1,
                hi=247,
                description="Modbus unit (device) id.",
                checks=("one axis per unit id and bus",),
            ),
            True,
        ),
        Key("counts_per_unit", _CPU),
        Key(
            "word_order",
            Choice(
                options=WORD_ORDERS,
                default_text="the register map's",
                description="Word order of 32-bit values (`big`: high word first).",
            ),
        ),
        Key(
            "register_map",
            OneOf(
                default="motionplc-v1",
                description="The drive's register map: a shipped map's name, a path to a map "
                "file (relative to the configuration file) or an inline map.",
                variants=(
                    String(what="a shipped map's name or a file"),
                    Ref(name="register_map", description="An inline register map."),
                ),
                checks=(
                    "simulated drives speak `motionplc-v1` only",
                    "the file or shipped map exists",
                ),
            ),
        ),
        Key(
            "following_error_window",
            Number(
                gt=0.0,
                unit="m or rad",
                description="Written at setup.",
                checks=("the map has the register and it holds the value",),
            ),
        ),
        Key(
            "following_error_timeout",
            Number(
                gt=0.0,
                unit="s",
                description="Written at setup.",
                checks=("the map has the register and it holds the value",),
            ),
        ),
        Key(
            "watchdog",
            Number(
                ge=0.0,
                unit="s",
                description="The drive's communication watchdog, written at setup; 0 = off.",
                checks=("the map has the register and it holds the value",),
            ),
        ),
        Key(
            "velocity_feed_forward",
            Bool(
                default=False,
                description="Write the velocity setpoint as feed-forward every cycle.",
                checks=("the map has a `target_velocity` register",),
            ),
        ),
        Key(
            "requests_in_flight",
            Integer(
                lo=1,
                hi=16,
                default=1,
                description="Requests of a cycle on the wire at once (1: each after the "
                "previous answer).",
            ),
        ),
        Key(
            "torque_register",
            Integer(
                lo=0,
                hi=0xFFFF,
                default_text="0x0208 with the motionplc-v1 map, else none",
                description="Holding register of the torque actual value (i16, per mille of "
                "`rated_torque`) for MC_ReadActualTorque.",
            ),
        ),
        Key(
            "rated_torque",
            Number(
                gt=0.0,
                le=1e9,
                unit="N m or N",
                default_text="none: MC_ReadActualTorque refuses",
                description="The drive's rated torque, the unit of its torque actual value "
                "(MC_ReadActualTorque).",
            ),
        ),
    ),
)
IDEAL_DRIVE = Obj(
    title="ideal drive",
    description="An in-process perfect follower (no bus): the default.",
    keys=(Key("type", Choice(options=("ideal",), description="An ideal drive.")),),
)
DRIVE = OneOf(
    description="The axis' drive: ideal (no bus), or a drive on a CAN or Modbus bus (the "
    "form follows the type of the bus named by `bus`).",
    variants=(IDEAL_DRIVE, CANOPEN_DRIVE, MODBUS_DRIVE),
    checks=("the bus-specific keys match the type of the bus named by `bus`",),
)
_COMMON_DRIVE_KEYS = ("type", "bus", "counts_per_unit")
CANOPEN_DRIVE_KEYS = {
    k.name: False for k in CANOPEN_DRIVE.keys if k.name not in (*_COMMON_DRIVE_KEYS, "node_id")
}
MODBUS_DRIVE_KEYS = {
    k.name: k.required for k in MODBUS_DRIVE.keys if k.name not in _COMMON_DRIVE_KEYS
}

# ------------------------------------------------------------------------------- axes
LIMITS = Obj(
    title="limits",
    description="Kinematic limits of the axis (the supported range keeps every FB input and "
    "every planned profile inside the planner's envelope).",
    keys=(
        Key(
            "v_max",
            Number(
                ge=LIMIT_LO, le=LIMIT_HI, unit="m/s or rad/s", example=0.5, description="Velocity."
            ),
            True,
        ),
        Key(
            "a_max",
            Number(
                ge=LIMIT_LO,
                le=LIMIT_HI,
                unit="m/s² or rad/s²",
                example=2.0,
                description="Acceleration.",
            ),
            True,
        ),
        Key(
            "j_max",
            Number(
                ge=LIMIT_LO,
                le=LIMIT_HI,
                inf_ok=True,
                default=float("inf"),
                unit="m/s³ or rad/s³",
                description="Jerk; `.inf` = no jerk limit (trapezoidal profiles).",
            ),
        ),
        Key(
            "v_min",
            Number(
                ge=-LIMIT_HI,
                le=-LIMIT_LO,
                unit="m/s or rad/s",
                default_text="-v_max",
                description="Velocity in the negative direction (asymmetric limits).",
            ),
        ),
        Key(
            "a_min",
            Number(
                ge=-LIMIT_HI,
                le=-LIMIT_LO,
                unit="m/s² or rad/s²",
                default_text="-a_max",
                description="Acceleration towards negative (asymmetric limits).",
            ),
        ),
    ),
)
_POS = {"ge": -POSITION_MAX, "le": POSITION_MAX}
SOFTWARE_LIMITS = Obj(
    title="software_limits",
    description="Software limit positions: a target beyond is refused at Execute; moves brake "
    "to stop exactly at a limit.",
    keys=(
        Key("min", Number(**_POS, unit="m or rad", description="Negative limit.")),
        Key(
            "max",
            Number(**_POS, unit="m or rad", description="Positive limit.", checks=("min < max",)),
        ),
    ),
    checks=("not together with `modulo`",),
)
HOMING = Obj(
    title="homing",
    description="What MC_Home does.",
    keys=(
        Key(
            "method",
            Choice(
                options=HOMING_METHODS,
                default="set_position",
                description="`set_position`: MC_Home sets the position; `switch`: move to the "
                "reference switch first.",
            ),
        ),
        Key(
            "switch",
            Number(
                **_POS,
                unit="m or rad",
                description="Position of the reference switch (drive coordinates).",
                checks=("required with method `switch`, refused with `set_position`",),
            ),
        ),
        Key(
            "velocity",
            Number(
                gt=0.0,
                unit="m/s or rad/s",
                description="Velocity of the move to the switch.",
                checks=("method `switch` only",),
            ),
        ),
        Key(
            "drive_method",
            Integer(
                lo=-128,
                hi=127,
                example=17,
                description="The CiA 402 homing method the drive runs (0x6098): 1..37, or a "
                "manufacturer's negative one (the virtual drive: 17..30, 33, 34, 35, 37).",
                checks=("required with method `drive`, refused otherwise", "not 0"),
            ),
        ),
        Key(
            "speed_switch",
            Number(
                gt=0.0,
                le=LIMIT_HI,
                unit="m/s or rad/s",
                description="Speed during the search for the switch (0x6099:01).",
                checks=("required with method `drive`",),
            ),
        ),
        Key(
            "speed_zero",
            Number(
                gt=0.0,
                le=LIMIT_HI,
                unit="m/s or rad/s",
                description="Speed during the search for the zero / the final approach "
                "(0x6099:02).",
                checks=("required with method `drive`",),
            ),
        ),
        Key(
            "acceleration",
            Number(
                gt=0.0,
                le=LIMIT_HI,
                unit="m/s² or rad/s²",
                description="Homing acceleration (0x609A).",
                checks=("required with method `drive`",),
            ),
        ),
        Key(
            "offset",
            Number(
                ge=-POSITION_MAX,
                le=POSITION_MAX,
                default_text="0",
                unit="m or rad",
                description="Home offset (0x607C): the axis position at the home position.",
                checks=("method `drive` only",),
            ),
        ),
        Key(
            "timeout",
            Number(
                gt=0.0,
                le=3600.0,
                default_text="60",
                unit="s",
                description="Homing by the drive that is not attained within this time fails "
                "(HOMING_FAILED).",
                checks=("method `drive` only",),
            ),
        ),
    ),
    checks=("method `drive`: the axis' drive is on a CAN bus",),
)
PROBE_SENSOR = Obj(
    title="probe sensor",
    description="A virtual sensor switching a touch probe input: high on each mark "
    "[m, m + width] (drive coordinates): the `marks` listed and, with `pitch`, one every "
    "`pitch` from `first` on (a registration-mark web).",
    keys=(
        Key(
            "marks",
            ListOf(
                item=Number(ge=-POSITION_MAX, le=POSITION_MAX, unit="m or rad"),
                description="Mark positions.",
            ),
        ),
        Key(
            "width",
            Number(gt=0.0, le=POSITION_MAX, unit="m or rad", description="Width of a mark."),
            True,
        ),
        Key(
            "first",
            Number(
                ge=-POSITION_MAX,
                le=POSITION_MAX,
                unit="m or rad",
                description="First mark of the web.",
                checks=("together with `pitch`",),
            ),
        ),
        Key(
            "pitch",
            Number(
                gt=0.0,
                le=POSITION_MAX,
                unit="m or rad",
                description="Distance of the web's marks.",
                checks=("together with `first`", "> width"),
            ),
        ),
    ),
)
TORQUE_MODEL = Obj(
    title="torque model",
    description="The torque an in-process ideal drive reports (MC_ReadActualTorque): inertia "
    "x actual acceleration + Coulomb friction x sign(v) + viscous friction x v.",
    keys=(
        Key(
            "inertia",
            Number(ge=0.0, le=1e12, unit="kg m² or kg", description="Moved inertia (mass)."),
            True,
        ),
        Key(
            "coulomb",
            Number(
                ge=0.0, le=1e12, default_text="0", unit="N m or N", description="Coulomb friction."
            ),
        ),
        Key(
            "viscous",
            Number(
                ge=0.0,
                le=1e12,
                default_text="0",
                unit="N m s/rad or N s/m",
                description="Viscous friction coefficient.",
            ),
        ),
    ),
)
SIMULATION = Obj(
    title="simulation",
    description="Wiring of an in-process drive (ideal, or a simulated bus's virtual CiA 402 "
    "drive), in drive coordinates: touch probe sensors and (virtual CiA 402 drive) the "
    "limit switches, home switch and encoder index pulse its homing methods use.",
    keys=(
        Key("probe1", PROBE_SENSOR),
        Key("probe2", PROBE_SENSOR),
        Key("torque", TORQUE_MODEL),
        Key(
            "negative_limit",
            Number(
                ge=-POSITION_MAX,
                le=POSITION_MAX,
                unit="m or rad",
                description="Negative limit switch: active at and below this position.",
                checks=("a virtual CiA 402 drive",),
            ),
        ),
        Key(
            "positive_limit",
            Number(
                ge=-POSITION_MAX,
                le=POSITION_MAX,
                unit="m or rad",
                description="Positive limit switch: active at and above this position.",
                checks=("a virtual CiA 402 drive", "> negative_limit"),
            ),
        ),
        Key(
            "home_switch",
            ListOf(
                item=Number(ge=-POSITION_MAX, le=POSITION_MAX, unit="m or rad", inf_ok=True),
                min_items=2,
                max_items=2,
                description="Home switch active on [lo, hi] (.inf / -.inf for a switch active "
                "on a whole side, methods 19..22).",
            ),
        ),
        Key(
            "index_pitch",
            Number(
                gt=0.0,
                le=POSITION_MAX,
                unit="m or rad",
                description="Encoder index pulse every `index_pitch` (from `index_offset`).",
            ),
        ),
        Key(
            "index_offset",
            Number(
                ge=-POSITION_MAX,
                le=POSITION_MAX,
                default_text="0",
                unit="m or rad",
                description="Position of an index pulse.",
            ),
        ),
    ),
    checks=("an ideal drive or one on a bus with `drives: simulated` (CAN)",),
)
AXIS = Obj(
    title="axis",
    description="A servo axis: limits, drive and options.",
    keys=(
        Key("units", Choice(options=UNITS, default="m", description="Linear (m) or rotary (rad).")),
        Key(
            "task",
            String(
                default_text="the first task",
                description="The task the axis runs in.",
                checks=("a task of `runtime.tasks`",),
            ),
        ),
        Key("limits", LIMITS, True),
        Key("software_limits", SOFTWARE_LIMITS),
        Key(
            "modulo",
            Number(
                gt=0.0,
                unit="m or rad",
                example=6.283185307179586,
                description="Modulo (rotary) axis: positions wrap at this value.",
            ),
        ),
        Key(
            "following_error",
            Number(
                gt=0.0,
                unit="m or rad",
                description="Following error limit: beyond it the axis goes to ErrorStop.",
            ),
        ),
        Key("homing", HOMING),
        Key(
            "drive",
            DRIVE,
        ),
        Key("simulation", SIMULATION),
        Key(
            "queue_depth",
            Integer(
                lo=0,
                hi=64,
                default=8,
                description="Moves that may wait (buffered or blending) behind the running one.",
            ),
        ),
        Key(
            "jog_velocity_slow",
            Number(
                gt=0.0,
                unit="m/s or rad/s",
                default_text="10 % of the speed limit of the jog direction",
                description="MC_Jog's speed in mode STANDARD_SLOW.",
                checks=("<= the lower of `limits.v_max` and `-limits.v_min`",),
            ),
        ),
        Key(
            "jog_velocity_fast",
            Number(
                gt=0.0,
                unit="m/s or rad/s",
                default_text="50 % of the speed limit of the jog direction",
                description="MC_Jog's speed in mode STANDARD_FAST.",
                checks=("<= the lower of `limits.v_max` and `-limits.v_min`",),
            ),
        ),
    ),
)

# ------------------------------------------------------------------------------- groups
GROUP = Obj(
    title="group",
    description="An axes group with options (PLCopen Part 4 GroupConfig).",
    keys=(
        Key(
            "axes",
            ListOf(
                item=String(pattern=NAME_PATTERN, description="An axis name."),
                min_items=1,
                description="The member axes in group order (X, Y, Z).",
                checks=(
                    "distinct known axes, none in another group, none modulo, all in one task",
                ),
            ),
            True,
        ),
        Key(
            "queue_depth",
            Integer(
                lo=1,
                hi=10_000,
                default=64,
                description="Moves waiting behind the running one (the look-ahead window).",
            ),
        ),
        Key(
            "tolerance",
            Number(
                gt=0.0,
                le=1.0,
                default=1e-4,
                unit="m",
                description="Corner deviation of G64 without P and of TM_MAX_CORNER_DEVIATION "
                "with parameter 0.",
            ),
        ),
        Key(
            "v_share",
            Number(
                ge=0.01,
                le=0.99,
                default=0.7,
                description="Share of the axes' acceleration and jerk budget the curvature of "
                "paths may use.",
            ),
        ),
        Key(
            "blend_share",
            Number(
                ge=0.01,
                le=0.99,
                default=0.95,
                description="Share of the budget corner blends may use.",
            ),
        ),
    ),
)
GROUP_ENTRY = OneOf(
    description="The member axes as a list (`xy: [x, y]`), or a mapping with options.",
    variants=(
        ListOf(
            item=String(pattern=NAME_PATTERN, description="An axis name."),
            min_items=1,
            description="The member axes in group order (X, Y, Z).",
            checks=("distinct known axes, none in another group, none modulo, all in one task",),
        ),
        GROUP,
    ),
    checks=("a group cannot have the name of an axis",),
)

# ------------------------------------------------------------------------------- cams
# the motion laws and ranges of motionplc.planning.cam (LAWS, COORD_MAX, SLOPE_MAX,
# CURVATURE_MAX; a test keeps them equal; literals so that the schema does not import numpy)
CAM_LAWS = (
    "cycloid",
    "harmonic",
    "linear",
    "modified_sine",
    "modified_trapezoid",
    "poly5",
    "poly7",
)
CAM_COORD_MAX = 1e12
CAM_SLOPE_MAX = 1e9
CAM_CURVATURE_MAX = 1e15
_CAM_RULES = (
    "at least 2 points, master strictly increasing (segments at least 1e-9 long)",
    "a slope a segment's law cannot meet is refused (a rest-to-rest law next to a non-zero "
    "slope, two linear segments of different slopes, an explicit slope against a linear "
    "segment): use poly5 or poly7 there",
)
_CAM_MASTER = Number(
    ge=-CAM_COORD_MAX, le=CAM_COORD_MAX, description="The master position (m or rad)."
)
_CAM_SLAVE = Number(ge=-CAM_COORD_MAX, le=CAM_COORD_MAX, description="The slave position.")
_CAM_SLOPE = Number(
    ge=-CAM_SLOPE_MAX,
    le=CAM_SLOPE_MAX,
    default_text="from a neighbouring linear or rest-to-rest segment, else 0",
    description="dy/dx at the point (slave units per master unit).",
)
_CAM_CURVATURE = Number(
    ge=-CAM_CURVATURE_MAX,
    le=CAM_CURVATURE_MAX,
    default_text="from a neighbouring linear or rest-to-rest segment, else 0",
    description="d2y/dx2 at the point.",
)
CAM_POINT = OneOf(
    description="A point: `[master, slave]`, `[master, slave, slope]`, "
    "`[master, slave, slope, curvature]` or a mapping (which may also name the law of the "
    "segment starting at the point).",
    variants=(
        ListOf(
            item=Number(ge=-CAM_COORD_MAX, le=CAM_COORD_MAX),
            min_items=2,
            max_items=4,
            description="master, slave[, slope[, curvature]].",
        ),
        Obj(
            title="cam point",
            description="A point with names.",
            keys=(
                Key("master", _CAM_MASTER, True),
                Key("slave", _CAM_SLAVE, True),
                Key("slope", _CAM_SLOPE),
                Key("curvature", _CAM_CURVATURE),
                Key(
                    "law",
                    Choice(
                        options=CAM_LAWS,
                        default_text="the cam's `law`",
                        description="The motion law of the segment from this point to the next.",
                    ),
                ),
            ),
        ),
    ),
)
CAM = Obj(
    title="cam",
    description="A cam table master -> slave (`motionplc.planning.CamTable`): points joined by "
    "VDI 2143 motion laws; C2 (continuous slave acceleration at constant master speed) "
    "wherever the laws allow. Given inline (`points`) or as a CSV file (`file`).",
    keys=(
        Key(
            "points",
            ListOf(
                item=CAM_POINT,
                min_items=2,
                description="The points in master order.",
                checks=_CAM_RULES,
            ),
        ),
        Key(
            "file",
            String(
                what="a file",
                description="A CSV file of points, relative to the configuration file: one "
                "point a line, `master, slave[, slope[, curvature[, law]]]` (an empty field: "
                "not given), `#` comments and a header line allowed.",
            ),
        ),
        Key(
            "law",
            Choice(
                options=CAM_LAWS,
                default_text="`poly5`",
                description="The motion law of every segment whose point names none: "
                "`poly5`/`poly7` (3-4-5 / 4-5-6-7 polynomials; Hermite polynomials meeting "
                "non-zero end slopes and curvatures), `modified_sine`, `modified_trapezoid`, "
                "`cycloid`, `harmonic` (rest to rest; harmonic's acceleration jumps at its "
                "ends), `linear` (constant velocity).",
            ),
        ),
        Key(
            "periodic",
            Bool(
                default_text="`false`",
                description="The first and last point are one point of a repeating profile: "
                "their slope and curvature are resolved together, so the table repeats "
                "without a step (a lift `slave_end - slave_start` is allowed).",
            ),
        ),
        Key(
            "smooth",
            Bool(
                default_text="`false`",
                description="Interior points without a slope or curvature between two "
                "poly5/poly7 segments get those of the C2 cubic spline through the points "
                "(clamped to the nearest other points) instead of stopping there: for point "
                "lists measured or taken from a drawing.",
            ),
        ),
    ),
    checks=("exactly one of `points` and `file`",),
)

TOP = Obj(
    title="machine configuration",
    keys=(
        Key("runtime", RUNTIME, True),
        Key(
            "buses",
            MapOf(value=BUS, description="The buses by name.", example={"can0": {"type": "can"}}),
        ),
        Key(
            "axes",
            MapOf(value=AXIS, min_items=1, description="The axes by name (at least one)."),
            True,
        ),
        Key(
            "groups",
            MapOf(value=GROUP_ENTRY, description="Axes groups by name (PLCopen Part 4)."),
        ),
        Key(
            "cams",
            MapOf(
                value=CAM,
                description="Cam tables by name (`Machine.cams`; for MC_CamTableSelect).",
            ),
        ),
        Key("gcode", GCODE),
        Key("opcua", OPCUA),
        Key("hmi", HMI),
    ),
)

EXAMPLE = """\
runtime:
  tick: 0.001
  clock: simulated             # simulated | realtime
  tasks:
    motion: {period: 0.002, priority: 1}
  realtime: {priority: 80, cpus: [2], lock_memory: true}   # used on the real-time clock
buses:
  can0: {type: can, interface: virtual, channel: demo}
  mb0: {type: modbus, host: 127.0.0.1, port: 0}
axes:
  x:
    limits: {v_max: 1.0, a_max: 4.0, j_max: 40.0}
    software_limits: {min: 0.0, max: 1.2}
    following_error: 0.005
    drive: {bus: can0, node_id: 1, counts_per_unit: 1.0e6}
  y:
    limits: {v_max: 0.8, a_max: 3.0, j_max: 30.0}
    drive: {bus: mb0, unit_id: 1, word_order: big}
groups:
  xy: [x, y]
cams:
  lift:                        # master x -> slave y, VDI 2143 motion laws
    law: poly5
    points: [[0.0, 0.0], [0.5, 0.1], {master: 1.0, slave: 0.1, law: modified_sine}, [1.5, 0.0]]
"""

CONFIG = FileSchema(
    kind="config",
    title="Machine configuration",
    root=TOP,
    intro="A machine configuration describes the runtime (base tick, clock, tasks, real-time "
    "settings), the buses (CAN, Modbus TCP), the axes (limits, software limits, modulo, "
    "following error, homing, drive), the axes groups and cam tables. `motionplc validate "
    "CONFIG` checks "
    "a file; every problem is reported as `FILE:LINE: key.path: problem (allowed: ...)`. "
    "Units are SI (m or rad, s). Floats such as `1e-6` are read as numbers.",
    example=EXAMPLE,
    defs={"register_map": REGISTER_MAP.root},
    pages={"register_map": "register_map.md"},
)
