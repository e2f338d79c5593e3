"""Operator interfaces of a running machine: the in-cycle desk (snapshot out, requests in:
:mod:`motionplc.operator.desk`), the operator process that serves them outside the real-time
process (:mod:`motionplc.operator.process`: the shared-memory snapshot board and the request
pipes) with the OPC UA server (:mod:`motionplc.operator.opcua`) and the web HMI
(:mod:`motionplc.operator.hmi`); the ``operator`` extra. Design: ``docs/operator.md``."""

from motionplc.operator.desk import OperatorDesk, Request, Snapshot
from motionplc.operator.settings import HmiSettings, OpcUaSettings, check_password, hash_password

__all__ = [
    "HmiSettings",
    "OpcUaSettings",
    "OperatorDesk",
    "Request",
    "Snapshot",
    "check_password",
    "hash_password",
]
