"""The ``motionplc`` command line.

``motionplc run CONFIG [SEQUENCE|PROGRAM|GCODE] [--group NAME]``, ``validate``, ``plot``,
``drives``, ``plan``, ``schema``, ``examples DIR``; ``motionplc --version``.

Exit codes (also in ``motionplc --help``):

* 0 success;
* 1 the run failed: an expectation, an FB or axis error, a timeout, more overruns than
  ``--max-overruns`` / ``runtime.max_overruns``;
* 2 invalid input: a configuration, sequence, program or G-code error (one line each,
  ``FILE:LINE: key.path: problem (allowed: ...)`` or ``FILE:LINE: WORD: ...``), a bad option
  (``invalid number: 'abc'``), a file that cannot be read or written (``--trace: out: is a
  directory``), a bus that cannot start (``FILE:LINE: buses.mb0.port: 127.0.0.1:5020 is in use
  (...)``, a CAN interface that does not open; also for ``drives``), a missing optional
  package;
* 3 internal error: an unexpected exception, one line ``motionplc: internal error: ... (run
  with --debug for the traceback)``; ``--debug`` prints the traceback as well;
* 130 interrupted (Ctrl-C): ``run`` still writes its trace and summary;
* 143 terminated (SIGTERM), the same.

Every end of ``run`` (a failure, Ctrl-C, SIGTERM, the end of ``--seconds`` or of the script, a
program that raised) is a controlled stop first (:meth:`motionplc.runtime.Runtime.shutdown`):
every group brakes along its path, every other axis with MC_Stop at its own deceleration and
jerk limits, then the drives are switched off (CiA 402 / Modbus shutdown sequence); those
cycles are in the trace and the summary says how long the stop took against its bound. A
second Ctrl-C (or SIGTERM) during the stop is a quick stop (ErrorStop QUICK_STOP, reported). An
axis not at rest or a drive not disabled within the bound is reported and left to its drive.

Nothing a user can reach prints a traceback without ``--debug``.

A G-code program (``.ngc``, ``.nc``, ``.gcode``, ``.tap``) runs on the configured axes group
(the only one, or ``--group NAME``) through :class:`motionplc.gcode_runner.GcodeRunner`; every
move it cannot run is reported before the first cycle. ``--trace`` (``.csv``, or ``.parquet``
with pyarrow) also writes the FB edges (``TRACE.events.csv`` / ``.events.parquet``) and the
groups sidecar (``TRACE.groups.json``) that ``motionplc plot`` reads.

``--seconds`` is a limit: a run with a sequence or program ends when it finishes (a program's
``ctx.done()``, a sequence's last step), at the latest after ``--seconds``; without a script
it runs exactly that long.

Statistics: in real time the task table shows execution time, lateness, overruns and omitted
cycles as measured by the runtime. On the simulated clock those cannot occur (time advances by
exactly one tick, lateness is 0 by construction), so the table shows cycles, overruns and
omitted cycles, and one line gives the wall-clock time per tick that the CLI measured around
each tick (all tasks, bus I/O and tracing; mean, p99, max, and the speed against real time).
The measurement only reads a clock between ticks: the simulated run and its trace stay
bit-reproducible. In real time the settings applied or refused by the operating system
(``--rt-priority``, ``--cpus``, ``--lock-memory`` or ``runtime.realtime`` in the YAML) are
printed after the run.

Progress: on a terminal a progress bar on stderr (simulated time against the limit, ETA from
wall-clock time; tqdm), otherwise a ``t = ...`` line every 5 s of simulated time, nothing with
``-q``.

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
import dataclasses
import logging
import math
import os
import re
import sys
import traceback
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from pathlib import Path
from typing import Any

from motionplc.errors import MotionPlcError, PlanningError, ProgramError

LIBRARY_LOGGERS = ("pymodbus", "canopen", "can")
"""Loggers of the fieldbus libraries, routed through the CLI's handler (see :func:`log_routing`)."""

EXIT_OK = 0
EXIT_FAILED = 1
EXIT_INVALID = 2
EXIT_INTERNAL = 3
EXIT_INTERRUPTED = 130
EXIT_TERMINATED = 143  # SIGTERM (128 + 15)

EXIT_CODES_HELP = (
    "exit codes:\n"
    "  0    ok\n"
    "  1    the run failed (an expectation, an FB or axis error, a timeout, more overruns\n"
    "       than --max-overruns)\n"
    "  2    invalid input: configuration, sequence, program or G-code (FILE:LINE: ...),\n"
    "       options, files that cannot be read or written, a bus that cannot start\n"
    "       (port in use, CAN interface missing), a missing optional package\n"
    "  3    internal error (run with --debug for the traceback)\n"
    "  130  interrupted (Ctrl-C)\n"
    "  143  terminated (SIGTERM)\n"
    "  every end of a run is a controlled stop first: axes and groups brake to rest within\n"
    "  their limits, the drives are switched off, the trace holds those cycles; a second\n"
    "  Ctrl-C during it is a quick stop"
)

TRACE_SUFFIXES = (".csv", ".parquet")
PLOT_SUFFIXES = (".png", ".html", ".htm")
SCHEMA_KINDS = ("config", "sequence", "register_map")
PROGRESS_EVERY = 5.0  # [s] of simulated time between the progress lines without a terminal


# ---------------------------------------------------------------------------- small helpers
def _number(text: str) -> float:
    """argparse type: a number (``inf`` allowed, ``nan`` not)."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"invalid number: {text!r}") from None
    if math.isnan(value):
        raise argparse.ArgumentTypeError(f"invalid number: {text!r}")
    return value


def _seconds(text: str) -> float:
    """argparse type: a finite duration > 0 [s]."""
    value = _number(text)
    if not (value > 0 and math.isfinite(value)):
        raise argparse.ArgumentTypeError(
            f"invalid duration: {text!r} (allowed: a number of seconds > 0)"
        )
    return value


def _count(text: str) -> int:
    """argparse type: an integer >= 0."""
    try:
        value = int(text)
    except ValueError:
        value = -1
    if value < 0:
        raise argparse.ArgumentTypeError(f"invalid count: {text!r} (allowed: an integer >= 0)")
    return value


def _priority(text: str) -> int:
    """argparse type: a SCHED_FIFO priority 1..99."""
    try:
        value = int(text)
    except ValueError:
        value = 0
    if not 1 <= value <= 99:
        raise argparse.ArgumentTypeError(f"invalid priority: {text!r} (allowed: 1..99)")
    return value


def _cpus(text: str) -> tuple[int, ...]:
    """argparse type: CPU numbers ``0,1`` or ranges ``0-3,6``, sorted, each once."""
    cpus: set[int] = set()
    try:
        for part in text.split(","):
            lo, _, hi = part.strip().partition("-")
            first, last = int(lo), int(hi) if hi else int(lo)
            if first < 0 or last < first:
                raise ValueError
            cpus.update(range(first, last + 1))
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"invalid CPU list: {text!r} (allowed: CPU numbers >= 0 and ranges, e.g. 0,1 or 2-3)"
        ) from None
    return tuple(sorted(cpus))


def _plural(n: int, word: str, plural: str | None = None) -> str:
    """``1 bus``, ``2 buses``, ``0 axes``."""
    return f"{n} {word if n == 1 else plural or word + 's'}"


def _num(x: float, fmt: str = "g") -> str:
    """``x`` formatted with ``fmt``; a result that reads as a negative zero is shown as 0."""
    text = format(x, fmt)
    if text.startswith("-") and float(text) == 0.0:
        text = text[1:]
    return text


def _duration(seconds: float) -> str:
    """A short time: ``812 ns``, ``45.2 us``, ``1.52 ms``, ``2.3 s``."""
    if seconds < 1e-6:
        return f"{seconds * 1e9:.0f} ns"
    if seconds < 1e-3:
        return f"{seconds * 1e6:.3g} us"
    if seconds < 1.0:
        return f"{seconds * 1e3:.3g} ms"
    return f"{seconds:.3g} s"


def _reason(exc: BaseException) -> str:
    """An exception as a short reason: the OS text for an OSError, else ``str`` or its type."""
    if isinstance(exc, OSError) and exc.strerror:
        return exc.strerror[:1].lower() + exc.strerror[1:]
    return str(exc) or type(exc).__name__


def _yaml_line(path: str | Path, keys: Sequence[str]) -> int:
    """The line of the deepest of ``keys`` (a path of mapping keys) found in the YAML file
    ``path`` (read by the configuration loader, which records every key's line); 1 if the file
    cannot be read."""
    from motionplc.config import YamlMap, load_yaml

    try:
        node = load_yaml(path)
    except MotionPlcError:
        return 1
    line = 1
    for key in keys:
        if not isinstance(node, YamlMap) or key not in node:
            break
        line, node = node.key_lines[key], node[key]
    return line


def _check_output(option: str, path: str | None, suffixes: Sequence[str]) -> Path | None:
    """An output file given by ``option``: its suffix allowed, not a directory, its directory
    creatable and writable. Checked before anything runs; raises a one-line MotionPlcError."""
    if path is None:
        return None
    p = Path(path)
    if p.is_dir():
        raise MotionPlcError(f"{option}: {p}: is a directory (allowed: a file name)")
    if p.suffix.lower() not in suffixes:
        raise MotionPlcError(
            f"{option}: {p}: unsupported file type {p.suffix or '(none)'!r} "
            f"(allowed: {', '.join(suffixes)})"
        )
    parent = p.parent
    try:
        parent.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise MotionPlcError(f"{option}: {p}: cannot create {parent}: {_reason(exc)}") from None
    if not os.access(parent, os.W_OK | os.X_OK) or (p.exists() and not os.access(p, os.W_OK)):
        raise MotionPlcError(f"{option}: {p}: not writable (permission denied)")
    return p


@contextmanager
def _writing(option: str, path: Path) -> Iterator[None]:
    """Turn an OSError while writing ``path`` into one line naming ``option``."""
    try:
        yield
    except OSError as exc:
        raise MotionPlcError(f"{option}: {path}: cannot write: {_reason(exc)}") from None


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


def package_version() -> str:
    """The installed distribution's version (package metadata), else ``motionplc.__version__``."""
    from importlib import metadata

    try:
        return metadata.version("motionplc")
    except metadata.PackageNotFoundError:
        import motionplc

        return motionplc.__version__


class _VersionAction(argparse.Action):
    """``--version``: the version and which planning core runs (mypyc-compiled or the Python
    sources, and why), worked out only when asked."""

    def __call__(self, parser: argparse.ArgumentParser, *_: Any, **__: Any) -> None:
        import motionplc

        core = motionplc.compiled_core()
        print(f"motionplc {package_version()} (planning core: {core.reason})")
        parser.exit()


# ---------------------------------------------------------------------------- plan
# the planner's field names as the options of ``plan`` (an error names what the user typed)
_PLAN_OPTIONS = {
    **{f"Limits.{k}": "--" + k.replace("_", "-") for k in ("v_max", "a_max", "j_max", "v_min")},
    "Limits.a_min": "--a-min",
    **{f"start.{k}": f"--{k}0" for k in "pva"},
    **{f"target.{k}": f"--{k}f" for k in "pva"},
}
_PLAN_FIELD = re.compile(r"\b(Limits\.[a-z_]+|start\.[pva]|target\.[pva])\b")


def _plan_option_message(text: str) -> str:
    """A planner error with its field names replaced by the ``plan`` options that set them
    (``Limits.v_max must be ...`` -> ``--v-max: must be ...``)."""
    m = _PLAN_FIELD.match(text)
    if m and m.group(1) in _PLAN_OPTIONS:
        rest = text[m.end() :].lstrip(": ")
        text = f"{_PLAN_OPTIONS[m.group(1)]}: {rest}"
    return _PLAN_FIELD.sub(lambda k: _PLAN_OPTIONS.get(k.group(1), k.group(1)), text)


def _cmd_plan(args: argparse.Namespace) -> int:
    from motionplc.planning import Limits, State, plan

    csv_path = _check_output("--csv", args.csv, (".csv",))
    plot_path = _check_output("--plot", args.plot, PLOT_SUFFIXES)
    if not (args.dt > 0 and math.isfinite(args.dt)):
        raise MotionPlcError(f"--dt: got {_num(args.dt)} (allowed: a number of seconds > 0)")
    try:
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
    except PlanningError as exc:
        raise MotionPlcError(_plan_option_message(str(exc))) from exc
    n = max(2, int(math.ceil(prof.duration / args.dt)) + 1)
    if n > 10_000_000:
        raise MotionPlcError(
            f"--dt: {_num(args.dt)} s gives {n} samples over {prof.duration:g} s "
            "(allowed: at most 10,000,000 samples; choose a larger --dt)"
        )

    def state(s: Any) -> str:
        return f"p = {_num(s.p)}, v = {_num(s.v)}, a = {_num(s.a)}"

    limits = f"v_max {_num(lim.v_max)}, a_max {_num(lim.a_max)}, j_max {_num(lim.j_max)}"
    if args.v_min is not None or args.a_min is not None:
        limits += f", v_min {_num(lim.v_min)}, a_min {_num(lim.a_min)}"
    print(f"start   {state(start)}")
    print(f"target  {state(target)}")
    print(f"limits  {limits}   (SI: m or rad, s)")
    print(f"profile family: {prof.kind}; duration {prof.duration:.9f} s")
    print(
        f"{'phase':>5} {'t_start [s]':>12} {'duration [s]':>13} {'jerk':>10} "
        f"{'p':>12} {'v':>10} {'a':>10}"
    )
    for i, (k, seg) in enumerate(zip(prof.knots, prof.segments, strict=True)):
        print(
            f"{i + 1:>5} {_num(k.t, '.6f'):>12} {_num(seg.duration, '.6f'):>13} "
            f"{_num(seg.jerk, '.4g'):>10} {_num(k.p, '.6f'):>12} {_num(k.v, '.5f'):>10} "
            f"{_num(k.a, '.5f'):>10}"
        )
    e = prof.end
    print(
        f"{'end':>5} {_num(prof.duration, '.6f'):>12} {'':>13} {'':>10} "
        f"{_num(e.p, '.6f'):>12} {_num(e.v, '.5f'):>10} {_num(e.a, '.5f'):>10}"
    )
    ts = [min(i * args.dt, prof.duration) for i in range(n)]
    s = prof.sample(ts)
    if csv_path is not None:
        with _writing("--csv", csv_path), csv_path.open("w", newline="") as fh:
            w = csv.writer(fh)
            w.writerow(["t", "p", "v", "a", "j"])
            for row in zip(ts, s.p, s.v, s.a, s.j, strict=True):
                w.writerow([f"{x:.12g}" for x in row])
        print(f"wrote {csv_path} ({n} samples at dt = {_num(args.dt)} s)")
    if plot_path is not None:
        import numpy as np

        from motionplc import scope

        series = {
            "position": (np.asarray(s.p), "m"),
            "velocity": (np.asarray(s.v), "m/s"),
            "acceleration": (np.asarray(s.a), "m/s^2"),
            "jerk": (np.asarray(s.j), "m/s^3"),
        }
        title = f"{prof.kind}: ({state(start)}) -> ({state(target)}), T = {prof.duration:.4f} s"
        with _writing("--plot", plot_path):
            scope.write_series_plot(plot_path, np.asarray(ts), series, title)
        print(f"wrote {plot_path}")
    return EXIT_OK


# ---------------------------------------------------------------------------- run / validate
def _load_script(path: str, config: Any, group: str | None = None) -> Any:
    """Validate a sequence, load a program or parse a G-code file before anything is built."""
    from motionplc.gcode_runner import GCODE_SUFFIXES, is_gcode, load_gcode_job

    if is_gcode(path):
        return load_gcode_job(path, config, group)
    suffix = Path(path).suffix.lower()
    if suffix not in (".yaml", ".yml", ".py"):
        kind = repr(suffix) if suffix else "(none)"
        raise MotionPlcError(
            f"{path}: unknown program type {kind} (allowed: .yaml or .yml sequence, .py "
            f"Python program, {', '.join(GCODE_SUFFIXES)} G-code)"
        )
    if group is not None:
        raise MotionPlcError(f"{path}: --group: only for G-code programs (.ngc, .nc, ...)")
    if Path(path).suffix == ".py":
        from motionplc.program import load_program

        return load_program(path)
    from motionplc.sequence import load_sequence

    return load_sequence(path, config)


def _plausibility_warnings(cfg: Any, script: Any = None) -> None:
    """Print the warnings (accepted, implausible values: motionplc.plausibility) of a
    configuration (``script`` None) or of its sequence or G-code program ``script``, one
    ``FILE:LINE: key: warning: ...`` line each, on stderr."""
    lines = list(getattr(cfg, "warnings", ())) if script is None else []
    lines += list(getattr(script, "warnings", ()) or ())
    if script is not None and hasattr(script, "program") and hasattr(script, "group"):
        from motionplc.plausibility import feed_warning

        units = cfg.axis(script.axes[0]).units if script.axes else "m"
        last = None
        try:
            moves = list(script.program.moves([0.0] * len(script.axes)))
        except MotionPlcError:
            moves = []  # reported as an error where the moves are resolved
        for mv in moves:
            if mv.feed is None or mv.feed == last:
                continue
            last = mv.feed
            text = feed_warning(mv.feed, units)
            if text is not None:
                lines.append(f"{script.path}:{mv.line}: F: warning: {text}")
    for line in lines:
        print(line, file=sys.stderr)


def _cmd_validate(args: argparse.Namespace) -> int:
    from motionplc.config import load_config

    cfg = load_config(args.config)
    _plausibility_warnings(cfg)
    tasks = ", ".join(f"{t.name} {t.period * 1e3:g} ms" for t in cfg.runtime.tasks)
    print(
        f"{args.config}: ok - {_plural(len(cfg.axes), 'axis', 'axes')} "
        f"({', '.join(a.name for a in cfg.axes)}), {_plural(len(cfg.buses), 'bus', 'buses')}, "
        f"{'task' if len(cfg.runtime.tasks) == 1 else 'tasks'}: {tasks}"
    )
    script = _load_script(args.script, cfg, args.group) if args.script else None
    if script is not None:
        _plausibility_warnings(cfg, script)
        if hasattr(script, "program") and hasattr(script, "group"):  # a G-code job
            spec = cfg.group(script.group)
            notes = script.program.notes
            for note in notes[:20]:
                print(f"note: {note}")
            if len(notes) > 20:
                print(f"note: ... and {len(notes) - 20} more notes")
            print(
                f"{args.script}: ok - {_plural(len(script.program), 'move')} from the origin "
                f"on group {script.group!r} ({', '.join(spec.axes)})"
            )
        elif hasattr(script, "steps"):
            print(
                f"{args.script}: ok - {_plural(len(script.steps), 'step')}, "
                f"{_plural(len(script.blocks), 'block')}, task {script.task}"
            )
        else:
            print(f"{args.script}: ok - program(ctx)")
    return EXIT_OK


class _TickTimer:
    """Wall-clock time per tick, measured by the CLI between two calls of :meth:`tick` (the
    stop predicate, called after every tick). Reads a :class:`RealtimeClock` used as a
    stopwatch; the runtime and its simulated time are not touched. Durations go into 1 us bins
    up to 10 ms (longer ones into one overflow bin) for the p99."""

    BINS = 10_000

    def __init__(self) -> None:
        from motionplc.runtime.clock import RealtimeClock

        self._watch = RealtimeClock()
        self._watch.start()
        self._last = self._watch.now_ns()
        self.count = 0
        self.total_ns = 0
        self.max_ns = 0
        self._hist = [0] * (self.BINS + 1)

    def restart(self) -> None:
        """The next tick starts now."""
        self._last = self._watch.now_ns()

    def tick(self) -> None:
        """One tick ended now."""
        now = self._watch.now_ns()
        d = now - self._last
        self._last = now
        self.count += 1
        self.total_ns += d
        if d > self.max_ns:
            self.max_ns = d
        self._hist[min(d // 1000, self.BINS)] += 1

    def percentile(self, q: float) -> float:
        """Upper edge [s] of the 1 us bin holding the ceil(q * count)-th duration."""
        need = math.ceil(q * self.count)
        seen = 0
        for i, n in enumerate(self._hist):
            seen += n
            if seen >= need and n:
                return self.max_ns * 1e-9 if i == self.BINS else (i + 1) * 1e-6
        return 0.0


class _Progress:
    """Run progress: a tqdm bar on a terminal's stderr (simulated time against ``limit``, ETA
    from wall-clock time), ``t = ...`` lines every 5 s of simulated time otherwise, nothing when
    quiet."""

    def __init__(self, limit: float, quiet: bool, step: float) -> None:
        self.limit = limit
        self._bar: Any = None
        self._next = PROGRESS_EVERY
        self._lines = not quiet
        if not quiet and sys.stderr.isatty():
            try:
                from tqdm import tqdm
            except ImportError:  # plain lines instead
                return
            self._lines = False
            self._bar = tqdm(
                total=limit,
                file=sys.stderr,
                leave=False,
                dynamic_ncols=True,
                bar_format="{desc}{percentage:3.0f}%|{bar}| t = {n:.1f} of {total:.4g} s "
                "[{elapsed}<{remaining}]",
                desc="run ",
            )
            self._next = max(step, limit / 1000.0)
            self._step = self._next

    def update(self, t: float) -> None:
        """Simulated time ``t`` reached (called after every tick: cheap)."""
        if t < self._next - 1e-9:
            return
        if self._bar is not None:
            self._bar.update(min(t, self.limit) - self._bar.n)
            self._next = t + self._step
        else:
            if self._lines:
                print(f"  t = {t:7.1f} s", file=sys.stderr, flush=True)
            self._next += PROGRESS_EVERY

    def close(self) -> None:
        if self._bar is not None:
            self._bar.close()
            self._bar = None


def _summary(
    machine: Any,
    runner: Any,
    timer: _TickTimer | None = None,
    realtime: bool = False,
    states: dict[str, str] | None = None,
) -> list[str]:
    """Per-axis table, groups, drive warnings and task statistics (see the module docs).
    ``states``: the axis and group states at the end of the run (before its controlled stop
    switched everything off); positions are the final ones."""
    states = states or {}
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
            f"{name:<10} {done.get(name, 0):>10} {states.get(name, ax.state.name):<20} "
            f"{_num(ax.position, '.9g'):>14} {_num(ax.actual_position, '.9g'):>14} "
            f"{_num(max_fe, '.3g'):>12}"
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
                f"{states.get(name, g.state.name):<20}"
            )
    lines.append("")
    stats = list(rt.stats().values())
    if realtime:
        lines.append(
            f"{'task':<10} {'cycles':>10} {'exec mean':>10} {'exec max':>10} "
            f"{'late p99':>10} {'late max':>10} {'overruns':>9} {'omitted':>8}"
        )
        for st in stats:
            lines.append(
                f"{st.name:<10} {st.cycle_count:>10} {st.exec_mean * 1e6:>8.1f}us "
                f"{st.exec_max * 1e6:>8.1f}us {st.lateness_p99 * 1e6:>8.1f}us "
                f"{st.lateness_max * 1e6:>8.1f}us {st.overruns:>9} {st.omitted_cycles:>8}"
            )
        return lines
    lines.append(f"{'task':<10} {'cycles':>10} {'overruns':>9} {'omitted':>8}")
    for st in stats:
        lines.append(f"{st.name:<10} {st.cycle_count:>10} {st.overruns:>9} {st.omitted_cycles:>8}")
    if timer is not None and timer.count:
        wall = timer.total_ns * 1e-9
        simulated = timer.count * rt.cycle
        speed = f", {simulated / wall:.3g}x real time" if wall > 0 else ""
        lines.append(
            f"wall-clock time per tick: mean {_duration(wall / timer.count)}, p99 "
            f"{_duration(timer.percentile(0.99))}, max {_duration(timer.max_ns * 1e-9)} "
            f"({_plural(timer.count, 'tick')} of {rt.cycle * 1e3:g} ms in {wall:.3g} s{speed})"
        )
        lines.append(
            "(simulated time: no lateness by construction; the CLI measured each tick, all "
            "tasks, bus I/O and trace)"
        )
    return lines


def _apply_realtime_options(cfg: Any, args: argparse.Namespace) -> Any:
    """The configuration with ``--rt-priority``, ``--cpus``, ``--lock-memory`` and
    ``--max-overruns`` overriding ``runtime.realtime`` / ``runtime.max_overruns``."""
    changes: dict[str, Any] = {}
    if args.rt_priority is not None:
        changes["rt_priority"] = args.rt_priority
    if args.cpus is not None:
        changes["rt_cpus"] = args.cpus
    if args.lock_memory:
        changes["rt_lock_memory"] = True
    rt_options = [
        o
        for o, given in (
            ("--rt-priority", args.rt_priority is not None),
            ("--cpus", args.cpus is not None),
            ("--lock-memory", args.lock_memory),
        )
        if given
    ]
    if rt_options and not args.realtime and cfg.runtime.clock != "realtime":
        raise MotionPlcError(
            f"{', '.join(rt_options)}: only for a real-time run (add --realtime, or "
            "runtime.clock: realtime in the configuration)"
        )
    if args.max_overruns is not None:
        changes["max_overruns"] = args.max_overruns
    if not changes:
        return cfg
    try:
        runtime = dataclasses.replace(cfg.runtime, **changes)
    except TypeError:
        raise MotionPlcError(
            f"{', '.join(rt_options) or '--max-overruns'}: this motionplc's configuration has "
            "no real-time settings (runtime.realtime, runtime.max_overruns)"
        ) from None
    return dataclasses.replace(cfg, runtime=runtime)


def _realtime_report(clock: Any) -> str | None:
    """What the operating system applied or refused of the requested real-time settings."""
    if not getattr(clock, "realtime", False):
        return None
    parts: list[str] = []
    prio = getattr(clock, "fifo_priority", None)
    if prio is not None:
        if getattr(clock, "fifo_active", False):
            parts.append(f"SCHED_FIFO {prio}: applied")
        else:
            parts.append(
                f"SCHED_FIFO {prio}: refused (needs CAP_SYS_NICE or an RLIMIT_RTPRIO >= {prio})"
            )
    cpus = getattr(clock, "cpus", None)
    if not cpus and getattr(clock, "cpu", None) is not None:
        cpus = (clock.cpu,)
    if cpus:
        listed = ",".join(str(c) for c in cpus)
        if getattr(clock, "affinity_active", False):
            parts.append(f"CPUs {listed}: applied")
        else:
            try:
                allowed = ",".join(str(c) for c in sorted(os.sched_getaffinity(0)))
                why = f"allowed CPUs: {allowed}"
            except (AttributeError, OSError):
                why = "no CPU affinity on this system"
            parts.append(f"CPUs {listed}: refused ({why})")
    if getattr(clock, "lock_memory", False):
        if getattr(clock, "mlock_active", False):
            parts.append("memory lock: applied")
        else:
            parts.append(
                "memory lock: refused (needs CAP_IPC_LOCK or a large enough RLIMIT_MEMLOCK)"
            )
    if not parts:
        return "real time: default scheduling (no priority, CPU affinity or memory lock asked)"
    return "real time: " + "; ".join(parts)


def _located_build_error(cfg: Any, exc: MotionPlcError) -> MotionPlcError:
    """A bus or drive that could not start, located at its YAML line: a Modbus port in use
    (``FILE:LINE: buses.NAME.port: HOST:PORT is in use (...)``), ``AXIS: ...`` of a drive
    (``FILE:LINE: axes.AXIS.drive (bus NAME): ...``); other errors (a CAN interface that does
    not open: ``FILE: buses.NAME: ...`` from ``build``) as they are."""
    from motionplc.fieldbus.drives_main import port_problem

    text = str(exc)
    cause = exc.__cause__
    if "Modbus" in text or isinstance(cause, (OSError, RuntimeError)):
        for bus in cfg.buses:
            if bus.type != "modbus" or bus.drives != "simulated" or not bus.port:
                continue
            problem = port_problem(bus.host, bus.port)
            if problem is not None:
                return MotionPlcError(_port_in_use(cfg.path, bus.name, bus.host, bus.port, problem))
    for ax in cfg.axes:
        if text.startswith(f"{ax.name}: ") and ax.drive.bus is not None:
            line = _yaml_line(cfg.path, ("axes", ax.name, "drive"))
            return MotionPlcError(
                f"{cfg.path}:{line}: axes.{ax.name}.drive (bus {ax.drive.bus}): "
                f"{text[len(ax.name) + 2 :]}"
            )
    return exc


def _port_in_use(config: str, bus: str, host: str, port: int, reason: str) -> str:
    """``CONFIG:LINE: buses.NAME.port: HOST:PORT is in use (...)`` (or cannot be listened on:
    ``reason`` is the operating system's)."""
    line = _yaml_line(config, ("buses", bus, "port"))
    if "in use" in reason:
        problem = f"{host}:{port} is in use ({reason}: another process listens there; stop it"
    else:
        problem = f"cannot listen on {host}:{port} ({reason}"
    return (
        f"{config}:{line}: buses.{bus}.port: {problem} or choose another port, 0 picks a free one)"
    )


def _build(cfg: Any, realtime: bool | None) -> Any:
    from motionplc.config import build

    try:
        return build(cfg, realtime=realtime)
    except MotionPlcError as exc:
        located = _located_build_error(cfg, exc)
        if located is exc:
            raise
        raise located from exc


class _Ending:
    """SIGINT and SIGTERM during ``run``: the first ends the run after the current tick (a
    flag the stop predicate reads: never an exception inside a cycle), one during the stop at
    the end asks for a quick stop (``Runtime.quick_stop_requested``)."""

    def __init__(self, rt: Any) -> None:
        self.rt = rt
        self.signal = ""  # "SIGINT" / "SIGTERM": the run was ended by it
        self.stopping = False  # the controlled stop runs
        self._old: dict[int, Any] = {}

    def install(self) -> None:
        import signal as sig

        for num in (sig.SIGINT, sig.SIGTERM):
            try:
                self._old[num] = sig.signal(num, self._handle)
            except (ValueError, OSError):  # not the main thread: the defaults stay
                pass

    def restore(self) -> None:
        import signal as sig

        for num, old in self._old.items():
            sig.signal(num, old)
        self._old = {}

    def _handle(self, num: int, frame: Any) -> None:
        import signal as sig

        name = "SIGINT" if num == sig.SIGINT else "SIGTERM"
        if self.stopping or self.signal:
            self.rt.quick_stop_requested = True
        else:
            self.signal = name

    def words(self) -> str:
        return {"SIGINT": "interrupted", "SIGTERM": "terminated (SIGTERM)"}.get(
            self.signal, self.signal
        )


def _cmd_run(args: argparse.Namespace) -> int:
    from motionplc.blocks import AxisState
    from motionplc.config import load_config
    from motionplc.sequence import axis_error_text

    cfg = load_config(args.config)
    if args.group is not None and not args.script:
        raise MotionPlcError("--group needs a G-code program")
    trace_path = _check_output("--trace", args.trace, TRACE_SUFFIXES)
    plot_path = _check_output("--plot", args.plot, PLOT_SUFFIXES)
    _plausibility_warnings(cfg)
    script = _load_script(args.script, cfg, args.group) if args.script else None
    if script is not None:
        _plausibility_warnings(cfg, script)
    cfg = _apply_realtime_options(cfg, args)
    max_overruns = getattr(cfg.runtime, "max_overruns", None)
    overrun_source = "--max-overruns" if args.max_overruns is not None else "runtime.max_overruns"
    # an operator acts in real time: --opcua (or an opcua: block) runs on the wall clock
    operated = args.opcua or cfg.opcua is not None or args.hmi or cfg.hmi is not None
    wants_rt = args.realtime or operated
    machine = _build(cfg, True if wants_rt else None)
    failures: list[str] = []
    interrupted = False
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
        operator = None
        if operated:  # the operator process: OPC UA server, web HMI (motionplc.operator)
            from motionplc.operator.run import start_operator

            operator = start_operator(
                machine,
                runner,
                task if runner is not None else None,
                opcua=args.opcua or cfg.opcua is not None,
                hmi=args.hmi or cfg.hmi is not None,
            )
        elif runner is not None:
            machine.attach(runner, task)
        rt = machine.runtime
        realtime = bool(rt.clock.realtime)
        limit = args.seconds
        if limit is None and operator is not None and runner is None:
            limit = 10 * 365 * 86400.0  # an operator's machine idles until Ctrl-C
        if limit is None:
            limit = 1.0 if runner is None else getattr(script, "timeout", 600.0) + rt.cycle
        mode = "real time" if realtime else "simulated time"
        program_error = ""
        progress = _Progress(limit, args.quiet, rt.cycle)
        timer = _TickTimer()

        def stop_now() -> bool:
            # one run, no slices: a slice boundary is housekeeping between cycles, a gap on
            # the bus in real time; called after every tick, so it only reads flags (and the
            # stopwatch: the simulated time is not touched)
            timer.tick()
            if ending.signal or (runner is not None and runner.over):
                return True
            progress.update(rt.time)
            return False

        ending = _Ending(rt)
        try:
            ending.install()
            if not args.quiet:  # inside the try: Ctrl-C once this is shown gives the summary
                what = f" with {args.script}" if args.script else ""
                print(
                    f"running {args.config}{what} ({mode}, tick {rt.cycle * 1e3:g} ms)", flush=True
                )
                if operator is not None:
                    print(operator.line(), flush=True)
            if rt.time < limit - 1e-9:
                timer.restart()
                rt.run_until(stop_now, max_seconds=limit - rt.time)
        except KeyboardInterrupt:  # (before the handler was in place)
            ending.signal = ending.signal or "SIGINT"
        except ProgramError as exc:  # the task halted, its axes are at rest
            program_error = str(exc)
            if runner is None or not runner.failures:
                failures.append(program_error)
        except MotionPlcError as exc:  # a drive that does not open at the start of the run
            ending.restore()
            located = _located_build_error(cfg, exc)
            if located is exc:
                raise
            raise located from exc
        finally:
            progress.close()
        if ending.signal:
            interrupted = ending.signal == "SIGINT"
            failures.append(f"{ending.words()} at t = {rt.time:.3f} s")
        # every way out is a controlled stop: axes and groups to rest, drives switched off,
        # those cycles in the trace (a second Ctrl-C meanwhile: a quick stop)
        t_run = rt.time  # the run's end; the stop's cycles follow
        end_states = {n: ax.state.name for n, ax in rt.axes.items()}
        end_states.update({n: g.state.name for n, g in rt.groups.items()})
        over = runner is not None and runner.over
        why = (
            ending.words()
            if ending.signal
            else "program error"
            if program_error
            else "a failure"
            if failures or (runner is not None and runner.failed)
            else "end of the run"
            if over or runner is None
            else "end of --seconds"
            if args.seconds is not None
            else "timeout"
        )
        ending.stopping = True
        try:
            stop = rt.shutdown(why)
        finally:
            ending.restore()
            if operator is not None:
                operator.close()
        if stop.quick and not ending.signal:
            interrupted = True
            failures.append("quick stop (Ctrl-C during the stop at the end of the run)")
        elif stop.quick:
            failures.append("quick stop (a second signal during the stop at the end of the run)")
        for line in stop.lines()[1:]:
            failures.append(line)
        if runner is not None:
            failures.extend(runner.failures)
            if not runner.finished and not runner.failed and not failures:
                failures.append(
                    f"{args.script}: did not finish within {t_run:g} s"
                    + ("" if args.seconds is None else " (--seconds)")
                )
        for name, ax in machine.axes.items():
            if ax.state is AxisState.ERROR_STOP and not any(f"{name!r}" in f for f in failures):
                failures.append(f"axis {name!r} ends in ERROR_STOP ({axis_error_text(ax)})")
        if rt.error_reason and rt.error_reason != program_error:
            failures.append(rt.error_reason)
        if max_overruns is not None:
            for st in rt.stats().values():
                if st.overruns > max_overruns:
                    failures.append(
                        f"task {st.name!r}: {_plural(st.overruns, 'overrun')} in "
                        f"{_plural(st.cycle_count, 'cycle')}, more than the {max_overruns} "
                        f"allowed ({overrun_source})"
                    )
        if trace_path is not None:
            _write_trace(trace_path, rt)
        if plot_path is not None:
            from motionplc import scope

            _write_plot(plot_path, scope.trace_from_runtime(rt), str(args.config), "--plot")
        report = _realtime_report(rt.clock)
        if not args.quiet or failures:
            print()
            for line in _summary(machine, runner, timer, realtime, end_states):
                print(line)
            print(stop.lines()[0])
            if report is not None:
                print(report)
            print()
        elif report is not None and "refused" in report:
            print(report)
        t_end = getattr(runner, "t_finished", None)
        if failures:
            for f in failures:
                print(f"FAILED: {f}", file=sys.stderr)
            if ending.signal == "SIGTERM":
                return EXIT_TERMINATED
            return EXIT_INTERRUPTED if interrupted else EXIT_FAILED
        if runner is not None and hasattr(runner, "report"):
            print(f"ok: {runner.report()}")
        elif runner is not None:
            print(f"ok: {args.script} finished at t = {t_end:.3f} s, all expectations met")
        else:
            print(f"ok: ran {t_run:g} s")
        return EXIT_OK
    finally:
        machine.close()


def _write_trace(path: Path, rt: Any) -> None:
    """Write ``--trace`` (CSV or Parquet), its FB edges and, with groups, the groups sidecar."""
    from motionplc import scope

    parquet = path.suffix.lower() == ".parquet"
    events = path.with_suffix(".events.parquet" if parquet else ".events.csv")
    with _writing("--trace", path):
        if parquet:
            rt.trace.to_parquet(path, events_path=events)
        else:
            rt.trace.to_csv(path, events_path=events)
        written = [events]
        if not parquet:  # the units of a CSV are in a sidecar (Parquet: schema metadata)
            from motionplc.runtime.trace import units_sidecar_path

            units = units_sidecar_path(path)
            if units.is_file() and rt.trace.units:
                written.append(units)
        if rt.groups:
            written.append(
                scope.write_groups_sidecar(
                    path, {n: list(g.axis_names) for n, g in rt.groups.items()}
                )
            )
        also = "".join(f", {w}" for w in written[:-1]) + f" and {written[-1]}"
    tr = rt.trace
    kept = ""
    if tr.dropped_rows or tr.dropped_events:
        kept = (
            f"; the last {len(tr)} cycles: {tr.dropped_rows} older rows and "
            f"{tr.dropped_events} FB edges dropped by the trace bound of "
            f"{tr.rows_capacity} rows / {tr.max_bytes / 2**20:g} MiB"
        )
    print(f"wrote {path} ({_plural(len(tr), 'row')}{kept}){also}")


# ---------------------------------------------------------------------------- plots
def _cmd_plot(args: argparse.Namespace) -> int:
    from motionplc import scope

    path = Path(args.trace)
    if path.suffix.lower() not in TRACE_SUFFIXES:
        raise MotionPlcError(
            f"{path}: unsupported trace type {path.suffix or '(none)'!r} "
            f"(allowed: {', '.join(TRACE_SUFFIXES)}, as written by run --trace)"
        )
    out = _check_output("--output", args.output, PLOT_SUFFIXES) or _check_output(
        "--output", str(path.with_suffix(".png")), PLOT_SUFFIXES
    )
    assert out is not None
    trace = scope.read_trace(path)
    _write_plot(out, trace, str(path), "--output")
    return EXIT_OK


def _write_plot(out: Path, trace: Any, title: str, option: str) -> None:
    """Write a scope plot (:func:`motionplc.scope.write_plot`); a missing plotting package is
    a one-line MotionPlcError (``scope.PlotDependencyError``)."""
    from motionplc import scope

    with _writing(option, out):
        scope.write_plot(out, trace, title)
    print(f"wrote {out}")


# ---------------------------------------------------------------------------- drives
def _cmd_drives(args: argparse.Namespace) -> int:
    import asyncio
    import json
    import signal

    from motionplc.config import load_config
    from motionplc.fieldbus.drives_main import DrivesSpec, DrivesStartError, run_drives

    cfg = load_config(args.config)
    specs: list[tuple[Any, DrivesSpec]] = []
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
                (
                    bus,
                    DrivesSpec(
                        can_nodes=tuple(a.drive.node_id for a in axes if a.drive.node_id),
                        can_interface=bus.interface,
                        can_channel=bus.channel,
                        duration=args.duration,
                    ),
                )
            )
        else:
            # one server on the bus's port with every unit of the bus, as 'motionplc run'
            # reaches them (host:port, unit id); no word_order: the register map's, big for
            # motionplc-v1
            units = [a.drive for a in axes if a.drive.unit_id]
            if units:
                specs.append(
                    (
                        bus,
                        DrivesSpec(
                            modbus=tuple(u.unit_id for u in units),
                            modbus_port=bus.port,
                            modbus_shared=True,
                            modbus_word_orders=tuple(u.word_order or "big" for u in units),
                            duration=args.duration,
                        ),
                    )
                )
    if not specs:
        raise MotionPlcError(f"{args.config}: no drives to serve in this configuration")

    def located(bus: Any, exc: DrivesStartError) -> str:
        if exc.kind == "modbus":
            host = bus.host if bus.host else "127.0.0.1"
            return _port_in_use(cfg.path, bus.name, host, exc.port, exc.reason)
        line = _yaml_line(cfg.path, ("buses", bus.name))
        return f"{cfg.path}:{line}: buses.{bus.name}: {exc}"

    async def serve() -> None:
        stop = asyncio.Event()
        loop = asyncio.get_running_loop()
        for sig in (signal.SIGTERM, signal.SIGINT):
            try:
                loop.add_signal_handler(sig, stop.set)
            except (NotImplementedError, RuntimeError):
                pass

        async def one(bus: Any, spec: DrivesSpec) -> None:
            def ready(info: dict[str, object]) -> None:
                if args.json:
                    print(json.dumps(info), flush=True)
                else:
                    print(_drives_summary(bus, cfg, info, args.duration), flush=True)

            try:
                await run_drives(spec, ready=ready, stop=stop)
            except DrivesStartError as exc:
                stop.set()  # the others end too
                raise MotionPlcError(located(bus, exc)) from exc

        await asyncio.gather(*(one(bus, s) for bus, s in specs))

    asyncio.run(serve())  # a server that cannot start: MotionPlcError, exit code 2
    return EXIT_OK


def _drives_summary(bus: Any, cfg: Any, info: dict[str, Any], duration: float | None) -> str:
    """One readable line of what ``drives`` serves on ``bus`` (``--json``: the raw record)."""
    axes = [a for a in cfg.axes if a.drive.bus == bus.name]
    until = f"for {_num(duration)} s" if duration is not None else "until Ctrl-C or SIGTERM"
    if bus.type == "can":
        can = info.get("can", {})
        nodes = ", ".join(f"node {a.drive.node_id} ({a.name})" for a in axes if a.drive.node_id)
        where = f"CAN {can.get('interface', bus.interface)} {can.get('channel', bus.channel)}"
        return f"bus {bus.name!r}: {where}: {nodes}; serving {until}"
    ports = info.get("modbus", {})
    units = ", ".join(f"unit {a.drive.unit_id} ({a.name})" for a in axes if a.drive.unit_id)
    port = next(iter(ports.values()), bus.port)
    return f"bus {bus.name!r}: Modbus TCP on 127.0.0.1:{port}: {units}; serving {until}"


# ---------------------------------------------------------------------------- schema
def _cmd_schema(args: argparse.Namespace) -> int:
    import json

    from motionplc import schema

    if args.format == "json":
        text = json.dumps(schema.json_schema(args.kind), indent=2, ensure_ascii=False) + "\n"
    else:
        text = schema.reference_markdown(args.kind)
        text = text if text.endswith("\n") else text + "\n"
    if args.output is None:
        sys.stdout.write(text)
        return EXIT_OK
    suffixes = (".json",) if args.format == "json" else (".md", ".markdown")
    out = _check_output("--output", args.output, suffixes)
    assert out is not None
    with _writing("--output", out):
        out.write_text(text, encoding="utf-8")
    print(f"wrote {out} ({args.kind}, {args.format})")
    return EXIT_OK


# ---------------------------------------------------------------------------- examples
def _cmd_examples(args: argparse.Namespace) -> int:
    from motionplc.examples import copy_examples

    written = copy_examples(args.dir, overwrite=args.force)
    print(f"wrote {len(written)} example files to {args.dir}")
    d = Path(args.dir)
    print(f"  try: motionplc run {d / 'demo.yaml'} {d / 'demo_sequence.yaml'}")
    return EXIT_OK


# ---------------------------------------------------------------------------- parser
_VERBOSE_HELP = (
    "show the log of the fieldbus libraries (pymodbus, canopen, python-can): -v warnings and "
    "errors, -vv everything (default: quiet; bus failures are reported as axis errors)"
)


class _Formatter(argparse.RawDescriptionHelpFormatter):
    """Keeps the epilog's line breaks (exit-code table); help texts state their defaults."""


def build_parser() -> argparse.ArgumentParser:
    """The argument parser of ``motionplc`` (every option documented with default and unit)."""
    common = argparse.ArgumentParser(add_help=False)
    common.add_argument(
        "--debug",
        action="store_true",
        default=argparse.SUPPRESS,
        help="print the traceback of an internal error (default: one line)",
    )
    parser = argparse.ArgumentParser(
        prog="motionplc",
        description="Soft-PLC motion-control runtime: run, check and plot machine "
        "configurations with PLCopen sequences, Python programs or G-code.",
        formatter_class=_Formatter,
        epilog=EXIT_CODES_HELP,
        parents=[common],
    )
    parser.add_argument(
        "--version",
        action=_VersionAction,
        nargs=0,
        help="print the version and the planning core in use (compiled or pure Python)",
    )
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")

    def command(name: str, help_text: str) -> argparse.ArgumentParser:
        return sub.add_parser(
            name,
            help=help_text,
            description=help_text[:1].upper() + help_text[1:] + ".",
            parents=[common],
            formatter_class=_Formatter,
            epilog=EXIT_CODES_HELP,
        )

    r = command("run", "run a configuration with a sequence, a Python program or a G-code program")
    r.add_argument("config", help="machine configuration (YAML)")
    r.add_argument(
        "script",
        nargs="?",
        help="sequence (.yaml), Python program (.py) or G-code program (.ngc, .nc, .gcode, "
        ".tap); without one, the machine idles for --seconds",
    )
    r.add_argument(
        "--group",
        help="the axes group a G-code program runs on (default: the only configured group)",
    )
    r.add_argument(
        "--realtime",
        action="store_true",
        help="run on the wall clock (default: the configuration's runtime.clock, simulated)",
    )
    r.add_argument(
        "--seconds",
        type=_seconds,
        default=None,
        metavar="S",
        help="time limit [s]: the run ends when the script finishes, at the latest after S "
        "(default: the script's timeout; 1 s without a script)",
    )
    r.add_argument(
        "--max-overruns",
        type=_count,
        default=None,
        metavar="N",
        help="fail the run if a task has more than N overruns (default: "
        "runtime.max_overruns, else no limit)",
    )
    r.add_argument(
        "--rt-priority",
        type=_priority,
        default=None,
        metavar="N",
        help="real time: SCHED_FIFO priority 1..99 (default: runtime.realtime.priority, else "
        "the normal scheduler)",
    )
    r.add_argument(
        "--cpus",
        type=_cpus,
        default=None,
        metavar="LIST",
        help="real time: pin the process to these CPUs, e.g. 0,1 or 2-3 (default: "
        "runtime.realtime.cpus, else all)",
    )
    r.add_argument(
        "--lock-memory",
        action="store_true",
        help="real time: lock the process' memory (mlockall) (default: "
        "runtime.realtime.lock_memory, else off)",
    )
    r.add_argument(
        "--trace",
        metavar="FILE",
        help="write the trace: .csv or .parquet (FB edges to FILE.events.csv/.parquet) "
        "(default: none)",
    )
    r.add_argument(
        "--plot",
        metavar="FILE",
        help="write a scope plot: .png or interactive .html (default: none)",
    )
    r.add_argument(
        "--quiet",
        "-q",
        action="store_true",
        help="no progress and, unless the run fails, no summary table (default: progress bar "
        "on a terminal, else a line every 5 s of simulated time)",
    )
    r.add_argument(
        "--opcua",
        action="store_true",
        help="serve the machine over OPC UA (the config's opcua: block, else 127.0.0.1:4840, "
        "Sign/SignAndEncrypt); implies --realtime; without a script the machine idles until "
        "Ctrl-C (default: only with an opcua: block)",
    )
    r.add_argument(
        "--hmi",
        action="store_true",
        help="serve the live web HMI (the config's hmi: block, else http://127.0.0.1:8480/ with "
        "the opcua: users); implies --realtime; without a script the machine idles until "
        "Ctrl-C (default: only with an hmi: block)",
    )
    r.add_argument("--verbose", "-v", action="count", default=0, help=_VERBOSE_HELP)
    r.set_defaults(func=_cmd_run)

    v = command("validate", "check a configuration (and a sequence, program or G-code program)")
    v.add_argument("config", help="machine configuration (YAML)")
    v.add_argument(
        "script",
        nargs="?",
        help="sequence (.yaml), Python program (.py) or G-code program (.ngc, .nc, .gcode, .tap)",
    )
    v.add_argument(
        "--group",
        help="the axes group of a G-code program (default: the only configured group)",
    )
    v.set_defaults(func=_cmd_validate)

    pl = command(
        "plot",
        "plot a trace: p/v/a/j and FB-state lanes per axis, and per axes group its path in "
        "space coloured by path speed",
    )
    pl.add_argument(
        "trace",
        help="trace written by run --trace, .csv or .parquet (groups from TRACE.groups.json "
        "if present)",
    )
    pl.add_argument(
        "-o",
        "--output",
        "--out",
        metavar="FILE",
        help="output .png or interactive .html (default: TRACE with .png)",
    )
    pl.set_defaults(func=_cmd_plot)

    d = command("drives", "serve the virtual drives of a configuration on their own")
    d.add_argument("config", help="machine configuration (YAML) whose drives to serve")
    d.add_argument(
        "--duration",
        type=_seconds,
        default=None,
        metavar="S",
        help="serve for S seconds [s] (default: until Ctrl-C or SIGTERM)",
    )
    d.add_argument(
        "--json",
        action="store_true",
        help="announce each bus as one JSON line (ports, nodes) for scripts (default: a "
        "readable line)",
    )
    d.add_argument("--verbose", "-v", action="count", default=0, help=_VERBOSE_HELP)
    d.set_defaults(func=_cmd_drives)

    p = command("plan", "plan one time-optimal move and print its phases")
    for name, default, what, unit in (
        ("p0", 0.0, "start position", "m or rad"),
        ("v0", 0.0, "start velocity", "m/s"),
        ("a0", 0.0, "start acceleration", "m/s^2"),
        ("pf", 6.0, "target position", "m or rad"),
        ("vf", 0.0, "target velocity", "m/s"),
        ("af", 0.0, "target acceleration", "m/s^2"),
        ("v-max", 1.8, "velocity limit", "m/s"),
        ("a-max", 1.2, "acceleration limit", "m/s^2"),
        ("j-max", 1.0, "jerk limit (inf: trapezoidal profile)", "m/s^3"),
    ):
        p.add_argument(
            f"--{name}",
            type=_number,
            default=default,
            metavar="X",
            help=f"{what} [{unit}] (default: {default:g})",
        )
    p.add_argument(
        "--v-min",
        type=_number,
        default=None,
        metavar="X",
        help="lowest velocity [m/s], negative (default: -v_max)",
    )
    p.add_argument(
        "--a-min",
        type=_number,
        default=None,
        metavar="X",
        help="lowest acceleration [m/s^2], negative (default: -a_max)",
    )
    p.add_argument(
        "--dt",
        type=_number,
        default=0.001,
        metavar="S",
        help="sample period of --csv and --plot [s] (default: 0.001)",
    )
    p.add_argument(
        "--csv", metavar="FILE", help="write the sampled profile t,p,v,a,j as CSV (default: none)"
    )
    p.add_argument(
        "--plot",
        metavar="FILE",
        help="plot p, v, a, j over time: .png or interactive .html (default: none)",
    )
    p.set_defaults(func=_cmd_plan)

    sc = command("schema", "print the JSON Schema or the reference of a file kind")
    sc.add_argument(
        "kind",
        nargs="?",
        default="config",
        choices=SCHEMA_KINDS,
        help="machine configuration, sequence or Modbus register map (default: config)",
    )
    sc.add_argument(
        "--format",
        choices=("json", "markdown"),
        default="json",
        help="JSON Schema (for editors) or the Markdown reference (default: json)",
    )
    sc.add_argument(
        "-o", "--output", metavar="FILE", help="write to FILE instead of stdout (default: stdout)"
    )
    sc.set_defaults(func=_cmd_schema)

    from motionplc.campaign.cli import add_command as add_campaign_command

    add_campaign_command(command)  # motionplc campaign (motionplc/campaign/cli.py)

    ex = command("examples", "copy the shipped example machines and programs into a folder")
    ex.add_argument("dir", metavar="DIR", help="destination folder (created if missing)")
    ex.add_argument(
        "--force", action="store_true", help="replace files that exist (default: refuse)"
    )
    ex.set_defaults(func=_cmd_examples)
    return parser


def _exit_status(code: object) -> int:
    """A SystemExit code as an exit status (argparse: 0 for --help, 2 for bad options)."""
    if code is None:
        return EXIT_OK
    return code if isinstance(code, int) else EXIT_INVALID


def main(argv: Sequence[str] | None = None) -> int:
    """Run one ``motionplc`` command; returns the exit code (see the module docs).

    Never raises for anything a user can cause: errors are one line on stderr."""
    parser = build_parser()
    try:
        args = parser.parse_args(argv)
    except SystemExit as exc:  # --help, --version, bad options (argparse printed them)
        return _exit_status(exc.code)
    debug = bool(getattr(args, "debug", False))
    func: Callable[[argparse.Namespace], int] = args.func
    try:
        if args.command in ("run", "drives"):
            with log_routing(args.verbose):
                return int(func(args))
        return int(func(args))
    except MotionPlcError as exc:
        if debug:
            traceback.print_exc()
        print(f"motionplc: error: {exc}", file=sys.stderr)
        return EXIT_INVALID
    except KeyboardInterrupt:
        print("motionplc: interrupted", file=sys.stderr)
        return EXIT_INTERRUPTED
    except OSError as exc:
        if debug:
            traceback.print_exc()
        where = f"{exc.filename}: " if exc.filename else ""
        print(f"motionplc: error: {where}{_reason(exc)}", file=sys.stderr)
        return EXIT_INVALID
    except Exception as exc:  # noqa: BLE001 - the last resort: one line, never a traceback
        if debug:
            traceback.print_exc()
        text = str(exc).splitlines()[0] if str(exc) else ""
        print(
            f"motionplc: internal error: {type(exc).__name__}"
            + (f": {text}" if text else "")
            + ("" if debug else " (run with --debug for the traceback)"),
            file=sys.stderr,
        )
        return EXIT_INTERNAL


if __name__ == "__main__":
    raise SystemExit(main())
