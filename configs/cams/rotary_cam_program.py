"""Camming on configs/cams/rotary_cam.yaml: the drum turns at 4 rad/s, the pusher follows the
360-degree ``pusher`` cam (poly5 rise, modified-sine return) and the knife the ``knife`` cam
(read from knife.csv), both periodic. MC_CamTableSelect checks each cam against its slave's
limits at the drum's speed, MC_CamIn couples. Once in sync, every cycle the slaves' set
positions must be the cam tables at the drum's position (to rounding) for two turns (and the
pusher's cam at twice the speed would need more than the pusher's 1 m/s: slave_peaks).

Run: ``motionplc run configs/cams/rotary_cam.yaml configs/cams/rotary_cam_program.py``.
"""

import math

import numpy as np

from motionplc.blocks import MC_CamTableSelect, MC_MoveVelocity, MC_Power
from motionplc.blocks.sync import MC_CamIn

TASK = "motion"
TIMEOUT = 10.0
DRUM_SPEED = 4.0  # [rad/s]
TURNS = 2.0  # turns checked in sync

power = {name: MC_Power() for name in ("drum", "pusher", "knife")}
drum = MC_MoveVelocity()
select = {name: MC_CamTableSelect() for name in ("pusher", "knife")}
cam_in = {name: MC_CamIn() for name in ("pusher", "knife")}


def setup(ctx):
    ctx.vars["checked"] = 0
    ctx.vars["max_error"] = 0.0
    ctx.vars["t_sync"] = None


def program(ctx):
    axes = ctx.axes
    for name, p in power.items():
        p(axis=axes[name], enable=True)
    if not all(p.status for p in power.values()):
        return
    drum(axis=axes["drum"], execute=True, velocity=DRUM_SPEED)
    if not drum.in_velocity:
        return
    for name in ("pusher", "knife"):
        sel = select[name]
        sel(master=axes["drum"], slave=axes[name], cam_table=ctx.machine.cams[name], execute=True)
        if sel.error:
            ctx.fail(f"MC_CamTableSelect {name}: {sel.error_text}")
            return
        cam_in[name](
            master=axes["drum"], slave=axes[name], cam_table_id=sel.cam_table_id, execute=True
        )
        if cam_in[name].error:
            ctx.fail(f"MC_CamIn {name}: {cam_in[name].error_text}")
            return
    if not all(c.in_sync for c in cam_in.values()):
        return
    if ctx.vars["t_sync"] is None:
        ctx.vars["t_sync"] = ctx.t
    x = math.fmod(axes["drum"].p, 2 * math.pi)
    for name in ("pusher", "knife"):
        want = ctx.machine.cams[name].sample(np.array([x])).y[0]
        err = abs(axes[name].p - want)
        ctx.vars["max_error"] = max(ctx.vars["max_error"], err)
    ctx.vars["checked"] += 1
    if ctx.t - ctx.vars["t_sync"] >= TURNS * 2 * math.pi / DRUM_SPEED:
        ctx.expect("max |slave - cam(drum)| [m]", ctx.vars["max_error"], 0.0, within=1e-9)
        # the pusher's cam at twice the drum speed needs more than the pusher's 1 m/s
        pusher = ctx.machine.cams["pusher"]
        ctx.expect("pusher needs [m/s] at 8 rad/s", pusher.slave_peaks(8.0).v > 1.0, True)
        ctx.done()
