"""Drive backends by name, imported lazily (python-can's ``BACKENDS`` pattern).

A configuration's ``kind:`` picks a backend; the module (and its optional heavy dependency,
``canopen`` or ``pymodbus``) is imported only when that backend is used.
"""

from __future__ import annotations

import importlib
from typing import Any

__all__ = ["BACKENDS", "VIRTUAL_DEVICES", "backend_class", "create_drive", "virtual_device_class"]

# kind -> (module, class): master-side backends implementing motionplc.fieldbus.base.Drive
BACKENDS: dict[str, tuple[str, str]] = {
    "ideal": ("motionplc.fieldbus.ideal", "IdealDrive"),
    "canopen": ("motionplc.fieldbus.canopen_drive", "CanopenDrive"),
    "modbus": ("motionplc.fieldbus.modbus_drive", "ModbusDrive"),
}

# kind -> (module, class): the simulated other end of the wire
VIRTUAL_DEVICES: dict[str, tuple[str, str]] = {
    "virtual_cia402": ("motionplc.fieldbus.virtual_cia402", "VirtualCia402Drive"),
    "virtual_can_bus": ("motionplc.fieldbus.virtual_cia402", "VirtualCanBus"),
    "virtual_modbus": ("motionplc.fieldbus.virtual_modbus", "VirtualModbusDrive"),
    "virtual_modbus_server": ("motionplc.fieldbus.virtual_modbus", "VirtualModbusServer"),
}


def _load(table: dict[str, tuple[str, str]], kind: str, what: str) -> Any:
    try:
        module_name, class_name = table[kind]
    except KeyError:
        raise ValueError(f"unknown {what} {kind!r}; known: {', '.join(sorted(table))}") from None
    return getattr(importlib.import_module(module_name), class_name)


def backend_class(kind: str) -> type:
    """The Drive class registered as ``kind`` (imports its module on first use)."""
    return _load(BACKENDS, kind, "drive backend")


def virtual_device_class(kind: str) -> type:
    """A virtual-device class registered as ``kind``."""
    return _load(VIRTUAL_DEVICES, kind, "virtual device")


def create_drive(kind: str, *args: Any, **kwargs: Any) -> Any:
    """Instantiate the backend ``kind`` with the backend's own constructor arguments."""
    return backend_class(kind)(*args, **kwargs)
