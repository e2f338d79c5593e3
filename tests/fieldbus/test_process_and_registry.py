"""Backend registry, the separate-process drives entry point, and vcan (skipped without it)."""

from __future__ import annotations

import json
import os
import selectors
import socket
import subprocess
import sys
from pathlib import Path

import can
import pytest

from motionplc.fieldbus.base import Drive, DriveCommand, FieldbusError
from motionplc.fieldbus.drives_main import DrivesSpec
from motionplc.fieldbus.modbus_drive import ModbusDrive, ModbusDriveConfig
from motionplc.fieldbus.registry import BACKENDS, backend_class, create_drive, virtual_device_class

ROOT = Path(__file__).resolve().parents[2]


def test_registry_resolves_every_backend_lazily() -> None:
    for kind in BACKENDS:
        assert issubclass(backend_class(kind), Drive)
    assert virtual_device_class("virtual_modbus").__name__ == "VirtualModbusDrive"
    drive = create_drive("modbus", "m", ModbusDriveConfig(port=1502))
    assert isinstance(drive, ModbusDrive)
    with pytest.raises(ValueError, match="known: canopen"):
        backend_class("ethercat")


def test_drives_spec_refuses_multicast() -> None:
    with pytest.raises(FieldbusError, match="udp_multicast"):
        DrivesSpec(can_nodes=(1,), can_interface="udp_multicast")
    with pytest.raises(ValueError):
        DrivesSpec()


def test_modbus_drive_in_a_separate_process() -> None:
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    proc = subprocess.Popen(
        [
            sys.executable,
            "-m",
            "motionplc.fieldbus.drives_main",
            "--modbus",
            "3",
            "--duration",
            "20",
        ],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        env=env,
        text=True,
    )
    try:
        sel = selectors.DefaultSelector()
        assert proc.stdout is not None
        sel.register(proc.stdout, selectors.EVENT_READ)
        assert sel.select(timeout=15.0), "drives process did not announce itself"
        info = json.loads(proc.stdout.readline())
        port = info["modbus"]["3"]
        drive = ModbusDrive("m", ModbusDriveConfig(port=port, device_id=3, timeout=0.5))
        drive.open()
        try:
            fb = None
            for k in range(12):
                fb = drive.read_inputs(k * 0.004)
                drive.write_outputs(k * 0.004, DriveCommand(fb.position, enable=True))
            assert fb is not None and fb.enabled and fb.comm_ok
        finally:
            drive.close()
    finally:
        proc.terminate()
        try:
            proc.wait(timeout=5.0)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait(timeout=5.0)


def vcan_channel() -> str:
    """The vcan interface to use, or pytest.skip with the failed check as the reason."""
    name = os.environ.get("FB_TEST_VCAN", "vcan0")
    if not hasattr(socket, "AF_CAN"):
        pytest.skip("socket.AF_CAN missing")
    try:
        s = socket.socket(socket.AF_CAN, socket.SOCK_RAW, socket.CAN_RAW)
        s.close()
    except OSError as exc:
        pytest.skip(f"AF_CAN socket unavailable: {exc}")
    if not Path(f"/sys/class/net/{name}").exists():
        pytest.skip(f"{name} does not exist (tools/setup_vcan.sh creates it)")
    return name


@pytest.mark.vcan
def test_canopen_over_vcan() -> None:
    channel = vcan_channel()
    from motionplc.fieldbus.canopen_drive import CanopenDrive, CanopenDriveConfig, CanopenMaster
    from motionplc.fieldbus.virtual_cia402 import VirtualCanBus, VirtualCia402Drive

    try:
        rack = VirtualCanBus(
            can.Bus(interface="socketcan", channel=channel), [VirtualCia402Drive(5)]
        )
    except OSError as exc:
        pytest.skip(f"socketcan {channel}: {exc}")
    master = CanopenMaster(can.Bus(interface="socketcan", channel=channel), peer=rack)
    try:
        drive = CanopenDrive("ax", master, CanopenDriveConfig(node_id=5))
        drive.open()
        fb = None
        for k in range(60):
            fb = drive.read_inputs(k * 0.001)
            drive.write_outputs(k * 0.001, DriveCommand(fb.position + 1e-5, enable=True))
        assert fb is not None and fb.enabled and fb.comm_ok
    finally:
        master.close()
        rack.close()
