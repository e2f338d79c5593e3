#!/usr/bin/env bash
# Create the kernel-local virtual CAN interface used by the socketcan tests (needs root and a
# kernel with CONFIG_CAN_VCAN). vcan traffic never leaves the machine.
#   tools/setup_vcan.sh            create and bring up vcan0
#   tools/setup_vcan.sh vcan1      another name
#   tools/setup_vcan.sh --remove   delete vcan0
# Then: FB_TEST_VCAN=vcan0 python -m pytest tests/fieldbus -rs
set -euo pipefail
if [[ "${1:-}" == "--remove" ]]; then
    ip link del "${2:-vcan0}"
    exit 0
fi
dev="${1:-vcan0}"
if [[ -e "/sys/class/net/${dev}" ]]; then
    echo "${dev} already exists"
else
    modprobe vcan 2>/dev/null || true
    if ! ip link add dev "${dev}" type vcan; then
        echo "cannot create ${dev}: this kernel has no vcan support (CONFIG_CAN_VCAN);" \
             "the vcan tests will be skipped" >&2
        exit 2
    fi
fi
ip link set up "${dev}"
echo "${dev} is up; run: FB_TEST_VCAN=${dev} python -m pytest tests/fieldbus -rs"
