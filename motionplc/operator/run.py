"""``motionplc run ... --opcua`` (or an ``opcua:`` block): the desk and the OPC UA server of a
run, started before its first cycle and stopped after its controlled stop."""

from __future__ import annotations

from typing import Any

from motionplc.errors import MotionPlcError
from motionplc.operator.desk import OperatorDesk
from motionplc.operator.settings import OpcUaSettings

__all__ = ["OperatorSession", "start_operator"]


class OperatorSession:
    """The desk and the server of one run; :meth:`close` stops the server."""

    def __init__(self, desk: OperatorDesk, server: Any) -> None:
        self.desk = desk
        self.server = server

    def line(self) -> str:
        st = self.server.settings
        users = len(st.users)
        who = f"{users} user{'s' if users != 1 else ''}"
        if st.anonymous:
            who += ", anonymous read"
        return f"OPC UA server: {self.server.endpoint} ({', '.join(st.security)}; {who})"

    def close(self) -> None:
        self.server.stop()


def start_operator(machine: Any, runner: Any = None, task: str | None = None) -> OperatorSession:
    """Install the desk on ``machine`` (``runner``: the run's program, which the desk calls in
    ``task``; it waits for the operator's Start with ``program_start: operator``) and start
    the OPC UA server with the configuration's ``opcua:`` settings (or the defaults)."""
    settings = machine.config.opcua or OpcUaSettings()
    try:
        import asyncua  # noqa: F401
    except ImportError:
        raise MotionPlcError(
            "the OPC UA server needs asyncua: pip install 'motionplc[operator]'"
        ) from None
    from motionplc.operator.opcua import OpcUaServer, OpcUaStartError

    rt = machine.runtime
    every = max(1, round(settings.publish_interval / rt.cycle))
    desk = OperatorDesk(
        machine,
        publish_every=every,
        program=runner,
        program_task=task,
        autostart=settings.program_start == "auto",
    )
    desk.install()
    server = OpcUaServer(desk, settings)
    try:
        server.start()
    except OpcUaStartError as exc:
        raise MotionPlcError(f"{machine.config.path}: opcua: {exc}") from exc
    return OperatorSession(desk, server)
