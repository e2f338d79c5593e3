"""The ``motionplc`` command line.

``motionplc run CONFIG [SEQUENCE|PROGRAM|GCODE] [--group NAME]``, ``validate``, ``plot``,
``drives``, ``plan``. Exit codes: 0 success, 1 the run failed (an expectation, an FB or axis
error, a timeout), 2 invalid input (configuration, sequence, program or G-code errors: one line
each, ``FILE:LINE: key.path: problem (allowed: ...)`` or ``FILE:LINE: WORD: ...``).

A G-code program (``.ngc``, ``.nc``, ``.gcode``, ``.tap``) runs on the configured axes group
(the only one, or ``--group NAME``) through :class:`motionplc.gcode_runner.GcodeRunner`; every
move it cannot run is reported before the first cycle. ``--trace`` also writes the groups
sidecar (``TRACE.groups.json``) that ``motionplc plot`` reads.

A failed run prints one ``FAILED:`` line per failure on stderr; an FB that failed because its
axis went to ErrorStop names the axis' error, code and reason (``... failed with
AXIS_ERROR_STOP (0x4000) at t = 0.672 s in step 'move_z' (line 5): axis 'z':
COMMUNICATION_LOST (0x4004): receive: Connection reset by peer``). The log of the fieldbus
libraries (pymodbus, canopen, python-can) is quiet unless ``run``/``drives`` get ``-v``
(warnings and errors) or ``-vv`` (debug); see :func:`log_routing`.
"""

from __future__ import annotations

import argparse
import csv
import logging
import math
import sys
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from pathlib import Path
from typing import Any

from motionplc.errors import MotionPlcError, ProgramError
from motionplc.planning import Limits, State, plan

LIBRARY_LOGGERS = ("pymodbus", "canopen", "can")
"""Loggers of the fieldbus libraries, routed through the CLI's handler (see :func:`log_routing`)."""


def _float(text: str) -> float:
    return float(text)


@contextmanager
def log_routing(verbose: int) -> Iterator[None]:
    """Route the log records of motionplc and the fieldbus libraries for one command.

    One non-blocking, rate-limited stderr handler (``drives_main.guarded_logging``) on the root
    logger receives them. ``verbose`` 0 (default): motionplc's warnings only; pymodbus, canopen
    and python-can are silent (what goes wrong on a bus reaches the user as the axis error and
    its reason in the FAILED line). 1 (``-v``): also the libraries' warnings and errors and
    motionplc's info. 2 (``-vv``): everything at debug level, not rate-limited. The previous
    logger levels are restored afterwards.
    """
    from motionplc.fieldbus.drives_main import guarded_logging

    if verbose <= 0:
        own, lib = logging.WARNING, logging.CRITICAL + 1
    elif verbose == 1:
        own, lib = logging.INFO, logging.WARNING
    else:
        own, lib = logging.DEBUG, logging.DEBUG
    levels = {"motionplc": own, **dict.fromkeys(LIBRARY_LOGGERS, lib)}
    saved = {name: logging.getLogger(name).level for name in levels}
    with guarded_logging(interval=0.0 if verbose >= 2 else 1.0) as handler:
        handler_level = handler.level
        handler.setLevel(min(own, lib))
        for name, level in levels.items():
            logging.getLogger(name).setLevel(level)
        try:
            yield
        finally:
            for name, level in saved.items():
                logging.getLogger(name).setLevel(level)
            handler.setLevel(handler_level)


def _cmd_plan(args: argparse.Namespace) -> int:
    lim = Limits(
        v_max=args.v_max,
        a_max=args.a_max,
        j_max=args.j_max,
        v_min=args.v_min,
        a_min=args.a_min,
    )
    start = State(args.p0, args.v0, args.a0)
    target = State(args.pf, args.vf, args.af)
    prof = plan(start, target, lim)
    print(f"start  {start}")
    print(f"target {target}")
    print(f"limits {lim}")
    print(f"profile family: {prof.kind}; duration {prof.duration:.9f} s")
    print(
        f"{'phase':>5} {'t_start [s]':>12} {'duration [s]':>13} {'jerk':>10} "
        f"{'p':>12} {'v':>10} {'a':>10}"
    )
    for i, (k, seg) in enumerate(zip(prof.knots, prof.segments, strict=True)):
        print(
            f"{i + 1:>5} {k.t:>12.6f} {seg.duration:>13.6f} {seg.jerk:>10.4g} "
            f"{k.p:>12.6f} {k.v:>10.5f} {k.a:>10.5f}"
        )
    e = prof.end
    print(
        f"{'end':>5} {prof.duration:>12.6f} {'':>13} {'':>10} "
        f"{e.p:>12.6f} {e.v:>10.5f} {e.a:>10.5f}"
    )
    n = max(2, int(math.ceil(prof.duration / args.dt)) + 1)
    ts = [min(i * args.dt, prof.duration) for i in range(n)]
    s = prof.sample(ts)
    if args.csv:
        path = Path(args.csv)
        path.parent.mkdir(parents=True, exist_ok=True)
        with path.open("w", newline="") as fh:
            w = csv.writer(fh)
            w.writerow(["t", "p", "v", "a", "j"])
            for row in zip(ts, s.p, s.v, s.a, s.j, strict=True):
                w.writerow([f"{x:.12g}" for x in row])
        print(f"wrote {path} ({n} samples at dt={args.dt} s)")
    if args.plot:
        try:
            import matplotlib

            matplotlib.use("Agg")
            import matplotlib.pyplot as plt
        except ImportError:
            print("--plot needs matplotlib: pip install 'motionplc[plot]'", file=sys.stderr)
            return 2
        fig, axes = plt.subplots(4, 1, sharex=True, figsize=(8, 8))
        for ax, ys, label in zip(
            axes,
            (s.p, s.v, s.a, s.j),
            ("position", "velocity", "acceleration", "jerk"),
            strict=True,
        ):
            ax.plot(ts, ys, drawstyle="steps-post" if label == "jerk" else "default")
            ax.set_ylabel(label)
            ax.grid(True, alpha=0.3)
        axes[-1].set_xlabel("time [s]")
        fig.suptitle(f"{prof.kind}: {start} -> {target}, T = {prof.duration:.4f} s", fontsize=9)
        fig.tight_layout()
        path = Path(args.plot)
        path.parent.mkdir(parents=True, exist_ok=True)
        fig.savefig(path, dpi=100)
        print(f"wrote {path}")
    return 0


# ---------------------------------------------------------------------------- run / validate
def _load_script(path: str, config: Any, group: str | None = None) -> Any:
    """Validate a sequence, load a program or parse a G-code file before anything is built."""
    from motionplc.gcode_runner import is_gcode, load_gcode_job

    if is_gcode(path):
        return load_gcode_job(path, config, group)
    if group is not None:
        raise MotionPlcError(f"{path}: --group: only for G-code programs (.ngc, .nc, ...)")
    if Path(path).suffix == ".py":
        from motionplc.program import load_program

        return load_program(path)
    from motionplc.sequence import load_sequence

    return load_sequence(path, config)


def _cmd_validate(args: argparse.Namespace) -> int:
    from motionplc.config import load_config

    cfg = load_config(args.config)
    tasks = ", ".join(f"{t.name} {t.period * 1e3:g} ms" for t in cfg.runtime.tasks)
    print(
        f"{args.config}: ok - {len(cfg.axes)} axes ({', '.join(a.name for a in cfg.axes)}), "
        f"{len(cfg.buses)} buses, tasks: {tasks}"
    )
    if args.script:
        script = _load_script(args.script, cfg, args.group)
        if hasattr(script, "program") and hasattr(script, "group"):  # a G-code job
            from motionplc.gcode_runner import group_moves

            spec = cfg.group(script.group)
            limits = [(cfg.axis(a).sw_limit_min, cfg.axis(a).sw_limit_max) for a in spec.axes]
            moves = group_moves(script.program, [0.0] * len(spec.axes), limits)
            print(
                f"{args.script}: ok - {len(script.program)} motion lines, {len(moves)} group "
                f"moves from the origin on group {script.group!r} ({', '.join(spec.axes)})"
            )
        elif hasattr(script, "steps"):
            print(
                f"{args.script}: ok - {len(script.steps)} steps, {len(script.blocks)} blocks, "
                f"task {script.task}"
            )
        else:
            print(f"{args.script}: ok - program(ctx)")
    return 0


def _summary(machine: Any, runner: Any) -> list[str]:
    """Per-axis table and task statistics."""
    import numpy as np

    rt = machine.runtime
    done: dict[str, int] = {}
    for ev in rt.trace.events:
        if ev.output == "done" and ev.value:
            ax = ev.fb.split(".", 1)[0]
            done[ax] = done.get(ax, 0) + 1
    lines = [
        f"{'axis':<10} {'moves done':>10} {'final state':<20} {'position':>14} "
        f"{'actual':>14} {'max |f.err|':>12}"
    ]
    for name, ax in machine.axes.items():
        try:
            fe = rt.trace.column(f"{name}.following_error")
            max_fe = float(np.max(np.abs(fe))) if fe.size else 0.0
        except KeyError:
            max_fe = float("nan")
        lines.append(
            f"{name:<10} {done.get(name, 0):>10} {ax.state.name:<20} {ax.position:>14.9g} "
            f"{ax.actual_position:>14.9g} {max_fe:>12.3g}"
        )
    warned = [(name, ax) for name, ax in machine.axes.items() if ax.warnings_seen]
    if warned:
        lines.append("")
        for name, ax in warned:
            t, text = ax.warnings_seen[-1]
            more = len(ax.warnings_seen) - 1
            also = f" (and {more} earlier)" if more else ""
            now = "active" if ax.drive_warning else "gone"
            lines.append(f"drive warning {name}: {text} at t = {t:.3f} s, {now}{also}")
    groups = getattr(machine, "axes_groups", {})
    if groups:
        lines.append("")
        lines.append(f"{'group':<10} {'axes':<20} {'moves done':>10} {'final state':<20}")
        for name, g in groups.items():
            lines.append(
                f"{name:<10} {','.join(g.axis_names):<20} {done.get(name, 0):>10} "
                f"{g.state.name:<20}"
            )
    lines.append("")
    lines.append(
        f"{'task':<10} {'cycles':>10} {'exec mean':>10} {'exec max':>10} "
        f"{'late p99':>10} {'late max':>10} {'overruns':>9} {'omitted':>8}"
    )
    for st in rt.stats().values():
        lines.append(
            f"{st.name:<10} {st.cycle_count:>10} {st.exec_mean * 1e6:>8.1f}us "
            f"{st.exec_max * 1e6:>8.1f}us {st.lateness_p99 * 1e6:>8.1f}us "
            f"{st.lateness_max * 1e6:>8.1f}us {st.overruns:>9} {st.omitted_cycles:>8}"
        )
    return lines


def _cmd_run(args: argparse.Namespace) -> int:
    from motionplc.blocks import AxisState
    from motionplc.config import build, load_config
    from motionplc.sequence import axis_error_text

    cfg = load_config(args.config)
    if args.group is not None and not args.script:
        print("motionplc: error: --group needs a G-code program", file=sys.stderr)
        return 2
    script = _load_script(args.script, cfg, args.group) if args.script else None
    if args.seconds is not None and not args.seconds > 0:
        print("motionplc: error: --seconds must be > 0", file=sys.stderr)
        return 2
    machine = build(cfg, realtime=True if args.realtime else None)
    failures: list[str] = []
    try:
        runner = None
        if script is not None:
            if hasattr(script, "program") and hasattr(script, "group"):  # a G-code job
                from motionplc.gcode_runner import GcodeRunner

                runner = GcodeRunner(script, machine)  # unrunnable moves: GcodeError here
                task = script.task
            elif hasattr(script, "steps"):
                from motionplc.sequence import SequenceRunner

                runner = SequenceRunner(script, machine)
                task = script.task
            else:
                from motionplc.program import ProgramRunner

                runner = ProgramRunner(script, machine)
                task = script.task or cfg.runtime.tasks[0].name
            machine.attach(runner, task)
        rt = machine.runtime
        limit = args.seconds
        if limit is None:
            limit = 1.0 if runner is None else getattr(script, "timeout", 600.0) + rt.cycle
        mode = "real time" if rt.clock.realtime else "simulated time"
        if not args.quiet:
            what = f" with {args.script}" if args.script else ""
            print(f"running {args.config}{what} ({mode}, tick {rt.cycle * 1e3:g} ms)")
        program_error = ""
        report = [5.0]  # next progress line [s]
        stop_on = None if runner is None else ("over" if args.seconds is None else "failed")

        def stop_now() -> bool:
            # one run, no slices: a slice boundary is housekeeping between cycles, a gap on
            # the bus in real time; called after every tick, so it only reads flags
            if stop_on is not None and getattr(runner, stop_on):
                return True
            if rt.time >= report[0] - 1e-9:
                report[0] += 5.0
                if not args.quiet:
                    print(f"  t = {rt.time:7.1f} s", file=sys.stderr, flush=True)
            return False

        try:
            if rt.time < limit - 1e-9:
                rt.run_until(stop_now, max_seconds=limit - rt.time)
        except KeyboardInterrupt:
            failures.append("interrupted")
        except ProgramError as exc:  # the task halted, its axes are at rest
            program_error = str(exc)
            if runner is None or not runner.failures:
                failures.append(program_error)
        if runner is not None:
            failures.extend(runner.failures)
            if not runner.finished and not runner.failed and not failures:
                failures.append(
                    f"{args.script}: did not finish within {rt.time:g} s"
                    + ("" if args.seconds is None else " (--seconds)")
                )
        for name, ax in machine.axes.items():
            if ax.state is AxisState.ERROR_STOP and not any(f"{name!r}" in f for f in failures):
                failures.append(f"axis {name!r} ends in ERROR_STOP ({axis_error_text(ax)})")
        if rt.error_reason and rt.error_reason != program_error:
            failures.append(rt.error_reason)
        if args.trace:
            path = Path(args.trace)
            path.parent.mkdir(parents=True, exist_ok=True)
            events = path.with_suffix(".events.csv")
            rt.trace.to_csv(path, events_path=events)
            if rt.groups:
                from motionplc import scope

                sidecar = scope.write_groups_sidecar(
                    path, {n: list(g.axis_names) for n, g in rt.groups.items()}
                )
                also = f", {events} and {sidecar}"
            else:
                also = f" and {events}"
            tr = rt.trace
            kept = ""
            if tr.dropped_rows or tr.dropped_events:
                kept = (
                    f"; the last {len(tr)} cycles: {tr.dropped_rows} older rows and "
                    f"{tr.dropped_events} FB edges dropped by the trace bound of "
                    f"{tr.rows_capacity} rows / {tr.max_bytes / 2**20:g} MiB"
                )
            print(f"wrote {path} ({len(tr)} rows{kept}){also}")
        if args.plot:
            from motionplc import scope

            code = _write_plot(Path(args.plot), scope.trace_from_runtime(rt), str(args.config))
            if code:
                return code
        if not args.quiet or failures:
            print()
            for line in _summary(machine, runner):
                print(line)
            print()
        t_end = getattr(runner, "t_finished", None)
        if failures:
            for f in failures:
                print(f"FAILED: {f}", file=sys.stderr)
            return 1
        if runner is not None and hasattr(runner, "report"):
            print(f"ok: {runner.report()}")
        elif runner is not None:
            print(f"ok: {args.script} finished at t = {t_end:.3f} s, all expectations met")
        else:
            print(f"ok: ran {rt.time:g} s")
        return 0
    finally:
        machine.close()


# ---------------------------------------------------------------------------- plots
def _cmd_plot(args: argparse.Namespace) -> int:
    from motionplc import scope

    path = Path(args.trace)
    trace = scope.read_trace(path)
    out = Path(args.output) if args.output else path.with_suffix(".png")
    return _write_plot(out, trace, str(path))


def _write_plot(out: Path, trace: Any, title: str) -> int:
    """Write a scope plot (:func:`motionplc.scope.write_plot`); 2 when matplotlib is missing."""
    from motionplc import scope

    try:
        scope.write_plot(out, trace, title)
    except scope.PlotDependencyError as exc:
        print(exc, file=sys.stderr)
        return 2
    print(f"wrote {out}")
    return 0


# ---------------------------------------------------------------------------- drives
def _cmd_drives(args: argparse.Namespace) -> int:
    import asyncio
    import json
    import signal

    from motionplc.config import load_config
    from motionplc.fieldbus.drives_main import DrivesSpec, run_drives

    cfg = load_config(args.config)
    specs: list[DrivesSpec] = []
    for bus in cfg.buses:
        axes = [a for a in cfg.axes if a.drive.bus == bus.name]
        if not axes:
            continue
        if bus.type == "can":
            if bus.interface == "virtual":
                print(
                    f"motionplc: bus {bus.name!r}: the python-can virtual bus does not reach "
                    "other processes; its drives run inside 'motionplc run' (use interface: "
                    "socketcan with vcan0 for separate drives)",
                    file=sys.stderr,
                )
                continue
            specs.append(
                DrivesSpec(
                    can_nodes=tuple(a.drive.node_id for a in axes if a.drive.node_id),
                    can_interface=bus.interface,
                    can_channel=bus.channel,
                    duration=args.duration,
                )
            )
        else:
            for order in ("big", "little"):
                ids = tuple(
                    a.drive.unit_id for a in axes if a.drive.word_order == order and a.drive.unit_id
                )
                if ids:
                    specs.append(
                        DrivesSpec(
                            modbus=ids,
                            modbus_port=bus.port,
                            word_order=order,  # type: ignore[arg-type]
                            duration=args.duration,
                        )
                    )
    if not specs:
        print("motionplc: no drives to serve in this configuration", file=sys.stderr)
        return 2

    async def serve() -> None:
        stop = asyncio.Event()
        loop = asyncio.get_running_loop()
        for sig in (signal.SIGTERM, signal.SIGINT):
            try:
                loop.add_signal_handler(sig, stop.set)
            except (NotImplementedError, RuntimeError):
                pass

        def ready(info: dict[str, object]) -> None:
            print(json.dumps(info), flush=True)

        await asyncio.gather(*(run_drives(s, ready=ready, stop=stop) for s in specs))

    try:
        asyncio.run(serve())
    except OSError as exc:
        print(f"motionplc: drives: {exc}", file=sys.stderr)
        return 1
    return 0


_VERBOSE_HELP = (
    "show the log of the fieldbus libraries (pymodbus, canopen, python-can): -v warnings and "
    "errors, -vv everything (default: quiet; bus failures are reported as axis errors)"
)


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="motionplc",
        description="Soft-PLC motion-control runtime.",
        formatter_class=argparse.RawDescriptionHelpFormatter,
        epilog="exit codes: 0 ok, 1 run failed, 2 invalid configuration/sequence/program",
    )
    sub = parser.add_subparsers(dest="command", required=True)
    r = sub.add_parser(
        "run", help="run a configuration with a sequence, a Python program or a G-code program"
    )
    r.add_argument("config", help="machine configuration (YAML)")
    r.add_argument(
        "script",
        nargs="?",
        help="sequence (.yaml), Python program (.py) or G-code program (.ngc, .nc, .gcode, .tap)",
    )
    r.add_argument(
        "--group",
        help="the axes group a G-code program runs on (default: the only configured group)",
    )
    r.add_argument("--realtime", action="store_true", help="wall-clock time instead of simulated")
    r.add_argument(
        "--seconds",
        type=_float,
        default=None,
        help="run exactly this long (default: until the script ends; 1 s without a script)",
    )
    r.add_argument("--trace", help="write the trace as CSV (FB edges to *.events.csv)")
    r.add_argument("--plot", help="write a scope plot: .png (needs matplotlib) or .html")
    r.add_argument("--quiet", "-q", action="store_true", help="no progress output")
    r.add_argument("--verbose", "-v", action="count", default=0, help=_VERBOSE_HELP)
    r.set_defaults(func=_cmd_run)
    v = sub.add_parser("validate", help="check a configuration (and a sequence or program)")
    v.add_argument("config")
    v.add_argument("script", nargs="?")
    v.add_argument("--group", help="the axes group of a G-code program")
    v.set_defaults(func=_cmd_validate)
    pl = sub.add_parser(
        "plot",
        help="plot a trace CSV: p/v/a/j and FB-state lanes per axis, and per axes group its "
        "path in space coloured by path speed",
    )
    pl.add_argument(
        "trace", help="trace CSV written by run --trace (groups from TRACE.groups.json if present)"
    )
    pl.add_argument("-o", "--output", help="output .png or .html (default: TRACE.png)")
    pl.set_defaults(func=_cmd_plot)
    d = sub.add_parser("drives", help="serve the virtual drives of a configuration on their own")
    d.add_argument("config")
    d.add_argument("--duration", type=_float, default=None, help="[s]; default: until Ctrl-C")
    d.add_argument("--verbose", "-v", action="count", default=0, help=_VERBOSE_HELP)
    d.set_defaults(func=_cmd_drives)
    p = sub.add_parser("plan", help="plan one time-optimal move and print its phases")
    for name, default in (
        ("p0", 0.0),
        ("v0", 0.0),
        ("a0", 0.0),
        ("pf", 6.0),
        ("vf", 0.0),
        ("af", 0.0),
    ):
        p.add_argument(f"--{name}", type=_float, default=default)
    p.add_argument("--v-max", type=_float, default=1.8)
    p.add_argument("--a-max", type=_float, default=1.2)
    p.add_argument("--j-max", type=_float, default=1.0)
    p.add_argument("--v-min", type=_float, default=None)
    p.add_argument("--a-min", type=_float, default=None)
    p.add_argument("--dt", type=_float, default=0.001, help="sample period of the CSV [s]")
    p.add_argument("--csv", help="write the sampled profile to this CSV file")
    p.add_argument("--plot", help="write a PNG plot (needs matplotlib)")
    p.set_defaults(func=_cmd_plan)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        if args.command in ("run", "drives"):
            with log_routing(args.verbose):
                return int(args.func(args))
        return int(args.func(args))
    except MotionPlcError as exc:
        print(f"motionplc: error: {exc}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    raise SystemExit(main())
