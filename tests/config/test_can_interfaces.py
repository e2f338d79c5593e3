"""CAN buses on any python-can interface by name, with its own options passed through; a bus
that cannot be opened is one located line (issue 13 finding 5, `drives: external` on any
interface)."""

from __future__ import annotations

import socket
import textwrap
from pathlib import Path

import can
import pytest

from motionplc.cli import main
from motionplc.config import CAN_INTERFACES, build, load_config
from motionplc.errors import ConfigError


def _config(tmp_path: Path, bus: str) -> Path:
    path = tmp_path / "machine.yaml"
    path.write_text(
        textwrap.dedent(
            f"""\
            runtime: {{tick: 0.001, tasks: {{m: {{period: 0.001}}}}}}
            buses:
              can0: {bus}
            axes:
              x:
                limits: {{v_max: 1.0, a_max: 1.0}}
                drive: {{bus: can0, node_id: 1}}
            """
        )
    )
    return path


def test_every_python_can_interface_but_multicast() -> None:
    assert set(CAN_INTERFACES) == set(can.interfaces.VALID_INTERFACES) - {"udp_multicast"}


def test_options_are_passed_through(tmp_path: Path) -> None:
    cfg = load_config(
        _config(
            tmp_path,
            "{type: can, interface: slcan, channel: /dev/ttyACM0, bitrate: 500000, "
            "drives: external, options: {tty_baudrate: 115200, sleep_after_open: 0.5}}",
        )
    )
    bus = cfg.bus("can0")
    assert bus.can_bus_kwargs() == {
        "interface": "slcan",
        "channel": "/dev/ttyACM0",
        "bitrate": 500000,
        "tty_baudrate": 115200,
        "sleep_after_open": 0.5,
    }


@pytest.mark.parametrize(
    ("bus", "message"),
    [
        (
            "{type: can, interface: udp_multicast}",
            "machine.yaml:3: buses.can0.interface: udp_multicast sends CAN frames as IP "
            "multicast beyond this machine (allowed: virtual, socketcan,",
        ),
        (
            "{type: can, interface: pcan}",
            "machine.yaml:3: buses.can0.channel: missing (interface pcan) (allowed: a channel)",
        ),
        (
            "{type: can, interface: pcan, channel: PCAN_USBBUS1, options: {bitrate: 250000}}",
            "machine.yaml:3: buses.can0.options.bitrate: set it on the bus itself "
            "(allowed: buses.can0.bitrate)",
        ),
        (
            "{type: can, interface: kvaser, channel: 0, options: {x: [1, 2]}}",
            "machine.yaml:3: buses.can0.options.x: got a list (allowed: a scalar value)",
        ),
    ],
)
def test_bad_bus_is_located(tmp_path: Path, bus: str, message: str) -> None:
    with pytest.raises(ConfigError) as info:
        load_config(_config(tmp_path, bus))
    assert message in str(info.value)


def _af_can() -> bool:
    try:
        socket.socket(socket.PF_CAN, socket.SOCK_RAW, socket.CAN_RAW).close()
    except (OSError, AttributeError):
        return False
    return True


def test_unopenable_bus_is_one_line_without_traceback(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    path = _config(tmp_path, "{type: can, interface: socketcan, channel: vcan97}")
    assert main(["run", str(path), "--seconds", "0.01", "-q"]) == 2
    err = capsys.readouterr().err
    assert "Traceback" not in err
    assert err.count("\n") == 1
    head = (
        f"motionplc: error: {path}:3: buses.can0: cannot open CAN interface 'socketcan' "
        "channel 'vcan97': "
    )
    assert err.startswith(head)
    if _af_can():  # the kernel has CAN, the channel does not exist
        assert "vcan97 does not exist: sudo ip link add dev vcan97 type vcan" in err
    else:
        assert "this kernel has no SocketCAN (AF_CAN)" in err


def test_external_drive_on_a_virtual_channel_is_reached_by_name(tmp_path: Path) -> None:
    """`drives: external` on the virtual interface: the master opens the channel by its name
    (no unique suffix), so a drive in this process on that channel is on the same bus."""
    channel = f"ext-{tmp_path.name}"
    cfg = load_config(
        _config(
            tmp_path, f"{{type: can, interface: virtual, channel: {channel}, drives: external}}"
        )
    )
    with can.Bus(interface="virtual", channel=channel) as listener:
        machine = build(cfg)
        try:
            drive = machine.axes["x"].drive
            drive.master.network.send_message(0x77, b"\x01")
            msg = listener.recv(timeout=1.0)
            assert msg is not None and msg.arbitration_id == 0x77
        finally:
            machine.close()


@pytest.mark.parametrize(
    ("interface", "channel"), [("pcan", "PCAN_USBBUS1"), ("kvaser", "0"), ("ixxat", "0")]
)
def test_absent_adapter_is_one_located_line_naming_the_interface(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], interface: str, channel: str
) -> None:
    # the configuration is valid; the adapter (or its vendor library) is not on this machine
    path = _config(
        tmp_path,
        f"{{type: can, interface: {interface}, channel: '{channel}', bitrate: 500000, "
        "drives: external}",
    )
    assert main(["validate", str(path)]) == 0
    capsys.readouterr()
    assert main(["run", str(path), "--seconds", "0.01", "-q"]) == 2
    err = capsys.readouterr().err
    assert "Traceback" not in err
    assert err.count("\n") == 1
    assert err.startswith(
        f"motionplc: error: {path}:3: buses.can0: cannot open CAN interface {interface!r} "
        f"channel {channel!r}: "
    )
