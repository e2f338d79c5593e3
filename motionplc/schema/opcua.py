"""The ``opcua:`` block of a machine configuration: the OPC UA server of the machine
(:mod:`motionplc.operator.opcua`; started by ``motionplc run`` when the block is present or with
``--opcua``)."""

from __future__ import annotations

from motionplc.schema.nodes import Bool, Choice, Integer, Key, ListOf, MapOf, Number, Obj, String


def _listen(default_port: str) -> tuple[Key, Key]:
    """The ``host`` and ``port`` keys of a server of the operator process."""
    return (
        Key(
            "host",
            String(
                what="an IP address or host name",
                default_text="127.0.0.1",
                description="The address to listen on (loopback unless given).",
            ),
        ),
        Key(
            "port",
            Integer(
                lo=0,
                hi=65535,
                default_text=default_port,
                description="The TCP port (0: a free one, printed at the start).",
            ),
        ),
    )


SECURITY_MODES = ("None", "Sign", "SignAndEncrypt")
POLICIES = ("Basic256Sha256", "Aes128Sha256RsaOaep", "Aes256Sha256RsaPss")

USER = Obj(
    title="OPC UA user",
    description="An operator: may call the methods (on a Sign or SignAndEncrypt channel).",
    keys=(
        Key(
            "password_hash",
            String(
                pattern=r"^scrypt\$[0-9]+\$[0-9]+\$[0-9]+\$[A-Za-z0-9+/=]+\$[A-Za-z0-9+/=]+$",
                what="scrypt$N$r$p$SALT$HASH",
                description="The password, hashed: `python -m motionplc.operator.passwd` "
                "prints it (the password itself is never stored).",
            ),
            True,
        ),
    ),
)

OPCUA = Obj(
    title="OPC UA server",
    description="The machine's OPC UA server (asyncua, in the operator process outside the "
    "real-time process): an address space "
    "modelled on OPC 40010-1 (MotionDeviceSystem, axes, controllers) with the operator "
    "methods. Anonymous sessions read and subscribe; a user of `users` on a Sign or "
    "SignAndEncrypt channel may also call the methods.",
    keys=(
        *_listen("4840"),
        Key(
            "security",
            ListOf(
                item=Choice(options=SECURITY_MODES),
                min_items=1,
                max_items=3,
                description="The endpoints' message security modes (default Sign and "
                "SignAndEncrypt; None only when listed here).",
                example=["Sign", "SignAndEncrypt"],
            ),
        ),
        Key(
            "policy",
            Choice(
                options=POLICIES,
                default_text="Basic256Sha256",
                description="The security policy of the Sign / SignAndEncrypt endpoints.",
            ),
        ),
        Key(
            "certificate",
            String(
                what="a file",
                description="The server's certificate (DER or PEM; relative to this file; with "
                "`private_key`). Default: a self-signed one generated on the first start in "
                "`certificate_dir`.",
            ),
        ),
        Key(
            "private_key",
            String(what="a file", description="The certificate's private key (PEM)."),
        ),
        Key(
            "certificate_dir",
            String(
                what="a folder",
                description="Where the generated certificate is kept (relative to this file; "
                "default ~/.local/state/motionplc/opcua).",
            ),
        ),
        Key(
            "anonymous",
            Bool(
                default_text="true",
                description="Anonymous sessions are allowed (read, browse and subscribe only).",
            ),
        ),
        Key(
            "users",
            MapOf(
                value=USER,
                description="The operators by user name.",
                example={"alice": {"password_hash": "scrypt$16384$8$1$c2FsdA==$aGFzaA=="}},
            ),
        ),
        Key(
            "publish_interval",
            Number(
                gt=0.0,
                le=10.0,
                unit="s",
                default_text="0.01",
                description="How often the cycle publishes its snapshot to the server (a "
                "multiple of the tick, rounded).",
            ),
        ),
        Key(
            "program_start",
            Choice(
                options=("auto", "operator"),
                default_text="auto",
                description="A program given to `motionplc run` starts at once (auto) or "
                "waits for the operator's Start (operator).",
            ),
        ),
    ),
)

HMI = Obj(
    title="Web HMI",
    description="The machine's live web HMI (Starlette and uvicorn in the operator process, "
    "outside the real-time process; `motionplc run --hmi`): axis positions, states and "
    "following errors, the group paths, the program's line and the cycle statistics; the "
    "operator methods behind a login with the same users and password hashes as OPC UA.",
    keys=(
        *_listen("8480"),
        Key(
            "users",
            MapOf(
                value=USER,
                description="The operators who may log in by user name (default: the users "
                "of `opcua:`).",
                example={"alice": {"password_hash": "scrypt$16384$8$1$c2FsdA==$aGFzaA=="}},
            ),
        ),
        Key(
            "anonymous",
            Bool(
                default_text="true",
                description="The page shows the live values without a login (the buttons "
                "always need one).",
            ),
        ),
        Key(
            "interval",
            Number(
                gt=0.0,
                le=10.0,
                unit="s",
                default_text="0.05",
                description="How often the page is sent the last snapshot (over a websocket).",
            ),
        ),
    ),
)
