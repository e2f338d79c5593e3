"""The campaign file: a machine configuration, a program, and the axes of variation (parameter
grids, seeded random draws, fault injections) of a scenario campaign
(:mod:`motionplc.campaign`, ``motionplc campaign CAMPAIGN.yaml``)."""

from __future__ import annotations

from motionplc.schema.nodes import (
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
    Scalar,
    String,
)

PATH_PATTERN = r"^(config|program|plant|faults)(\.[A-Za-z0-9_]+|\[[0-9]+\])+$"
"""A parameter path: ``config.axes.x.limits.a_max``, ``program.steps[1].call[0].velocity``
(or ``program.SPEED`` of a Python program), ``plant.x.kp``, ``faults[0].at``."""

PLANT_PARAMS = (
    "kp",
    "kff",
    "tau_v",
    "v_max",
    "a_max",
    "coulomb",
    "viscous",
    "load",
    "tau_coast",
)
"""The virtual drive's plant parameters a campaign may vary (``plant.<axis>.<name>``)."""

FAULT_KINDS = (
    "drive",
    "feedback_loss",
    "setpoint_loss",
    "sync_loss",
    "bus_off",
    "load_step",
)

DISTRIBUTION = Obj(
    title="Distribution",
    description="A seeded random draw (exactly one of the forms; `clip` only with `normal`).",
    keys=(
        Key(
            "uniform",
            ListOf(
                item=Number(), min_items=2, max_items=2, description="[lo, hi]: uniform in lo..hi."
            ),
        ),
        Key(
            "loguniform",
            ListOf(
                item=Number(gt=0),
                min_items=2,
                max_items=2,
                description="[lo, hi] (both > 0): uniform in log(lo)..log(hi).",
            ),
        ),
        Key(
            "normal",
            ListOf(
                item=Number(), min_items=2, max_items=2, description="[mean, standard deviation]."
            ),
        ),
        Key(
            "clip",
            ListOf(
                item=Number(),
                min_items=2,
                max_items=2,
                description="[lo, hi]: a normal draw is clipped to lo..hi (both are validated "
                "against the configuration).",
            ),
        ),
        Key(
            "integers",
            ListOf(
                item=Integer(),
                min_items=2,
                max_items=2,
                description="[lo, hi]: an integer in lo..hi (both included).",
            ),
        ),
        Key(
            "choice",
            ListOf(item=Scalar(), min_items=1, max_items=10000, description="One of the values."),
        ),
    ),
    checks=(
        "exactly one of uniform, loguniform, normal, integers, choice",
        "lo <= hi (uniform, loguniform, integers, clip); standard deviation >= 0",
    ),
)

FAULT = Obj(
    title="Fault injection",
    description="One fault injected into the virtual drives or buses at a simulated time. Each "
    "field may be a value or a distribution; grid and random paths `faults[i].field` vary it "
    "too.",
    keys=(
        Key(
            "fault",
            Choice(
                options=FAULT_KINDS,
                description="`drive`: a drive fault (FAULT REACTION -> FAULT, EMCY, 0x603F); "
                "`feedback_loss`: the drive's TPDOs are lost; `setpoint_loss`: the drive "
                "receives no RPDO (RPDO time-out); `sync_loss`: the master sends no SYNC; "
                "`bus_off`: the drives' CAN endpoint goes bus-off; `load_step`: the plant's "
                "load changes to `value` [axis unit/s²]. Only `drive` on a Modbus bus with "
                "simulated drives; none on an ideal drive.",
            ),
            required=True,
        ),
        Key(
            "axis",
            OneOf(
                variants=(String(what="an axis"), DISTRIBUTION),
                description="The axis whose drive (or bus) gets the fault, or a distribution "
                "(`choice`) of axes.",
            ),
            required=True,
        ),
        Key(
            "at",
            OneOf(
                variants=(Number(ge=0), DISTRIBUTION),
                unit="s",
                description="Simulated time of the injection (a number >= 0 or a distribution).",
            ),
            required=True,
        ),
        Key(
            "duration",
            OneOf(
                variants=(Number(gt=0), DISTRIBUTION),
                unit="s",
                default_text="to the end of the run",
                description="How long a loss, a SYNC loss or a bus-off lasts.",
            ),
        ),
        Key(
            "code",
            OneOf(
                variants=(Integer(lo=1, hi=0xFFFF), DISTRIBUTION),
                default_text="0x1000 (generic error)",
                description="The CiA 301 error code of a `drive` fault.",
            ),
        ),
        Key(
            "persistent",
            Bool(
                default_text="false",
                description="A `drive` fault stays present (a reset fails) to the end of the run.",
            ),
        ),
        Key(
            "value",
            OneOf(
                variants=(Number(), DISTRIBUTION),
                description="The new load of a `load_step` [axis unit/s²].",
            ),
        ),
        Key(
            "probability",
            Number(
                ge=0,
                le=1,
                default=1.0,
                description="The chance that a scenario has this fault (a seeded draw).",
            ),
        ),
    ),
    checks=(
        "axis names an axis of the configuration on a drive that supports the fault",
        "code only with drive, value (required) only with load_step",
    ),
)

EXECUTION = Obj(
    title="Execution",
    description="Where and how the scenarios run (the command line overrides each key).",
    keys=(
        Key(
            "scheduler",
            String(
                pattern=r"^tcp://(127\.0\.0\.1|localhost|\[::1\]):[0-9]{1,5}$",
                what="a loopback scheduler address",
                description="An existing Dask scheduler (`dask scheduler --host 127.0.0.1`); "
                "absent: a LocalCluster of processes on 127.0.0.1.",
                example="tcp://127.0.0.1:8786",
            ),
        ),
        Key(
            "workers",
            Integer(
                lo=0,
                hi=256,
                default_text="the number of cores",
                description="Worker processes of the LocalCluster (one thread each); 0: run "
                "serially in this process, without Dask.",
            ),
        ),
        Key(
            "batch",
            Integer(
                lo=1,
                hi=10000,
                default_text="scenarios / (8 x workers), 1..50",
                description="Scenarios per Dask task.",
            ),
        ),
        Key(
            "output",
            String(
                what="a directory",
                default_text="out/campaigns/<name> (relative to the working directory)",
                description="Where the results (Parquet, one file per finished task), the "
                "report and the traces go; relative to the working directory.",
            ),
        ),
        Key(
            "trace",
            Bool(
                default_text="false",
                description="Keep each scenario's trace (Parquet) under `<output>/traces/`.",
            ),
        ),
    ),
)

VERDICT = Obj(
    title="Verdict",
    description="What a scenario must show to pass.",
    keys=(
        Key(
            "program",
            Choice(
                options=("required", "unless_fault", "ignored"),
                default="required",
                description="The program's expectations: must hold (`required`), must hold "
                "in the scenarios without an injected fault (`unless_fault`, a fault Monte "
                "Carlo), are not judged (`ignored`).",
            ),
        ),
        Key(
            "reaction_time",
            Number(
                gt=0,
                unit="s",
                description="An injected fault (not `load_step`) must bring its axis to "
                "ErrorStop within this time (absent: it must be detected at all).",
            ),
        ),
        Key(
            "max_following_error",
            Number(
                gt=0,
                unit="m or rad",
                description="The largest following error allowed on any axis (absent: not "
                "judged beyond the axes' own limits).",
            ),
        ),
    ),
)

TOP = Obj(
    title="Campaign",
    keys=(
        Key(
            "name",
            String(
                pattern=r"^[A-Za-z0-9_.-]+$",
                what="a name",
                default_text="the file's stem",
                description="The campaign's name.",
            ),
        ),
        Key(
            "config",
            String(what="a file", description="The machine configuration (relative to this file)."),
            required=True,
        ),
        Key(
            "program",
            String(
                what="a file",
                description="The program: a sequence (.yaml), a Python program (.py) or a "
                "G-code file (relative to this file); absent: the machine runs `seconds`.",
            ),
        ),
        Key("group", String(what="a group", description="The axes group of a G-code program.")),
        Key(
            "seed",
            Integer(lo=0, hi=2**63 - 1, default=0, description="The seed of every random draw."),
        ),
        Key(
            "draws",
            Integer(
                lo=1,
                hi=1_000_000,
                default=1,
                description="Random draws per grid point (scenarios = grid points x draws).",
            ),
        ),
        Key(
            "seconds",
            Number(
                gt=0,
                unit="s",
                default_text="the program's timeout (1 s without a program)",
                description="Simulated time limit of a scenario.",
            ),
        ),
        Key(
            "timeout",
            Number(
                gt=0,
                unit="s",
                default=300.0,
                description="Wall-clock limit of a scenario: beyond it the scenario is a "
                "`timeout` result.",
            ),
        ),
        Key(
            "grid",
            MapOf(
                key=String(pattern=PATH_PATTERN, what="a parameter path"),
                value=ListOf(item=Scalar(), min_items=1, max_items=100000),
                description="Parameter path -> the values of a grid axis (the scenarios run "
                "the Cartesian product, the last path fastest).",
                example={"config.axes.x.limits.a_max": [1.0, 1.5, 2.0]},
            ),
        ),
        Key(
            "random",
            MapOf(
                key=String(pattern=PATH_PATTERN, what="a parameter path"),
                value=DISTRIBUTION,
                description="Parameter path -> a distribution, drawn per scenario from the "
                "seed and the scenario's number (independent of the order the scenarios run).",
                example={"plant.y.kp": {"uniform": [60, 150]}},
            ),
        ),
        Key(
            "faults",
            ListOf(item=FAULT, max_items=64, description="Fault injections of each scenario."),
        ),
        Key("verdict", VERDICT),
        Key("execution", EXECUTION),
    ),
    checks=(
        "config.* paths name a value of the configuration (the last key may be new), "
        "program.* a value of the sequence or a module constant of a Python program",
        "every grid value and the bounds of every distribution are accepted by the "
        "configuration's or the sequence's validator",
        "plant.<axis>.<name>: an axis on a simulated CiA 402 drive (CAN or Modbus), name one "
        "of " + ", ".join(PLANT_PARAMS) + " (motionplc.fieldbus.plant.PlantParams; v_max, "
        "a_max, coulomb and load in the axis' units per s, s² - scaled by counts_per_unit - "
        "kp in 1/s, tau_v and tau_coast in s, kff and viscous as they are)",
        "grid points x draws <= 1,000,000",
    ),
)

EXAMPLE = """\
# a fault Monte Carlo on the demo machine
config: ../demo.yaml
program: ../demo_sequence.yaml
seed: 29
draws: 100
grid:
  config.axes.x.limits.a_max: [1.5, 2.0]
random:
  plant.y.kp: {uniform: [60, 150]}
faults:
  - {fault: drive, axis: {choice: [x, y]}, at: {uniform: [0.1, 4.0]}, code: 0x2310,
     probability: 0.8}
verdict: {program: unless_fault, reaction_time: 0.01}
"""

CAMPAIGN = FileSchema(
    kind="campaign",
    title="Scenario campaign",
    root=TOP,
    intro="A campaign runs one machine configuration and program many times on the simulated "
    "clock, each run (a scenario) with its own values: the Cartesian product of `grid`, times "
    "`draws` seeded random draws of `random` and of the fault fields. `motionplc campaign "
    "FILE` runs it on Dask (a LocalCluster, or a scheduler by address), keeps each result in "
    "Parquet as it arrives (an interrupted campaign resumes) and writes a report.",
    example=EXAMPLE,
)
