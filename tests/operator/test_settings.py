"""The ``opcua:`` block: its defaults, its checks (FILE:LINE: key: problem (allowed: ...)) and
the password hashes."""

from __future__ import annotations

from pathlib import Path

import pytest

from motionplc.config import load_config
from motionplc.errors import ConfigError
from motionplc.operator.settings import OpcUaSettings, check_password, hash_password

BASE = """\
runtime:
  tasks:
    motion: {period: 0.001}
axes:
  x:
    limits: {v_max: 1.0, a_max: 2.0}
"""


def _load(tmp_path: Path, block: str) -> OpcUaSettings:
    f = tmp_path / "m.yaml"
    f.write_text(BASE + block)
    return load_config(f).opcua


def test_defaults_are_loopback_and_secure(tmp_path: Path) -> None:
    st = _load(tmp_path, "opcua: {}\n")
    assert st.host == "127.0.0.1" and st.port == 4840
    assert st.security == ("Sign", "SignAndEncrypt")  # no None endpoint unless listed
    assert st.anonymous and st.users == () and st.publish_interval == 0.01
    f = tmp_path / "m.yaml"
    f.write_text(BASE)
    assert load_config(f).opcua is None


def test_values_and_relative_paths(tmp_path: Path) -> None:
    h = hash_password("pw")
    st = _load(
        tmp_path,
        "opcua:\n  port: 0\n  security: [None, SignAndEncrypt]\n  certificate_dir: certs\n"
        f"  users:\n    bob: {{password_hash: '{h}'}}\n  publish_interval: 0.02\n",
    )
    assert st.port == 0 and st.security == ("None", "SignAndEncrypt")
    assert st.certificate_dir == str((tmp_path / "certs").resolve())
    assert st.user_hash("bob") == h and st.user_hash("eve") is None
    assert st.publish_interval == 0.02


@pytest.mark.parametrize(
    ("block", "message"),
    [
        ("opcua:\n  port: 70000\n", "m.yaml:8: opcua.port: "),
        ("opcua:\n  security: [Sign, Encrypt]\n", "m.yaml:8: opcua.security: got"),
        ("opcua:\n  policy: Basic128\n", "m.yaml:8: opcua.policy: "),
        ("opcua:\n  publish_interval: 0\n", "m.yaml:8: opcua.publish_interval: "),
        ("opcua:\n  users:\n    bob: {password_hash: secret}\n", "opcua.users.bob.password_hash"),
        ("opcua:\n  users:\n    bob: {password: x}\n", "opcua.users.bob.password"),
        ("opcua:\n  certificate: c.der\n", "certificate and private_key go together"),
        ("opcua:\n  listen: 1\n", "opcua.listen: unknown key"),
        ("hmi:\n  port: -1\n", "m.yaml:8: hmi.port: "),
        ("hmi:\n  interval: 0\n", "m.yaml:8: hmi.interval: "),
        ("hmi:\n  users:\n    bob: {password_hash: secret}\n", "hmi.users.bob.password_hash"),
        ("hmi:\n  theme: dark\n", "hmi.theme: unknown key"),
    ],
)
def test_bad_values_name_the_key(tmp_path: Path, block: str, message: str) -> None:
    with pytest.raises(ConfigError) as info:
        _load(tmp_path, block)
    assert any(message in e for e in info.value.errors), info.value.errors


def test_hmi_defaults_and_the_opcua_users(tmp_path: Path) -> None:
    f = tmp_path / "m.yaml"
    f.write_text(BASE + "hmi: {}\n")
    st = load_config(f).hmi
    assert (st.host, st.port, st.users, st.anonymous, st.interval) == (
        "127.0.0.1",
        8480,
        (),
        True,
        0.05,
    )
    h, k = hash_password("pw"), hash_password("other")
    f.write_text(BASE + f"opcua:\n  users:\n    bob: {{password_hash: '{h}'}}\nhmi:\n  port: 0\n")
    cfg = load_config(f)
    assert cfg.hmi.users == cfg.opcua.users == (("bob", h),)  # the OPC UA users by default
    f.write_text(
        BASE
        + f"opcua:\n  users:\n    bob: {{password_hash: '{h}'}}\n"
        + f"hmi:\n  anonymous: false\n  users:\n    eve: {{password_hash: '{k}'}}\n"
    )
    st = load_config(f).hmi
    assert st.users == (("eve", k),) and st.user_hash("bob") is None and not st.anonymous


def test_password_hash_round_trip() -> None:
    h = hash_password("correct horse")
    assert h.startswith("scrypt$16384$8$1$")
    assert check_password("correct horse", h)
    assert not check_password("correct hors", h)
    assert not check_password("correct horse", "scrypt$1$2$3$bad$bad")
    assert hash_password("x") != hash_password("x")  # salted
