"""Operator interfaces of a running machine: the in-cycle desk (snapshot out, requests in:
:mod:`motionplc.operator.desk`) and the OPC UA server (:mod:`motionplc.operator.opcua`, the
``operator`` extra: asyncua). Design: ``docs/operator.md``."""

from motionplc.operator.desk import OperatorDesk, Request, Snapshot
from motionplc.operator.settings import OpcUaSettings, check_password, hash_password

__all__ = [
    "OpcUaSettings",
    "OperatorDesk",
    "Request",
    "Snapshot",
    "check_password",
    "hash_password",
]
