"""Junction speeds stay consistent while moves are queued: every link of the group's chain is
entered at the speed its predecessor ends with. A run of pieces merged behind an exact corner (a
corner the corner choice stops at) starts with no speeds; a forward pass that skipped it as
unchanged left it planned from rest behind a piece ending at speed: on bench_gcode's contour the
group then went from 25 mm/s to 0 in one cycle (differenced jerk 60x the limit)."""

from __future__ import annotations

from pathlib import Path

from motionplc.config import build, load_config
from motionplc.gcode_runner import GcodeRunner, load_gcode_job

CONFIG = """runtime:
  tick: 0.001
  tasks:
    motion: {period: 0.001, priority: 1}
axes:
  x: {limits: {v_max: 1.0, a_max: 4.0, j_max: 40.0}, software_limits: {min: -1.0, max: 1.0}}
  y: {limits: {v_max: 0.8, a_max: 3.0, j_max: 30.0}, software_limits: {min: -1.0, max: 1.0}}
  z: {limits: {v_max: 0.3, a_max: 2.0, j_max: 20.0}, software_limits: {min: -0.2, max: 0.2}}
groups:
  xyz: {axes: [x, y, z], queue_depth: 64}
"""

# the first 70 moves of tools/bench_gcode.py's contour (seed 25, mm): edges of 5-20 mm, every
# third corner a tangent arc, the others sharp (blended or stopped under G64 P0.05)
CONTOUR = """%
G21 G90 G17
G64 P0.05
F6000.000
G1 X-8.391188 Y6.407006
G1 X-12.079131 Y13.890567
G1 X-17.314208 Y16.355721
G2 X-18.680245 Y17.790955 R2.739625
G1 X-26.344019 Y36.398217
G1 X-34.161921 Y37.069870
G1 X-47.101871 Y49.932643
G3 X-47.974095 Y50.614504 R4.666878
G1 X-57.476499 Y56.370349
G1 X-64.726364 Y56.898497
G1 X-78.603828 Y58.328709
G3 X-80.905251 Y57.802311 R3.668997
G1 X-87.652144 Y53.643298
G1 X-93.116241 Y43.357126
G1 X-104.306942 Y33.314860
G3 X-104.594240 Y33.013417 R2.670169
G1 X-112.639667 Y23.131644
G1 X-109.945063 Y8.530908
G1 X-109.176562 Y-0.182682
G2 X-109.333732 Y-1.578134 R3.532013
G1 X-111.826490 Y-9.299313
G1 X-110.892430 Y-25.504571
G1 X-104.334877 Y-26.459145
G2 X-102.063853 Y-27.928844 R3.245821
G1 X-98.175644 Y-34.040523
G1 X-98.326526 Y-43.512534
G1 X-95.607080 Y-48.136474
G3 X-94.846351 Y-48.928430 R2.371500
G1 X-81.343865 Y-57.618568
G1 X-71.988561 Y-66.130877
G1 X-62.646342 Y-62.222140
G3 X-62.218541 Y-62.013537 R4.146131
G1 X-50.256298 Y-55.304755
G1 X-42.208137 Y-60.599669
G1 X-33.951270 Y-53.022118
G2 X-31.781985 Y-51.856047 R4.991048
G1 X-16.080615 Y-47.948266
G1 X-12.730120 Y-42.543657
G1 X-3.301668 Y-38.882952
G3 X-1.189550 Y-36.028258 R3.324286
G1 X-0.733308 Y-29.834544
G1 X3.515486 Y-24.817310
G1 X8.573825 Y-17.955213
G2 X8.784356 Y-17.696565 R3.476766
G1 X15.671771 Y-10.018674
G1 X22.958297 Y6.129948
G1 X16.579158 Y15.514108
G2 X15.845918 Y17.211143 R4.915276
G1 X11.815391 Y35.348844
G1 X1.696393 Y50.935158
G1 X-9.849556 Y62.131598
G2 X-10.412839 Y62.796834 R4.446932
G1 X-16.481872 Y71.584099
G1 X-26.950679 Y69.652491
G1 X-38.728453 Y66.708902
G2 X-41.262588 Y67.456303 R2.605522
G1 X-44.666263 Y71.093225
G1 X-57.232412 Y67.052152
G1 X-70.432481 Y65.409052
G3 X-72.037542 Y64.812011 R3.719725
G1 X-79.041118 Y60.139032
G1 X-92.234145 Y50.173901
G1 X-99.954886 Y51.744132
G3 X-102.712439 Y51.115291 R3.430917
G1 X-108.880980 Y46.435079
G1 X-121.525183 Y41.038476
G1 X-121.101147 Y33.432059
G2 X-121.239883 Y32.288608 R3.281291
G1 X-124.754899 Y20.810555
G1 X-133.692721 Y8.873922
G1 X-132.916003 Y-5.452566
M2
%
"""


def test_every_link_is_entered_at_the_speed_its_predecessor_ends_with(tmp_path: Path) -> None:
    (tmp_path / "m.yaml").write_text(CONFIG)
    (tmp_path / "contour.ngc").write_text(CONTOUR)
    cfg = load_config(tmp_path / "m.yaml")
    job = load_gcode_job(tmp_path / "contour.ngc", cfg, "xyz")
    machine = build(cfg, realtime=False)
    try:
        g = machine.axes_groups["xyz"]
        assert g.cfg.corner_choice  # the default
        runner = GcodeRunner(job, machine)
        machine.attach(runner, job.task)
        runs = 0
        for cycle in range(80):  # the queue fills (one move per cycle, 64 deep)
            machine.runtime.run(cycles=1)
            links = g.chain.links
            runs = max(runs, sum(lk.members is not None for lk in links))
            for k in range(1, len(links)):
                assert links[k].w_in == links[k - 1].w_out, (cycle, k, len(links))
        assert len(g.chain.links) > 60 and runs > 0  # the chain is deep and has runs
        assert not runner.failures
    finally:
        machine.close()
