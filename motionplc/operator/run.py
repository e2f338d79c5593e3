"""``motionplc run ... --opcua`` / ``--hmi`` (or an ``opcua:`` / ``hmi:`` block): the desk of a
run and its operator process (the OPC UA server and / or the web HMI), started before the
first cycle and stopped after the controlled stop."""

from __future__ import annotations

from typing import Any

from motionplc.errors import MotionPlcError
from motionplc.operator.desk import OperatorDesk
from motionplc.operator.settings import HmiSettings, OpcUaSettings

__all__ = ["OperatorSession", "start_operator"]


class OperatorSession:
    """The desk and the operator process of one run; :meth:`close` stops the process."""

    def __init__(self, desk: OperatorDesk, process: Any) -> None:
        self.desk = desk
        self.process = process

    def line(self) -> str:
        out = []
        p = self.process
        if p.opcua is not None:
            st = p.opcua
            users = len(st.users)
            who = f"{users} user{'s' if users != 1 else ''}"
            if st.anonymous:
                who += ", anonymous read"
            out.append(f"OPC UA server: {p.endpoint} ({', '.join(st.security)}; {who})")
        if p.hmi is not None:
            n = len(p.hmi.users)
            out.append(f"web HMI: {p.hmi_url} ({n} user{'s' if n != 1 else ''})")
        return "\n".join(out) + f"\n(operator process pid {p.pid})"

    def close(self) -> None:
        self.process.stop()


def start_operator(
    machine: Any,
    runner: Any = None,
    task: str | None = None,
    *,
    opcua: bool = True,
    hmi: bool = False,
) -> OperatorSession:
    """Install the desk on ``machine`` (``runner``: the run's program, which the desk calls in
    ``task``; it waits for the operator's Start with ``program_start: operator``) and start
    the operator process with the OPC UA server (``opcua``: the configuration's ``opcua:``
    settings or the defaults) and / or the web HMI (``hmi``: ``hmi:`` or the defaults with
    the OPC UA users)."""
    cfg = machine.config
    ua_settings = (cfg.opcua or OpcUaSettings()) if opcua else None
    hmi_settings = None
    if hmi:
        hmi_settings = cfg.hmi or HmiSettings(users=(cfg.opcua.users if cfg.opcua else ()))
    missing = []
    if ua_settings is not None:
        try:
            import asyncua  # noqa: F401
        except ImportError:
            missing.append("the OPC UA server needs asyncua")
    if hmi_settings is not None:
        try:
            import starlette  # noqa: F401
            import uvicorn  # noqa: F401
            import websockets  # noqa: F401
        except ImportError:
            missing.append("the web HMI needs starlette, uvicorn and websockets")
    if missing:
        raise MotionPlcError("; ".join(missing) + ": pip install 'motionplc[operator]'")
    from motionplc.operator.process import OperatorProcess, OperatorStartError

    rt = machine.runtime
    interval = ua_settings.publish_interval if ua_settings is not None else 0.01
    every = max(1, round(interval / rt.cycle))
    desk = OperatorDesk(
        machine,
        publish_every=every,
        program=runner,
        program_task=task,
        autostart=ua_settings is None or ua_settings.program_start == "auto",
    )
    desk.install()
    process = OperatorProcess(desk, ua_settings, hmi_settings)
    try:
        process.start()
    except OperatorStartError as exc:
        raise MotionPlcError(f"{cfg.path}: operator process: {exc}") from exc
    return OperatorSession(desk, process)
