"""Telescope mount tracking a moving target (seed 003), for configs/telescope.yaml.

The target (a satellite-like pass: azimuth rate growing, altitude rising and falling) is
"measured" every cycle as a kinematic state. A planning Tracker per axis plans the jerk-limited
meeting with the target and then follows it; the axes follow the Tracker's commanded velocity
with a small position correction through MC_MoveVelocity (re-triggered every second cycle).
After the slew the pointing error must stay below 0.1 mrad. (The FB library has no
synchronised set-point block yet; velocity re-commanding limits the accuracy.)
"""

import math

from motionplc.blocks import Direction, MC_MoveVelocity, MC_Power
from motionplc.planning import Limits, State, Tracker

TASK = "tracking"
TIMEOUT = 30.0
T_END = 20.0  # [s] end of the observation
T_SETTLED = 10.0  # [s] the error is checked from here on
MAX_ERROR = 1e-4  # [rad] (about 20 arcsec; limited by the velocity interface, see below)
GAIN = 5.0  # [1/s] position correction
LOOKAHEAD = 0.004  # [s] acceleration feed-forward: the velocity is re-commanded every 4 ms

power = {name: MC_Power() for name in ("az", "alt")}
jog = {name: MC_MoveVelocity() for name in ("az", "alt")}


def target(name: str, t: float) -> State:
    """Target position, velocity and acceleration at time t."""
    if name == "az":  # 0.8 rad + slowly accelerating azimuth rate
        return State(0.8 + 0.01 * t + 0.0002 * t * t, 0.01 + 0.0004 * t, 0.0004)
    w = 2 * math.pi / 60.0  # altitude: 0.6 rad +- 0.1 rad, period 60 s
    return State(
        0.6 + 0.1 * math.sin(w * t),
        0.1 * w * math.cos(w * t),
        -0.1 * w * w * math.sin(w * t),
    )


def setup(ctx):
    ctx.vars["trackers"] = {}
    ctx.vars["max_error"] = 0.0


def program(ctx):
    trackers = ctx.vars["trackers"]
    ready = True
    for name, axis in ctx.axes.items():
        power[name](axis=axis, enable=True)
        ready = ready and power[name].status
    if not ready:
        return
    for name, axis in ctx.axes.items():
        if name not in trackers:
            cfg = axis.cfg
            lim = Limits(v_max=0.9 * cfg.v_max, a_max=0.9 * cfg.a_max, j_max=0.9 * cfg.j_max)
            trackers[name] = Tracker(lim, ctx.dt, State(axis.p, axis.v, axis.a), mode="replan")
        ref = trackers[name].update(target(name, ctx.t))
        v_cmd = ref.v + LOOKAHEAD * ref.a + GAIN * (ref.p - axis.p)
        v_cmd = max(-axis.cfg.v_max, min(axis.cfg.v_max, v_cmd))
        jog[name](
            axis=axis,
            execute=ctx.cycle % 4 == 0,  # a rising edge every second task cycle
            velocity=abs(v_cmd),
            direction=Direction.POSITIVE if v_cmd >= 0 else Direction.NEGATIVE,
        )
        if ctx.t >= T_SETTLED:
            err = abs(axis.p - target(name, ctx.t).p)
            ctx.vars["max_error"] = max(ctx.vars["max_error"], err)
    if ctx.t >= T_END:
        ctx.expect("max pointing error [rad]", ctx.vars["max_error"], 0.0, within=MAX_ERROR)
        ctx.done()
