"""Writes the G-code corpus of this directory (our own programs, see LICENSE.md).

    python tests/gcode/corpus/make_corpus.py

The programs imitate the styles real ones use (CAM post-processor output for LinuxCNC and
Fanuc-like controls with their headers, machinists' hand-written programs with subroutines
and parameters, canned cycles, helices, a rotary A axis); every file is written here, none is
copied. Parts fit the configs/gcode mills with their G54 offset (program X, Y within +-120 mm,
Z within -25..30 mm).
"""

from __future__ import annotations

import random
from pathlib import Path

HERE = Path(__file__).resolve().parent


def f(x: float) -> str:
    s = f"{x:.4f}".rstrip("0").rstrip(".")
    return "0" if s in ("-0", "") else s


def cam_header(name: str, post: str, inch: bool = False) -> list[str]:
    units = "G20" if inch else "G21"
    return [
        "%",
        f"({name})",
        f"(Post processor: {post})",
        "(Machine: 3-axis vertical mill, LinuxCNC)",
        "(Stock: 200 x 150 x 30, origin top centre)",
        f"G17 {units} G90 G94 G40 G49 G80 G54",
        "G64 P0.01" if not inch else "G64 P0.0005",
    ]


def cam_footer() -> list[str]:
    return ["M5", "M9", "G28 G91 Z0", "G90", "M30", "%"]


def profile(rng: random.Random, n: int, feed: int, depth: float) -> list[str]:
    """A closed contour of lines and tangent arcs at a depth (CAM style, N numbers)."""
    out = []
    w, h, r = rng.uniform(30, 80), rng.uniform(20, 60), rng.uniform(3, 12)
    out.append(f"G0 X{f(-w)} Y{f(-h + r)}")
    out.append("G0 Z5")
    out.append(f"G1 Z{f(depth)} F{feed // 3}")
    out.append(f"G1 Y{f(h - r)} F{feed}")
    out.append(f"G2 X{f(-w + r)} Y{f(h)} I{f(r)} J0")
    out.append(f"G1 X{f(w - r)}")
    out.append(f"G2 X{f(w)} Y{f(h - r)} I0 J{f(-r)}")
    out.append(f"G1 Y{f(-h + r)}")
    out.append(f"G2 X{f(w - r)} Y{f(-h)} R{f(r)}")
    out.append(f"G1 X{f(-w + r)}")
    out.append(f"G2 X{f(-w)} Y{f(-h + r)} R{f(r)}")
    for _ in range(n):
        x, y = rng.uniform(-w + 2, w - 2), rng.uniform(-h + 2, h - 2)
        out.append(f"G1 X{f(x)} Y{f(y)}")
    out.append("G0 Z5")
    return out


def numbered(lines: list[str], step: int = 10) -> list[str]:
    out, n = [], step
    for ln in lines:
        if ln.startswith(("%", "(")) or not ln:
            out.append(ln)
        else:
            out.append(f"N{n} {ln}")
            n += step
    return out


def prog_cam_linuxcnc(i: int, rng: random.Random) -> str:
    lines = cam_header(f"cam_linuxcnc_{i:02d}", "LinuxCNC, generic mill")
    lines += ["(T1 D=6 CR=0 - ZMIN=-3 - flat end mill)", "T1 M6", "S12000 M3", "M8", "G43 H1"]
    for k in range(1 + i % 3):
        lines += profile(rng, 8 + 4 * k, 900, -1.0 - k)
    lines += cam_footer()
    return "\n".join(numbered(lines) if i % 2 else lines) + "\n"


def prog_cam_fanuc(i: int, rng: random.Random) -> str:
    lines = [
        "%",
        f"(FANUC-STYLE POST {i:02d} FOR LINUXCNC - NO PROGRAM NUMBER)",
        "(DATE=2026-12-01 TIME=10:00)",
        "G90 G17 G40 G80 G49",
        "G21",
        "G91 G28 Z0.",
        "G90",
        "T2 M06",
        "(DRILL 3MM)",
        "G00 G90 G54 X0. Y0. S3000 M03",
        "G43 Z25. H02 M08",
    ]
    pts = [(rng.uniform(-80, 80), rng.uniform(-60, 60)) for _ in range(6 + i % 5)]
    cyc = ["G81", "G82", "G83", "G73"][i % 4]
    extra = {"G81": "", "G82": " P0.5", "G83": " Q2.", "G73": " Q1.5"}[cyc]
    x, y = pts[0]
    lines.append(f"G99 {cyc} X{f(x)} Y{f(y)} Z-8. R2.{extra} F120.")
    for x, y in pts[1:-1]:
        lines.append(f"X{f(x)} Y{f(y)}")
    x, y = pts[-1]
    lines.append(f"G98 X{f(x)} Y{f(y)}")
    lines += ["G80", "M09", "M05", "G91 G28 Z0.", "G90", "M30", "%"]
    return "\n".join(lines) + "\n"


def prog_hand_sub(i: int, rng: random.Random) -> str:
    """Hand-written: a pocket of circles by a subroutine with parameters."""
    d = rng.uniform(8, 20)
    return (
        "\n".join(
            [
                f"(hand_{i:02d}: circular pockets by subroutine, machinist style)",
                "G21 G90 G17 G64 P0.02",
                "#<tool_r> = 3",
                f"#<depth> = -{f(rng.uniform(2, 6))}",
                "#<step> = 1",
                "o<pocket> sub",
                "  (#1 = x, #2 = y, #3 = radius)",
                "  G0 X#1 Y#2",
                "  G0 Z2",
                "  #<z> = 0",
                "  o101 while [#<z> GT #<_depth_in>]",
                "    #<z> = [#<z> - #<_step_in>]",
                "    o102 if [#<z> LT #<_depth_in>]",
                "      #<z> = #<_depth_in>",
                "    o102 endif",
                "    G1 Z#<z> F200",
                "    #<r> = [#3 - #<_r_in>]",
                "    G1 X[#1 + #<r>] F600",
                "    G3 I[-#<r>] J0",
                "    G1 X#1",
                "  o101 endwhile",
                "  G0 Z5",
                "o<pocket> endsub",
                "#<_depth_in> = #<depth>",
                "#<_step_in> = #<step>",
                "#<_r_in> = #<tool_r>",
                "G0 Z10",
                "S8000 M3",
                f"o<pocket> call [-40] [0] [{f(d)}]",
                f"o<pocket> call [40] [0] [{f(d)}]",
                f"o<pocket> call [0] [30] [{f(d * 0.7)}]",
                "M5",
                "G0 Z20",
                "M2",
            ]
        )
        + "\n"
    )


def prog_helix(i: int, rng: random.Random) -> str:
    """Thread milling / helical boring: helices with P turns and helical ramps."""
    r = rng.uniform(4, 12)
    pitch = rng.choice([0.8, 1.0, 1.25, 1.5, 2.0])
    turns = 2 + i % 6
    z0 = 2.0
    lines = [
        f"(helix_{i:02d}: helical bore r={f(r)} pitch={pitch} turns={turns})",
        "G21 G90 G17",
        "G61",
        "T1 M6",
        "G43 H1",
        "S10000 M3",
        "M7",
        f"G0 X{f(r)} Y0",
        f"G0 Z{f(z0)}",
        "F400",
        f"G{2 + i % 2} X{f(r)} Y0 I{f(-r)} J0 Z{f(z0 - pitch * turns)} P{turns}",
        f"G{2 + i % 2} I{f(-r)} J0",
        "G0 Z10",
        "G18 (a ZX-plane half circle as a check)",
        f"G0 X{f(-r)} Z5",
        f"G2 X{f(r)} Z5 I{f(r)} K0",
        "G17",
        "M9",
        "M5",
        "M30",
    ]
    return "\n".join(lines) + "\n"


def prog_engrave_4ax(i: int, rng: random.Random) -> str:
    """4-axis: wrapping lines on the A axis (degrees), mixed X/A moves."""
    lines = [
        f"(rotary_{i:02d}: 4-axis wrap engraving, A axis along X, degrees)",
        "G21 G90 G17 G94",
        "G64 P0.05",
        "T6 M6",
        "G43 H6",
        "S15000 M3",
        "G0 X-50 Y0 Z10 A0",
        "G1 Z-0.5 F200",
    ]
    a = 0.0
    for _ in range(20 + i):
        a += rng.uniform(5, 30)
        x = rng.uniform(-50, 50)
        lines.append(f"G1 X{f(x)} A{f(a)} F800")
    lines += ["G0 Z10", "G0 A0", "M5", "M2"]
    return "\n".join(lines) + "\n"


def prog_inch(i: int, rng: random.Random) -> str:
    lines = cam_header(f"inch_{i:02d}", "generic inch post", inch=True)
    lines += ["T3 M6", "S6000 M3", "G43 H3", "F30."]
    for _ in range(10):
        lines.append(f"G1 X{f(rng.uniform(-3, 3))} Y{f(rng.uniform(-2, 2))}")
        if rng.random() < 0.4:
            lines.append("G0 Z0.2")
            lines.append("G1 Z-0.05 F10.")
            lines.append("F30.")
    lines.append("G0 Z0.5")
    lines.append("G0 X0.5 Y0")
    lines.append("G2 X1.5 Y0 I0.5 J0 F20.")
    lines += cam_footer()
    return "\n".join(lines) + "\n"


def prog_grid_params(i: int, rng: random.Random) -> str:
    """Hand-written drilling grid with nested loops, numbered params and G10/G55."""
    nx, ny = 3 + i % 4, 2 + i % 3
    return (
        "\n".join(
            [
                f"(grid_{i:02d}: bolt grid {nx} x {ny} with loops, G10 L2 work offset)",
                "G21 G90 G17 G40 G49 G80",
                "G10 L2 P2 X0.15 Y0.12 Z-0.05",
                "G10 L2 P2 X150 Y120 Z-50",
                "G55",
                "T2 M6",
                "G43 H2",
                "S2500 M3",
                "M8",
                f"#1 = {nx}",
                f"#2 = {ny}",
                f"#3 = {f(rng.uniform(10, 20))}",
                "#4 = 0",
                "G0 Z10",
                "o1 while [#4 LT #2]",
                "  #5 = 0",
                "  o2 while [#5 LT #1]",
                "    G98 G81 X[#5 * #3] Y[#4 * #3] Z-6 R2 F150",
                "    #5 = [#5 + 1]",
                "  o2 endwhile",
                "  #4 = [#4 + 1]",
                "o1 endwhile",
                "G80",
                "M9",
                "M5",
                "G54",
                "G0 Z20",
                "M30",
            ]
        )
        + "\n"
    )


def prog_spiral_expr(i: int, rng: random.Random) -> str:
    """Hand-written: an Archimedean spiral of short G1 segments from expressions."""
    turns = 2 + i % 3
    return (
        "\n".join(
            [
                f"(spiral_{i:02d}: spiral of short segments from SIN/COS, naive-CAM Q merge on)",
                "G21 G90 G17",
                "G64 P0.01 Q0.005",
                "#<n> = 0",
                f"#<nmax> = {72 * turns}",
                "G0 X0 Y0 Z2",
                "G1 Z-0.5 F150",
                "F900",
                "o100 while [#<n> LE #<nmax>]",
                "  #<ang> = [#<n> * 5]",
                f"  #<rad> = [#<n> * {f(rng.uniform(0.05, 0.12))}]",
                "  G1 X[#<rad> * COS[#<ang>]] Y[#<rad> * SIN[#<ang>]]",
                "  #<n> = [#<n> + 1]",
                "o100 endwhile",
                "G0 Z5",
                "M2",
            ]
        )
        + "\n"
    )


def prog_misc(i: int, rng: random.Random) -> str:
    """Boring / tapping cycles, G92, G28.1/G30, block delete, optional stop, dwell, outputs."""
    return (
        "\n".join(
            [
                f"(misc_{i:02d}: boring and tapping cycles, G92, dwell, outputs, block delete)",
                "G21 G90 G17",
                "G28.1",
                "T5 M6",
                "G43 H5",
                "S800 M3",
                "M62 P0 (clamp with the next move)",
                "G0 X-30 Y-20 Z10",
                "G4 P0.2",
                f"G{[85, 86, 89][i % 3]} X-30 Y-20 Z-10 R2 P0.3 F60"
                if i % 3
                else "G85 X-30 Y-20 Z-10 R2 F60",
                "X30",
                "G80",
                "/M0 (check the bore - skipped with block delete on)",
                "M1 (optional stop)",
                "T4 M6",
                "G43 H4",
                "S500 M3",
                "G84 X0 Y20 Z-12 R3 F625 (M8 x 1.25 at 500 rpm)",
                "G80",
                "G92 X0 Y0",
                "G0 X5 Y5",
                "G92.1",
                "M64 P1",
                "G4 P0.1",
                "M65 P1",
                "M63 P0",
                "G0 Z10",
                "G28",
                "M5",
                "M30",
            ]
        )
        + "\n"
    )


def main() -> None:
    makers = [
        ("cam_linuxcnc", prog_cam_linuxcnc, 8),
        ("cam_fanuc", prog_cam_fanuc, 8),
        ("hand_sub", prog_hand_sub, 6),
        ("helix", prog_helix, 6),
        ("rotary", prog_engrave_4ax, 5),
        ("inch", prog_inch, 5),
        ("grid", prog_grid_params, 5),
        ("spiral", prog_spiral_expr, 4),
        ("misc", prog_misc, 6),
    ]
    n = 0
    for name, make, count in makers:
        for i in range(count):
            rng = random.Random(1000 * n + i)
            text = make(i, rng)
            (HERE / f"{name}_{i:02d}.ngc").write_text(text, encoding="utf-8")
            n += 1
    print(f"wrote {n} programs")  # noqa: T201


if __name__ == "__main__":
    main()
