"""Machines of 1-16 axes for the scope's layout tests (tests/cli/test_scope_layout.py): a YAML
configuration (ideal drives, a 1 ms task) and a sequence that moves every axis, run through
``motionplc run --trace`` like a user's own machine.

With two or more axes the first ones form group ``g1`` (up to three members: x, y, z), enabled
and driven along a rectangle with blended corners and a circle; with six or more the next three
form group ``g2``, which the sequence never enables. The other axes make single-axis moves of
their own, staggered in time.
"""

from __future__ import annotations

from pathlib import Path

NAMES = ("x", "y", "z", "a", "b", "c", "u", "v", "w", "p", "q", "r", "s", "t", "e", "f")


def axis_names(n: int) -> list[str]:
    if not 1 <= n <= len(NAMES):
        raise ValueError(f"scope_rig: n = {n} (allowed: 1..{len(NAMES)})")
    return list(NAMES[:n])


def groups_of(n: int) -> dict[str, list[str]]:
    names = axis_names(n)
    out = {}
    if n >= 2:
        out["g1"] = names[: min(3, n)]
    if n >= 6:
        out["g2"] = names[3:6]
    return out


def write_machine(out: Path, n: int) -> tuple[Path, Path]:
    """Write ``machine.yaml`` and ``sequence.yaml`` for ``n`` axes into ``out``."""
    names = axis_names(n)
    groups = groups_of(n)
    axes = "\n".join(
        f"  {a}:\n    limits: {{v_max: {0.4 + 0.05 * (k % 4):.2f}, a_max: 3.0, j_max: 30.0}}"
        f"\n    following_error: 0.01"
        for k, a in enumerate(names)
    )
    grp = "".join(f"  {g}: [{', '.join(ms)}]\n" for g, ms in groups.items())
    machine = (
        "runtime:\n  tick: 0.001\n  clock: simulated\n  tasks:\n    motion: {period: 0.001}\n"
        f"axes:\n{axes}\n" + (f"groups:\n{grp}" if grp else "")
    )
    power = "\n".join(
        f"      - {{block: p{a}, type: MC_Power, axis: {a}, enable: true}}" for a in names
    )
    steps = [f"  - name: power on\n    call:\n{power}\n    timeout: 1.0"]
    grouped = set(groups.get("g1", []))
    if "g1" in groups:
        d = len(groups["g1"])

        def pt(x: float, y: float) -> str:
            return "[" + ", ".join(f"{v:g}" for v in [x, y, 0.02][:d]) + "]"

        corner = "buffer_mode: BLENDING_LOW, transition_mode: TM_MAX_CORNER_DEVIATION, "
        corner += "transition_parameter: 0.002"
        steps.append(
            "  - name: enable g1\n    call: [{block: en, type: MC_GroupEnable, group: g1}]"
        )
        rect = [(0.2, 0.0), (0.2, 0.1), (0.0, 0.1), (0.0, 0.0)]
        calls = "\n".join(
            f"      - {{block: r{i}, type: MC_MoveLinearAbsolute, group: g1, position: "
            f"{pt(x, y)}, velocity: 0.3{', ' + corner if i else ''}}}"
            for i, (x, y) in enumerate(rect)
        )
        steps.append(
            f"  - name: rectangle\n    call:\n{calls}\n"
            "    until: {done: r3, state: {g1: GROUP_STANDBY}}"
        )
    others = [a for a in names if a not in grouped]
    if others:
        calls = "\n".join(
            f"      - {{block: m{a}, type: MC_MoveAbsolute, axis: {a}, "
            f"position: {0.05 * (k + 1):g}, velocity: 0.3}}"
            for k, a in enumerate(others)
        )
        done = ", ".join(f"m{a}" for a in others)
        steps.append(
            f"  - name: single-axis moves\n    call:\n{calls}\n    until: {{done: [{done}]}}"
        )
        back = "\n".join(f"      - {{block: m{a}, position: 0.0}}" for a in others)
        steps.append(f"  - name: back\n    call:\n{back}\n    until: {{done: [{done}]}}")
    seq = "timeout: 20\nsteps:\n" + "\n".join(steps) + "\n"
    cfg, sq = out / "machine.yaml", out / "sequence.yaml"
    cfg.write_text(machine)
    sq.write_text(seq)
    return cfg, sq
