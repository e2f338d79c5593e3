"""FB base classes: the PLCopen Execute/Enable interface rules, implemented once.

Calling convention (IEC semantics): ``fb(axis=x, execute=True, position=1.0)`` updates the given
inputs (an omitted input keeps its previous value; an unknown keyword raises ``TypeError``),
runs one scan and returns the FB. Outputs are attributes.

Execute FBs (spec 2.1, Fig. 7/8):

* inputs are latched on the rising edge of ``execute``;
* while ``execute`` is TRUE exactly one of busy/done/error/command_aborted is TRUE;
* done/error/command_aborted are held while ``execute`` stays TRUE and reset in the scan in
  which it falls; if ``execute`` is already FALSE when they occur they are shown for exactly
  one scan;
* a rising edge while busy re-triggers: the new command takes over and the old one gives no
  feedback (``retrigger_ignored=True`` selects the Beckhoff behaviour: the edge is ignored).

Enable FBs: ``valid`` (or ``enabled``) and ``error`` are mutually exclusive and are computed in
the same scan as ``enable`` (Valid rises in the scan of Enable's rising edge); everything is
reset in the scan in which ``enable`` falls. Errors of Enable FBs clear by themselves when the
condition disappears (busy stays TRUE meanwhile).

Timing: the motion kernel runs after the program, so changes it makes (Active, Done, ...)
appear at the FB's next call. A command rejected at submission (bad input, state violation,
queue full) shows ``error`` in the calling scan; ``error_text`` says why.

Fault barrier: no exception of an FB's scan escapes the call (and so the cycle). A bad input is
an ``InputError`` (ErrorID of the input, its allowed range in ``error_text``); anything else is a
defect and ends the FB's command with Error ``ErrorID.INTERNAL_ERROR`` (the exception in
``error_text``). Only an unknown input keyword or an ``axis`` that is not an Axis raise
``TypeError`` (programming errors, found on the first call).
"""

from __future__ import annotations

import math
import reprlib
from operator import attrgetter
from typing import TYPE_CHECKING, Any, ClassVar

from motionplc.blocks.axis import Axis, Handle, Status
from motionplc.blocks.enums import ErrorID, ExecutionMode

if TYPE_CHECKING:
    from motionplc.runtime.trace import Trace


class FunctionBlock:
    """Common machinery: persistent inputs, keyword calls, output edges for the trace."""

    INPUTS: ClassVar[tuple[str, ...]] = ("axis",)
    OUTPUTS: ClassVar[tuple[str, ...]] = ()  # boolean outputs (traced as edges)
    _input_set: ClassVar[frozenset[str]] = frozenset()
    _get_outputs: ClassVar[Any] = staticmethod(lambda fb: ())

    def __init_subclass__(cls, **kw: Any) -> None:
        super().__init_subclass__(**kw)
        cls._input_set = frozenset(cls.INPUTS)
        outs = cls.OUTPUTS
        if len(outs) == 1:
            getter = attrgetter(outs[0])
            cls._get_outputs = staticmethod(lambda fb: (getter(fb),))
        elif outs:
            cls._get_outputs = staticmethod(attrgetter(*outs))

    def __init__(self, name: str | None = None, **inputs: Any) -> None:
        if name is not None and not isinstance(name, str):
            # MC_Power(ax) would otherwise name the FB after the axis and leave it unconnected
            raise TypeError(
                f"{type(self).__name__}: the first positional argument is the FB's name (a str),"
                f" got {type(name).__name__}; connect an axis with axis=..."
            )
        self.axis: Axis | None = None
        self.name = name
        self._registered: Axis | None = None
        self._traced_bits: tuple[Any, ...] = (False,) * len(self.OUTPUTS)
        # True when a traced output may have changed since the last edge emission; the scan
        # fast paths leave it alone, so the trace skips the FBs whose outputs did not change
        self._dirty = True
        self.error = False
        self.error_id = ErrorID.OK
        self.error_text = ""
        self._set_inputs(inputs)

    def _set_inputs(self, kw: dict[str, Any]) -> None:
        if not self._input_set.issuperset(kw):
            k = next(k for k in kw if k not in self._input_set)
            raise TypeError(
                f"{type(self).__name__}() got an unknown input {k!r}; "
                f"inputs: {', '.join(self.INPUTS)}"
            )
        # setattr, not ``__dict__.update``: touching ``__dict__`` turns the instance's inline
        # attribute values into a dict, and every later attribute access gets slower
        for k, v in kw.items():
            setattr(self, k, v)

    def __call__(self, **inputs: Any) -> Any:
        """One scan. Keyword arguments update the (persistent) inputs first; the lean hot
        path is ``fb()`` with the inputs set as attributes when they change."""
        if inputs:  # inlined _set_inputs
            if not self._input_set.issuperset(inputs):
                self._set_inputs(inputs)  # raises TypeError naming the unknown input
            for k, v in inputs.items():
                setattr(self, k, v)
        axis = self.axis
        if axis is not self._registered and axis is not None:
            if not isinstance(axis, Axis):  # a bad input is the FB's Error, not an exception
                self._dirty = True
                self.error = True
                self.error_id = ErrorID.INVALID_AXIS
                self.error_text = (
                    f"{type(self).__name__}: axis must be an Axis (ctx.axes['name']), "
                    f"got {reprlib.repr(axis)}"
                )
                return self
            trace_name = axis.register(self)
            if self.name is None:
                self.name = trace_name
            self._registered = axis
        try:
            self._scan()
        except Exception as exc:  # noqa: BLE001 - no exception of an FB body escapes the cycle
            self._scan_failed(exc)
        return self

    def _scan(self) -> None:
        raise NotImplementedError

    def _scan_failed(self, exc: Exception) -> None:
        """An unexpected exception in this scan (a defect; bad inputs are InputErrors): the FB
        shows Error with ``ErrorID.INTERNAL_ERROR`` and the exception in ``error_text``."""
        self._dirty = True
        self.error = True
        self.error_id = ErrorID.INTERNAL_ERROR
        self.error_text = f"internal error in {type(self).__name__}: {type(exc).__name__}: {exc}"

    # -- trace support ---------------------------------------------------------------------
    def _out_bits(self) -> tuple[Any, ...]:
        """Current values of the boolean outputs (compared with the last traced ones)."""
        return self._get_outputs(self)

    def _emit_edges(self, trace: Trace, cycle: int, bits: tuple[Any, ...]) -> None:
        self._dirty = False
        for n, old, new in zip(self.OUTPUTS, self._traced_bits, bits, strict=True):
            if bool(old) != bool(new):
                trace.event(cycle, self.name or type(self).__name__, n, bool(new))
        self._traced_bits = bits


def _failed(error_id: ErrorID, reason: str = "") -> Handle:
    h = Handle("rejected")
    h._finish(Status.ERROR, error_id, reason)
    return h


class InputError(Exception):
    """A bad FB input found by validation (becomes ``error``/``error_id``)."""

    def __init__(self, error_id: ErrorID, text: str) -> None:
        super().__init__(text)
        self.error_id = error_id


def check_number(
    name: str,
    value: Any,
    error_id: ErrorID,
    lo: float = -math.inf,
    hi: float = math.inf,
    lo_open: bool = False,
) -> float:
    """Validate a numeric FB input; raises :class:`InputError` naming it and its range."""
    ok = isinstance(value, (int, float)) and not isinstance(value, bool)
    x = float(value) if ok else math.nan
    if not ok or math.isnan(x) or (math.isinf(x) and math.isfinite(hi if x > 0 else lo)):
        ok = False
    elif lo_open and not x > lo or not lo_open and not x >= lo or x > hi:
        ok = False
    if not ok or not math.isfinite(x):
        rng = f"{'(' if lo_open else '['}{lo:g}, {hi:g}]"
        raise InputError(error_id, f"{name} must be a finite number in {rng}, got {value!r}")
    return x


def check_dynamic(name: str, value: Any, error_id: ErrorID, lo: float, hi: float) -> float:
    """Validate an Acceleration / Deceleration / Jerk input: 0 (the axis' own limit) or a
    finite number in [lo, hi]; raises :class:`InputError` naming it and its range."""
    ok = isinstance(value, (int, float)) and not isinstance(value, bool)
    x = float(value) if ok else math.nan
    if x == 0.0 or lo <= x <= hi and x < math.inf:
        return x
    raise InputError(
        error_id,
        f"{name} must be 0 (the axis' limit) or a finite number in [{lo:g}, {hi:g}], got {value!r}",
    )


def check_execution_mode(value: Any) -> ExecutionMode:
    """Validate an ExecutionMode input (MC_SetPosition, MC_Write*Parameter,
    MC_CamTableSelect); raises :class:`InputError` INVALID_EXECUTION_MODE otherwise."""
    if not isinstance(value, ExecutionMode):
        raise InputError(
            ErrorID.INVALID_EXECUTION_MODE,
            f"execution_mode must be an ExecutionMode, got {value!r}",
        )
    return value


class ExecuteFB(FunctionBlock):
    """Execute/Done FBs (one-shot): done, busy, error, error_id."""

    INPUTS = ("axis", "execute")
    OUTPUTS = ("busy", "done", "error")
    _TERMINAL_OUT = True
    _hook_before: ClassVar[bool] = False
    _hook_busy: ClassVar[bool] = False
    _busy_traced: ClassVar[bool] = False
    # a subclass whose _busy_outputs changes no traced output (or sets _dirty itself)
    _BUSY_HOOK_UNTRACED: ClassVar[bool] = False

    def __init__(
        self, name: str | None = None, *, retrigger_ignored: bool = False, **inputs: Any
    ) -> None:
        self.execute = False
        self.busy = False
        self.done = False
        self.active = False
        self.command_aborted = False
        self.retrigger_ignored = retrigger_ignored
        self._prev_execute = False
        self._handle: Handle | None = None
        self._seen = False
        self._busy_status: Status | None = None
        super().__init__(name, **inputs)

    def _start(self, axis: Axis) -> Handle:
        """Latch the inputs and submit the command (subclasses)."""
        raise NotImplementedError

    def _start_checked(self) -> Handle:
        axis = self.axis
        self.error_text = ""
        if axis is None:
            self.error_text = "axis input is not connected"
            return _failed(ErrorID.INVALID_AXIS)
        try:
            return self._start(axis)
        except InputError as exc:
            self.error_text = str(exc)
            return _failed(exc.error_id, str(exc))

    def __init_subclass__(cls, **kw: Any) -> None:
        super().__init_subclass__(**kw)
        # the per-scan hooks are called on the fast paths only when a subclass defines them
        cls._hook_before = cls._before_outputs is not ExecuteFB._before_outputs
        cls._hook_busy = cls._busy_outputs is not ExecuteFB._busy_outputs
        cls._busy_traced = cls._hook_busy and not cls._BUSY_HOOK_UNTRACED
        cls._inline_scan = cls._scan is ExecuteFB._scan

    _inline_scan: ClassVar[bool] = True

    def __call__(self, **inputs: Any) -> Any:
        """One scan (see :meth:`FunctionBlock.__call__`). The common scans of a long-lived FB
        (its axis registered, no Execute edge, idle or still in the same busy state) run the
        fast paths of :meth:`_scan` here, one call less per scan."""
        if inputs:
            self._set_inputs(inputs)
        if self.axis is not self._registered or not self._inline_scan:
            return FunctionBlock.__call__(self)
        try:
            ex = self.execute
            prev = self._prev_execute  # a bool
            # no Execute edge (bool(execute) called only for a value that is not a bool)
            if ex is prev or (ex is not True and ex is not False and bool(ex) is prev):
                h = self._handle
                if h is None:
                    if self._hook_before:
                        self._before_outputs(prev)
                    return self
                if h.status is self._busy_status:
                    if self._hook_before:
                        self._before_outputs(prev)
                    if self._hook_busy:
                        self._busy_outputs(h)
                        if self._busy_traced:
                            self._dirty = True
                    return self
            self._scan()
        except Exception as exc:  # noqa: BLE001 - no exception of an FB body escapes the cycle
            self._scan_failed(exc)
        return self

    def _scan(self) -> None:
        ex = bool(self.execute)
        h = self._handle
        if ex is self._prev_execute:
            if h is None:
                # fast path: idle (no command, no edge); the outputs were cleared already
                if self._hook_before:
                    self._before_outputs(ex)
                return
            if h.status is self._busy_status:
                # fast path: no edge and the command is still in the same busy state
                if self._hook_before:
                    self._before_outputs(ex)
                if self._hook_busy:
                    self._busy_outputs(h)
                    if self._busy_traced:
                        self._dirty = True
                return
        self._dirty = True
        if ex and not self._prev_execute:
            if not (self.retrigger_ignored and self.busy):
                self._handle = self._start_checked()
                self._seen = False
        self._prev_execute = ex
        self._before_outputs(ex)
        h = self._handle
        self._busy_status = None
        if h is None:
            self._clear()
            return
        st = h.status
        if st >= Status.DONE:
            if ex or not self._seen:
                self._seen = True
                self.busy = self.active = False
                self.done = st is Status.DONE
                self.error = st is Status.ERROR
                self.command_aborted = st is Status.ABORTED
                self.error_id = h.error_id if self.error else ErrorID.OK
                if self.error and h.reason:
                    self.error_text = h.reason
                self._terminal_outputs(h)
            else:
                self._handle = None
                self._clear()
        else:
            self._busy_status = st
            self.busy = True
            self.active = st is Status.ACTIVE
            self.done = self.error = self.command_aborted = False
            self.error_id = ErrorID.OK
            self._busy_outputs(h)

    def _scan_failed(self, exc: Exception) -> None:
        """An unexpected exception in this scan: the command (if the axis runs it) ends with
        Error INTERNAL_ERROR, and the FB shows that Error under the usual output rules."""
        reason = f"internal error in {type(self).__name__}: {type(exc).__name__}: {exc}"
        h = self._handle
        axis = self.axis
        if h is not None and not h.terminal and isinstance(axis, Axis):
            axis.fail_command(h, ErrorID.INTERNAL_ERROR)
        self._handle = _failed(ErrorID.INTERNAL_ERROR, reason)
        self._seen = True
        self._prev_execute = bool(self.execute)
        self._busy_status = None
        self._dirty = True
        self.busy = self.active = self.done = self.command_aborted = False
        self.error = True
        self.error_id = ErrorID.INTERNAL_ERROR
        self.error_text = reason

    def _before_outputs(self, execute: bool) -> None:
        """Hook run every scan before the outputs are computed."""

    def _clear(self) -> None:
        self.busy = self.active = self.done = self.error = self.command_aborted = False
        self.error_id = ErrorID.OK

    def _terminal_outputs(self, h: Handle) -> None:
        """Extra outputs when the command ended (subclasses)."""

    def _busy_outputs(self, h: Handle) -> None:
        """Extra outputs while busy (subclasses)."""


class MotionFB(ExecuteFB):
    """Execute FBs that control the axis: adds active and command_aborted."""

    OUTPUTS = ("busy", "active", "done", "command_aborted", "error")


# ``EnableFB._steady`` when the steady path is off (never an axis input: a bad ``axis`` such as
# ``False`` must still reach the general path's type check)
_NOT_STEADY: Any = object()


class EnableFB(FunctionBlock):
    """Enable/Valid FBs: valid, busy, error, error_id."""

    INPUTS = ("axis", "enable")
    OUTPUTS = ("valid", "busy", "error")
    _values_traced: ClassVar[bool] = False
    # a subclass with extra traced outputs whose _update sets _dirty itself when they change
    _UPDATE_MARKS_DIRTY: ClassVar[bool] = False

    def __init__(self, name: str | None = None, **inputs: Any) -> None:
        self.enable = False
        self.valid = False
        self.busy = False
        # the axis while the next scan may take the steady path (set after a general scan)
        self._steady: Any = _NOT_STEADY
        super().__init__(name, **inputs)

    def __init_subclass__(cls, **kw: Any) -> None:
        super().__init_subclass__(**kw)
        extra = not set(cls.OUTPUTS) <= {"valid", "busy", "error"}
        cls._values_traced = extra and not cls._UPDATE_MARKS_DIRTY
        cls._inline_scan = cls._scan is EnableFB._scan
        cls._steady_ok = cls._steady_allowed()

    _inline_scan: ClassVar[bool] = True
    # whether this class' scans may take the steady path of its ``__call__``
    _steady_ok: ClassVar[bool] = True

    @classmethod
    def _steady_allowed(cls) -> bool:
        """Whether the steady path of ``__call__`` gives this class' scan (subclasses with a
        steady path of their own refine it)."""
        return cls._inline_scan

    def __call__(self, **inputs: Any) -> Any:
        """One scan (see :meth:`FunctionBlock.__call__`). The steady scan of a long-lived FB
        (its axis registered, enabled and valid without error: ``_steady`` is its axis) runs
        the path of :meth:`_scan` for that case here, one call less per scan."""
        if inputs:
            self._set_inputs(inputs)
        axis = self.axis
        if axis is not self._steady or not self.enable:
            return self._call_general()
        try:
            try:
                self._update(axis)
            except InputError as exc:
                self._steady = _NOT_STEADY
                self._dirty = True
                self.busy = True
                self.valid = False
                self.error = True
                self.error_id = exc.error_id
                self.error_text = str(exc)
                self._reset_values()
                return self
            if not self.valid or self.error:
                self._dirty = True
                self.busy = True
                self.valid = True
                self.error = False
                self.error_id = ErrorID.OK
                self.error_text = ""
            elif self._values_traced:
                self._dirty = True
        except Exception as exc:  # noqa: BLE001 - no exception of an FB body escapes the cycle
            self._scan_failed(exc)
        return self

    def _call_general(self) -> Any:
        """One scan through :meth:`FunctionBlock.__call__` (registration, :meth:`_scan`), then
        ``_steady``: the axis if the next scan may take the steady path (the class allows it,
        the axis is registered, valid without error), else ``_NOT_STEADY``."""
        FunctionBlock.__call__(self)
        axis = self.axis
        if (
            self._steady_ok
            and axis is self._registered
            and axis is not None
            and self.valid
            and not self.error
        ):
            self._steady = axis
        else:
            self._steady = _NOT_STEADY
        return self

    def _scan(self) -> None:
        if not self.enable:
            self._dirty = True
            self.valid = self.busy = self.error = False
            self.error_id = ErrorID.OK
            self.error_text = ""
            self._reset_values()
            return
        axis = self.axis
        try:
            if axis is None:
                raise InputError(ErrorID.INVALID_AXIS, "axis input is not connected")
            self._update(axis)
        except InputError as exc:
            self._dirty = True
            self.busy = True
            self.valid = False
            self.error = True
            self.error_id = exc.error_id
            self.error_text = str(exc)
            self._reset_values()
            return
        if not self.valid or self.error:  # steady state (valid, no error): nothing to write
            self._dirty = True
            self.busy = True
            self.valid = True
            self.error = False
            self.error_id = ErrorID.OK
            self.error_text = ""
        elif self._values_traced:
            self._dirty = True

    def _scan_failed(self, exc: Exception) -> None:
        self._steady = _NOT_STEADY
        super()._scan_failed(exc)
        self.valid = False
        self.busy = bool(self.enable)
        self._reset_values()

    def _update(self, axis: Axis) -> None:
        """Compute the values (subclasses); raise InputError for a (recoverable) error."""
        raise NotImplementedError

    def _reset_values(self) -> None:
        """Reset the value outputs (subclasses)."""
