"""``python -m motionplc.operator.passwd [USER]``: read a password (twice, not echoed) and print
the ``opcua.users`` entry with its hash (``scrypt$N$r$p$SALT$HASH``)."""

from __future__ import annotations

import getpass
import sys

from motionplc.operator.settings import hash_password


def main(argv: list[str] | None = None) -> int:
    args = sys.argv[1:] if argv is None else argv
    user = args[0] if args else "operator"
    pw = getpass.getpass(f"password for {user}: ")
    if not pw:
        print("error: empty password", file=sys.stderr)  # noqa: T201
        return 2
    if getpass.getpass("again: ") != pw:
        print("error: the passwords differ", file=sys.stderr)  # noqa: T201
        return 2
    print(f"{user}: {{password_hash: '{hash_password(pw)}'}}")  # noqa: T201
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
