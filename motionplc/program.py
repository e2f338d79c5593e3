"""Python programs: a module with ``program(ctx)`` and its FB instances, run by the runtime.

::

    # configs/my_program.py
    from motionplc.blocks import MC_MoveAbsolute, MC_Power

    TASK = "motion"      # optional (default: the first task)
    TIMEOUT = 30.0       # optional [s] of (virtual) time
    power = MC_Power()
    move = MC_MoveAbsolute()

    def program(ctx):
        x = ctx.axes["x"]
        power(axis=x, enable=True)
        move(axis=x, execute=power.status, position=1.0, velocity=0.5)
        if move.done:
            ctx.expect("x.position", x.position, 1.0, within=1e-9)
            ctx.done()

``ctx`` (:class:`ProgramContext`) has ``t``, ``dt``, ``cycle``, ``axes``, ``groups``,
``machine``, ``inputs``/``outputs`` (process image), ``done()``, ``fail(msg)`` and
``expect(name, actual, expected, within)``. A module may also define ``setup(ctx)``, called
once before the first cycle. An exception raised by the program fails the run with the file
and line where it happened (the runtime keeps its state).

Every message about a program names its file as given (relative paths stay relative) and the
line in it: an exception at import or in ``program``/``setup`` the program's own line where it
happened (the last frame in the file, whatever the working directory), a failed
``ctx.expect``/``ctx.fail`` the line that called it, a bad ``TASK``/``TIMEOUT`` the line that
assigns it.
"""

from __future__ import annotations

import ast
import importlib.util
import inspect
import sys
import traceback
import uuid
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from pathlib import Path
from types import ModuleType
from typing import TYPE_CHECKING, Any

from motionplc.errors import ConfigError

if TYPE_CHECKING:
    from motionplc.blocks.axis import Axis
    from motionplc.config import Machine
    from motionplc.runtime import CycleContext

__all__ = ["Program", "ProgramContext", "ProgramRunner", "load_program"]


@dataclass(frozen=True, slots=True)
class Program:
    path: str
    module: ModuleType
    program: Callable[[Any], Any]
    setup: Callable[[Any], Any] | None
    task: str | None
    timeout: float


def load_program(path: str | Path) -> Program:
    """Import a program file (under a private module name, not added to ``sys.modules``)."""
    p = Path(path)
    if not p.is_file():
        raise ConfigError(f"{p}: cannot read: no such file")
    spec = importlib.util.spec_from_file_location(f"motionplc_program_{uuid.uuid4().hex}", p)
    if spec is None or spec.loader is None:
        raise ConfigError(f"{p}: cannot load as a Python module")
    module = importlib.util.module_from_spec(spec)
    try:
        spec.loader.exec_module(module)
    except SyntaxError as exc:
        raise ConfigError(f"{p}:{exc.lineno or 1}: syntax error: {exc.msg}") from None
    except (Exception, SystemExit) as exc:  # noqa: BLE001 - reported as a configuration error
        line = _user_line(exc, p)
        raise ConfigError(f"{p}:{line}: import failed: {type(exc).__name__}: {exc}") from None
    prog = getattr(module, "program", None)
    if not callable(prog):
        raise ConfigError(
            f"{p}:{_assign_line(p, 'program')}: program: "
            f"{'missing' if prog is None else f'not a function: {type(prog).__name__}'} "
            "(allowed: a function program(ctx))"
        )
    try:
        nparams = len(inspect.signature(prog).parameters)
    except (TypeError, ValueError):
        nparams = 1
    if nparams != 1:
        line = getattr(getattr(prog, "__code__", None), "co_firstlineno", 1)
        raise ConfigError(
            f"{p}:{line}: program: takes {nparams} parameters (allowed: one, program(ctx))"
        )
    setup = getattr(module, "setup", None)
    task = getattr(module, "TASK", None)
    timeout = getattr(module, "TIMEOUT", 600.0)
    if task is not None and not isinstance(task, str):
        raise ConfigError(
            f"{p}:{_assign_line(p, 'TASK')}: TASK: got {task!r} (allowed: a task name)"
        )
    if isinstance(timeout, bool) or not isinstance(timeout, (int, float)) or not timeout > 0:
        raise ConfigError(
            f"{p}:{_assign_line(p, 'TIMEOUT')}: TIMEOUT: got {timeout!r} (allowed: a number > 0)"
        )
    return Program(str(p), module, prog, setup if callable(setup) else None, task, float(timeout))


def _assign_line(path: Path, name: str) -> int:
    """The line of the last top-level statement of ``path`` that binds ``name`` (an assignment,
    ``def``, ``class`` or import), else 1."""
    try:
        tree = ast.parse(path.read_text(), str(path))
    except (OSError, SyntaxError, ValueError):
        return 1
    line = 1
    for node in tree.body:
        targets: list[ast.expr] = []
        if isinstance(node, ast.Assign):
            targets = list(node.targets)
        elif isinstance(node, (ast.AnnAssign, ast.AugAssign)):
            targets = [node.target]
        elif isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
            if node.name == name:
                line = node.lineno
            continue
        elif isinstance(node, (ast.Import, ast.ImportFrom)):
            if any((a.asname or a.name.split(".")[0]) == name for a in node.names):
                line = node.lineno
            continue
        for t in targets:
            if any(isinstance(n, ast.Name) and n.id == name for n in ast.walk(t)):
                line = node.lineno
    return line


def _caller_line(path: Path) -> int | None:
    """The line of the innermost frame of the call stack that runs code of ``path``."""
    path = path.resolve()
    frame = sys._getframe(1)
    while frame is not None:
        if Path(frame.f_code.co_filename).resolve() == path:
            return frame.f_lineno
        frame = frame.f_back
    return None


def _user_line(exc: BaseException, path: Path) -> int:
    """The line of the last traceback frame in ``path`` (compared as resolved paths: a
    program loaded by a relative path has relative code file names), else 1."""
    path = path.resolve()
    frames = [
        f for f in traceback.extract_tb(exc.__traceback__) if Path(f.filename).resolve() == path
    ]
    return frames[-1].lineno or 1 if frames else 1


class ProgramContext:
    """What ``program(ctx)`` sees. Updated in place every cycle."""

    def __init__(self, runner: ProgramRunner, machine: Machine) -> None:
        self._runner = runner
        self.machine = machine
        self.axes: Mapping[str, Axis] = machine.axes
        self.groups: Mapping[str, tuple[str, ...]] = machine.groups
        self.cycle_ctx: CycleContext | None = None
        self.vars: dict[str, Any] = {}  # user state that survives cycles

    @property
    def t(self) -> float:
        return self.cycle_ctx.t if self.cycle_ctx is not None else 0.0

    @property
    def dt(self) -> float:
        return self.cycle_ctx.dt if self.cycle_ctx is not None else 0.0

    @property
    def cycle(self) -> int:
        return self.cycle_ctx.cycle if self.cycle_ctx is not None else 0

    @property
    def inputs(self) -> Mapping[str, Any]:
        assert self.cycle_ctx is not None
        return self.cycle_ctx.inputs

    @property
    def outputs(self) -> dict[str, Any]:
        assert self.cycle_ctx is not None
        return self.cycle_ctx.outputs

    def done(self) -> None:
        """The program has finished (the run ends; FBs keep their last state)."""
        self._runner.finish()

    def fail(self, message: str) -> None:
        """Fail the run with ``message`` (located at the program line that called this)."""
        self._runner.fail(message, _caller_line(Path(self._runner.program.path)))

    def expect(self, name: str, actual: Any, expected: Any, within: float = 1e-6) -> bool:
        """Check a value; a mismatch fails the run. Returns whether it matched."""
        if isinstance(expected, (bool, str)) or not isinstance(actual, (int, float)):
            ok = actual == expected
            want = repr(expected)
        else:
            ok = abs(actual - expected) <= within
            want = f"{expected:g} within {within:g}"
        if not ok:
            self._runner.fail(
                f"expectation failed at t = {self.t:.3f} s: {name} = {actual!r}, expected {want}",
                _caller_line(Path(self._runner.program.path)),
            )
        return ok


class ProgramRunner:
    """Runs a :class:`Program` as a task program; same outcome interface as SequenceRunner."""

    def __init__(self, program: Program, machine: Machine) -> None:
        self.program = program
        self.machine = machine
        self.ctx = ProgramContext(self, machine)
        self.finished = False
        self.failures: list[str] = []
        self.t_finished: float | None = None
        self._setup_done = False
        self.steps_done = 0

    @property
    def failed(self) -> bool:
        return bool(self.failures)

    @property
    def over(self) -> bool:
        return self.finished or self.failed

    def finish(self) -> None:
        if not self.finished:
            self.finished = True
            self.t_finished = self.ctx.t

    def fail(self, message: str, line: int | None = None) -> None:
        """Record a failure ``FILE:LINE: message`` (``FILE: message`` without a line)."""
        where = self.program.path if line is None else f"{self.program.path}:{line}"
        self.failures.append(f"{where}: {message}")

    def __call__(self, ctx: CycleContext) -> None:
        self.ctx.cycle_ctx = ctx
        if self.failed:
            return
        try:
            if not self._setup_done:
                self._setup_done = True
                if self.program.setup is not None:
                    self.program.setup(self.ctx)
            self.program.program(self.ctx)
        except SystemExit as exc:
            # sys.exit() in a program would end the process with its axes in motion: a program
            # error like any other (the task halts, its axes stop under control)
            line = _user_line(exc, Path(self.program.path))
            self.failures.append(
                f"{self.program.path}:{line}: program called sys.exit({exc.code!r}); a program "
                f"ends with ctx.done() or ctx.fail(message) (t = {ctx.t:.3f} s)"
            )
            raise RuntimeError(f"program called sys.exit({exc.code!r})") from None
        except Exception as exc:
            # a user program error fails the run; the runtime halts the task and brings its
            # axes to a controlled stop (Runtime.run raises ProgramError once they are at rest)
            line = _user_line(exc, Path(self.program.path))
            self.failures.append(
                f"{self.program.path}:{line}: program raised {type(exc).__name__}: {exc} "
                f"(t = {ctx.t:.3f} s)"
            )
            raise
        if not self.finished and ctx.t >= self.program.timeout - 1e-12:
            self.fail(
                f"timeout: the program did not call ctx.done() within {self.program.timeout:g} s"
            )
